"""The result of :func:`rrr4.simulate`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..checks import unknown_value
from ..problem import Problem
from ..scene import Scene
from .verdict import Verdict, energy_verdict

__all__ = ["Simulation"]


@dataclass(frozen=True)
class Simulation:
    """Result of :func:`simulate`. N output instants (t = 0 included), nc clearance joints.

    t (N,) [s]; q, qd, qdd (N, nq); pose, pose_ref (N, 3) [m, m, rad] of the task body (zeros
    without one); platform_error (N,) [m] (position distance to the commanded path); tau
    (N, n) [N m or N]; contact_force (N, nc, 2) [N] on the journal body, global frame (the
    reaction convention when the journal sits on the joint's second body, as in every
    n-RRR); normal_force (N, nc) [N]; friction_force (N, nc) [N]: the dry friction force on
    the journal along the tangent t (the contact normal e/|e| rotated by +90 deg), so that
    contact_force = -normal_force n + friction_force t (+ film_force); eccentricity (N, nc,
    2) [m]; penetration (N, nc) [m];
    reaction (N, k, 2) [N] of the k ideal passive revolute joints (force of the first body
    on the second); driver_effort (N, n_drivers) [N m or N]; contact_loss_events: passive
    joint -> count of contact -> free-flight transitions (0 for ideal joints); energy: dict of (N,) arrays [J] (see
    :mod:`rrr4.dynamics.energy`); energy_audit_residual = max |W_in - dE - D| / largest
    energy term; extremes: over every integrator step (and the start), whatever the output
    rate: normal_force_max, normal_force_min, penetration_max (nc,) [N, N, m] per clearance
    joint and, in torque mode, tau_abs_max (n,) [N m or N] per actuator (see
    :func:`rrr4.simulation.system.extremes`); film_force (N, nc, 2) [N]: the oil film's share
    of contact_force (zeros at dry joints; :mod:`rrr4.contact.lubrication`); stats: solver
    statistics (method, step, steps, graph sizes; wall_time [s]: the stepping, without making
    its frame inputs, input_time [s], or its outputs, output_time [s]); wear: at the joints
    that wear (``effects.wear``), joint -> surface ('bearing', 'journal') -> the node depths
    (M,) [m] worn over the run, Archard's law integrated at every step
    (:mod:`rrr4.contact.wear`; empty without wear).
    :meth:`body` gives the (N, 3) pose of any body; :attr:`verdict` whether the run has
    converged (its energy audit, :mod:`rrr4.simulation.verdict`).
    """
    scene: Scene
    clearance_joints: tuple[str, ...]
    ideal_passive_joints: tuple[str, ...]
    terms: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    pose: np.ndarray
    pose_ref: np.ndarray
    platform_error: np.ndarray
    tau: np.ndarray
    contact_force: np.ndarray
    normal_force: np.ndarray
    eccentricity: np.ndarray
    penetration: np.ndarray
    reaction: np.ndarray
    driver_effort: np.ndarray
    contact_loss_events: dict
    energy: dict
    energy_audit_residual: float
    extremes: dict
    stats: dict = field(default_factory=dict)
    film_force: np.ndarray | None = None
    friction_force: np.ndarray | None = None
    wear: dict = field(default_factory=dict)

    @property
    def verdict(self) -> Verdict:
        """The energy audit's verdict on this run: converged or not, and the numbers behind it."""
        return energy_verdict(self.energy)

    def body(self, name: str) -> np.ndarray:
        """(N, 3) pose [x, y, theta] [m, m, rad] of the centre of mass of the body `name`."""
        model = Problem.from_scene(self.scene).model
        if name not in model.body_names:
            raise unknown_value("body", "body", name, model.body_names)
        return model.body_poses(self.q, name)
