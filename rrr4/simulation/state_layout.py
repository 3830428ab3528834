"""The layout of a simulation's flat state vector, in one place.

A simulation steps x = [t, y, z] (:class:`rrr4.integrators.System`):

- y, the continuous state: the stepped coordinates and their rates (q, qd, or the tree
  coordinates p, pd), then the quadratures: the actuators' work W_in, the damping and the
  friction dissipation, then the wear profiles' node depths (none without wear);
- z, the discrete state: per clearance joint the approach velocity at contact onset, the
  in-contact flag and the contact-loss count (the events), then the constant numbers (the
  equations' parameters, the controller's settings), then the running maxima of the peaks.

:class:`StateLayout` names each part as a slice, of y, of z, or of x; the System is built with it
(:func:`rrr4.simulation.system.system_of`) and every reader and writer of these vectors (the
initial state, the outputs, identification's shooting) goes through it, so a new state adds
its slice here once.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["StateLayout", "ENERGY"]

ENERGY = ("work_in", "damping", "friction")  # the energy quadratures, in this order, after the rates


@dataclass(frozen=True)
class StateLayout:
    """nq: the stepped coordinates; n_wear: the wear quadratures; nc: the clearance joints;
    n_parameters: the equations' parameters; n_settings: the controller's; n_peaks: the
    running maxima."""
    nq: int
    n_wear: int = 0
    nc: int = 0
    n_parameters: int = 0
    n_settings: int = 0
    n_peaks: int = 0

    # ---------------------------------------------------------------- y
    @property
    def ny(self) -> int:
        return 2 * self.nq + len(ENERGY) + self.n_wear

    @property
    def q(self) -> slice:
        return slice(0, self.nq)

    @property
    def qd(self) -> slice:
        return slice(self.nq, 2 * self.nq)

    @property
    def motion(self) -> slice:
        """q and qd together: what an initial condition sets."""
        return slice(0, 2 * self.nq)

    @property
    def energy(self) -> slice:
        return slice(2 * self.nq, 2 * self.nq + len(ENERGY))

    @property
    def wear(self) -> slice:
        return slice(2 * self.nq + len(ENERGY), self.ny)

    # ---------------------------------------------------------------- z
    @property
    def nz(self) -> int:
        return 3 * self.nc + self.n_parameters + self.n_settings + self.n_peaks

    @property
    def delta_dot0(self) -> slice:
        return slice(0, self.nc)

    @property
    def in_contact(self) -> slice:
        return slice(self.nc, 2 * self.nc)

    @property
    def losses(self) -> slice:
        return slice(2 * self.nc, 3 * self.nc)

    @property
    def events(self) -> int:
        """How many leading entries of z change at a contact event."""
        return 3 * self.nc

    @property
    def parameters(self) -> slice:
        return slice(3 * self.nc, 3 * self.nc + self.n_parameters)

    @property
    def settings(self) -> slice:
        a = 3 * self.nc + self.n_parameters
        return slice(a, a + self.n_settings)

    @property
    def peaks(self) -> slice:
        return slice(self.nz - self.n_peaks, self.nz)

    # ---------------------------------------------------------------- x = [t, y, z]
    def in_x(self, part: str) -> slice:
        """The slice of x = [t, y, z] of a part of y (q, qd, motion, energy, wear) or of z
        (delta_dot0, in_contact, losses, parameters, settings, peaks)."""
        s = getattr(self, part)
        offset = 1 if part in ("q", "qd", "motion", "energy", "wear") else 1 + self.ny
        return slice(s.start + offset, s.stop + offset)
