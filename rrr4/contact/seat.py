"""The journal seat: where a clearance journal rests in its bearing under a steady load.

Under a reaction r [N] (force of the joint's first body on its second) a seated journal
sits on the side of its bearing that r pushes it to, pressed in by the elastic part of the
contact law, K delta^n = f_n, and turned by friction: the contact force balances r with a
normal part f_n along -n and a tangential part f_t = mu f_n along t = E n. Then the gap
(second joint point minus first) is

    g = -(c + delta) (r + mu E r) / (sqrt(1 + mu^2) |r|),   f_n = |r| / sqrt(1 + mu^2),

whichever body carries the journal (c: radial clearance [m]). A joint carrying less than
:data:`SEAT_FORCE` has no determined seat and stays centred. This one model serves the
seated initial state of a simulation (mu = 0) and the controller's clearance compensation
(mu from the friction law at the planned slip velocity). Works on floats and CasADi
symbols alike.
"""

from __future__ import annotations

import functools

import casadi as ca

from ..scene import JointSpec
from .normal import stiffness_internal_cylinder

__all__ = ["seat_gap", "seat_gap_function", "joint_stiffness", "SEAT_FORCE"]

SEAT_FORCE = 1e-6  # [N] below this load a journal's seat is undetermined: it is taken as centred


def seat_gap(r, clearance, stiffness, exponent, mu=0.0):
    """(gap (2,) [m], normal force f_n [N]) of a journal seated under the reaction r (2,)
    [N], with radial clearance [m], contact stiffness K [N/m^n] and exponent n, and friction
    coefficient mu at the slip (0: frictionless). Symbolic (SX/MX) or numeric (returns DM)."""
    r = ca.DM(r) if not isinstance(r, (ca.SX, ca.MX, ca.DM)) else r
    f = ca.norm_2(r)
    root = ca.sqrt(1 + mu**2)
    f_n = f / root
    delta = (f_n / stiffness) ** (1.0 / exponent)
    g = -(clearance + delta) * (r + mu * ca.vertcat(-r[1], r[0])) / (root * ca.fmax(f, SEAT_FORCE))
    return ca.if_else(f > SEAT_FORCE, g, ca.DM.zeros(2)), f_n


@functools.cache
def seat_gap_function() -> ca.Function:
    """:func:`seat_gap` as an SX Function 'seat_gap': r (2,) [N], clearance [m], stiffness,
    exponent, mu -> gap (2,) [m], f_n [N]; map it over joints to seat many at once (one call
    instead of a few dozen DM operations per joint)."""
    r, c, k, n, mu = ca.SX.sym("r", 2), ca.SX.sym("clearance"), ca.SX.sym("stiffness"), ca.SX.sym("exponent"), \
        ca.SX.sym("mu")
    return ca.Function("seat_gap", [r, c, k, n, mu], list(seat_gap(r, c, k, n, mu)),
                       ["r", "clearance", "stiffness", "exponent", "mu"], ["gap", "f_n"])


def joint_stiffness(joint: JointSpec, given: float | None = None) -> float:
    """K [N/m^n] of a clearance joint: `given` (a scene's effects.contact.stiffness), else
    from its materials and radii (Lankarani-Nikravesh / Flores, internal cylinders)."""
    if given is not None:
        return given
    jm, bm = joint.journal_material, joint.bearing_material
    return stiffness_internal_cylinder(joint.journal_radius, joint.bearing_radius, jm.youngs_modulus,
                                       jm.poisson_ratio, bm.youngs_modulus, bm.poisson_ratio)
