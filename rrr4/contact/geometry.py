"""Kinematics of a revolute clearance joint (Flores & Ambrosio 2004, Comput. Struct. 82,
eq. 1-12; Flores et al. 2011, Kinematics and Dynamics of Multibody Systems with Imperfect
Joints, ch. 3).

The scene names the body that carries the journal (:attr:`rrr4.scene.JointSpec.journal_body`;
in an n-RRR the outboard body, further from ground); the other body carries the bearing.
The eccentricity is e = r_journal - r_bearing, the gap between the joint's points.

- n = e / |e| (contact normal, bearing -> journal), t = E n (tangent, n rotated by +90 deg);
- penetration delta = |e| - c, c = R_B - R_J; contact while delta > 0;
- contact points P_J = r_J + R_J n, P_B = r_B + R_B n;
- normal velocity delta_dot = (v_PJ - v_PB) . n = e_dot . n (the rotation terms are along t);
- tangential velocity v_t = (v_PJ - v_PB) . t = e_dot . t + R_J omega_J - R_B omega_B.

All expressions are CasADi SX; lengths in m, velocities in m/s, angular rates in rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ..mechanism.model import perp

# |e| is evaluated as sqrt(e.e + (EPS_REL c)^2) so that n stays finite for a centred journal.
EPS_REL = 1e-6


@dataclass(frozen=True)
class ClearanceKinematics:
    """Symbolic contact kinematics of one clearance joint (shapes: vectors (2,), scalars)."""
    eccentricity: ca.SX    # e (2,) [m]
    normal: ca.SX          # n (2,)
    tangent: ca.SX         # t (2,)
    penetration: ca.SX     # delta [m], > 0 in contact
    delta_dot: ca.SX       # [m/s], > 0 while approaching
    v_t: ca.SX             # tangential slip velocity of the journal contact point [m/s]


def clearance_kinematics(e, e_dot, omega_bearing, omega_journal, journal_radius: float,
                         bearing_radius: float) -> ClearanceKinematics:
    """Contact kinematics from eccentricity e (2,) and its rate e_dot (2,), the angular
    rates [rad/s] of the bearing (inboard) and journal (outboard) bodies and the radii [m]."""
    c = bearing_radius - journal_radius
    norm_e = ca.sqrt(ca.dot(e, e) + (EPS_REL * c) ** 2)
    n = e / norm_e
    t = perp(n)
    delta = norm_e - c
    delta_dot = ca.dot(e_dot, n)
    v_t = ca.dot(e_dot, t) + journal_radius * omega_journal - bearing_radius * omega_bearing
    return ClearanceKinematics(e, n, t, delta, delta_dot, v_t)


def contact_generalized_forces(k: ClearanceKinematics, f_n, f_t, g_bearing, g_journal, i_bearing: int,
                               i_journal: int, journal_radius: float, bearing_radius: float, nq: int):
    """Generalised forces Q (nq,) of one contact and the force on the journal (2,) [N].

    The journal (outboard body) receives f = -f_n n + f_t t at P_J; the bearing (inboard
    body) receives -f at P_B (Newton's third law). g_* (2 x nq) are the Jacobians of the
    joint centres r_B, r_J with respect to q (they carry the moment arm from each centre of
    mass to the joint centre); i_* index the bodies' rotation coordinates; the offsets
    R n add the moments R_J f_t on the journal and -R_B f_t on the bearing.
    """
    f = -f_n * k.normal + f_t * k.tangent
    Q = g_journal.T @ f - g_bearing.T @ f
    arm = ca.SX.zeros(nq, 1)  # SX: the radii may be symbols (the contact parameters)
    if i_journal is not None:  # None: the ground carries it
        arm[i_journal] += journal_radius
    if i_bearing is not None:
        arm[i_bearing] -= bearing_radius
    return Q + arm * f_t, f
