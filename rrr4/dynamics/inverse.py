"""Inverse dynamics of the ideal n-RRR along a platform motion: the affine family of
actuator torques and joint reactions that realises it.

Equations of motion (Zhang & Zhang 2017, eq. 5; Nikravesh 1988, ch. 6):
``M qdd + Phi_q^T lambda = Q_g + B tau`` with all 3n joints ideal. Given the platform
motion, q, qd, qdd follow from the closed-form IK; the 6n + 3 equations then fix the
7n unknowns (2 per joint, 1 per actuator) up to n - 3 free parameters alpha:

    tau = tau_p + tau_n alpha,        r_j = r_p[:, j] + r_n[:, j, :] alpha.

The solution is built chain by chain (Newton-Euler per body, no linear solve of the
27-coordinate system):

- following link i2 (B -> C, unit e_i): its moment balance fixes the reaction component
  normal to the link; the axial component s_i is free;
- driving link i1, moment about A_i: tau_i = t0_i + T_i s_i with T_i = (B_i - A_i) x e_i;
- platform: W s = w0 (3 equations) with W = [e_i; (C_i - o) x e_i]. Since
  W diag(1/T) = J^T (Jacobian of :class:`~rrr4.Mechanism`), in torques this reads
  J^T tau = w0 + J^T t0.

tau_p is the minimum-norm solution, tau_p = J (J^T J)^-1 (w0 + J^T t0), so tau_p is
orthogonal to tau_n; tau_n is ``Mechanism.null_space`` (unit, J^T tau_n = 0). The
null-space reactions are pure axial forces in the following links:
r_n[:, B_i] = r_n[:, C_i] = (tau_n,i / T_i) e_i.

Reaction convention (project-wide): r_j [N, global frame] is the force the inboard body
exerts on the outboard body of joint j, i.e. r_j = -lambda_j for Phi = gap.
"""

from __future__ import annotations

import casadi as ca

from ..mechanism import Mechanism
from ..mechanism import kinematics as kin

__all__ = ["inverse_dynamics_function", "joint_reactions_function", "actuator_motion_function"]

def _actuator_motion(mech: Mechanism) -> ca.Function:
    pose, pose_d, shift = ca.SX.sym("pose", 3), ca.SX.sym("pose_d", 3), ca.SX.sym("shift", 2, mech.n)
    cs = (ca.cos(pose[2]), ca.sin(pose[2]))
    u1s, rates = [], []
    for i, c in enumerate(mech.data.chains):
        u1, e, _, Cd_rel, _, _ = kin.chain_motion(c, pose[0:2] - shift[:, i], pose_d[2], 0, cs)
        u1s.append(u1)
        rates.append(kin.link_rates(c, u1, e, pose_d[0:2] + Cd_rel, kin.transmission(c, u1, e)[2])[0])
    return ca.Function("actuator_motion", [pose, pose_d, shift], [ca.horzcat(*u1s), ca.vertcat(*rates)],
                       ["pose", "pose_d", "shift"], ["driving_direction", "theta_d"])


def actuator_motion_function(mech: Mechanism) -> ca.Function:
    """SX Function 'actuator_motion': pose (3) [m, m, rad], pose_d (3), shift (2, n) [m] ->
    driving_direction (2, n) [-] = [cos theta_i, sin theta_i] of the IK actuator angles in
    the scene's working modes, theta_d (n,) [rad/s] = J pose_d, with chain i's platform
    point moved by -shift[:, i] (0 for the ideal chain; the sum of a chain's joint gaps for
    journals off-centre, see :func:`rrr4.mechanism.kinematics.chain_ik`), held fixed in the rate.

    The same closed-form expressions as the inverse dynamics (no trigonometry of the
    angles), so a controller built from both shares them. Built once per mechanism (cached on
    it, :meth:`rrr4.Mechanism.memo`).
    """
    return mech.memo(("actuator_motion",), lambda: _actuator_motion(mech))


def _platform_wrench(loads, pose):
    """Force (2,) [N] and moment about the platform's centre [N m] of constant loads
    (point, (fx, fy), tz, in_body_frame) on it."""
    f, m = ca.SX.zeros(2), ca.SX(0)
    R = ca.vertcat(ca.horzcat(ca.cos(pose[2]), -ca.sin(pose[2])), ca.horzcat(ca.sin(pose[2]), ca.cos(pose[2])))
    for point, force, torque, body in loads:
        fi = R @ ca.DM(force) if body else ca.DM(force)
        f += fi
        m += kin.cross(R @ ca.DM(point), fi) + torque
    return f, m


def _reactions(mech: Mechanism, gravity: tuple[float, float], loads: tuple) -> ca.Function:
    """:func:`joint_reactions_function`, built once per mechanism, gravity and loads (cached on
    the mechanism: it lives as long as the mechanism does)."""
    return mech.memo(("joint_reactions", gravity, loads), lambda: _build(mech, gravity, loads))


def _build(mech: Mechanism, gravity: tuple[float, float], loads: tuple = ()) -> ca.Function:
    data, n = mech.data, mech.n
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    g = ca.DM(gravity)
    cs = (ca.cos(pose[2]), ca.sin(pose[2]))
    ao = pose_dd

    e, T, Ts, inv_T, t0, rC_fixed, f2, fA, Co = [], [], [], [], [], [], [], [], []
    for c in data.chains:
        m1, I1, m2, I2 = c.driving.mass, c.driving.inertia, c.following.mass, c.following.inertia
        l1, l2 = c.driving.length, c.following.length
        A = ca.DM(c.base)
        u1, ei, Coi, Cd_rel, Cdd_rel, B = kin.chain_motion(c, pose[0:2], pose_d[2], pose_dd[2], cs)
        # link rates from C_d = l1 w1 E u1 + l2 w2 E e (and its derivative), T = l1 (u1 x e)
        Ti, Tsi, inv_Ti = kin.transmission(c, u1, ei)
        w1, w2 = kin.link_rates(c, u1, ei, pose_d[0:2] + Cd_rel, inv_Ti)
        al1, al2 = kin.link_rates(c, u1, ei, pose_dd[0:2] + Cdd_rel + l1 * w1**2 * u1 + l2 * w2**2 * ei, inv_Ti)
        aB = l1 * (al1 * kin.perp(u1) - w1**2 * u1)
        a1 = 0.5 * aB  # centre of mass of the driving link
        a2 = aB + 0.5 * l2 * (al2 * kin.perp(ei) - w2**2 * ei)
        # following link: r_B = r_C + m2 (a2 - g); moment about its CoM fixes the normal part p of r_C
        f2i = m2 * (a2 - g)
        p = (kin.cross(-0.5 * l2 * ei, f2i) - I2 * al2) / l2
        rC_fixed.append(p * kin.perp(ei))
        f2.append(f2i)
        # driving link, moment about the fixed pivot A_i: tau = I1 al1 + (G1 - A) x m1 (a1 - g) + (B - A) x r_B
        t0.append(I1 * al1 + kin.cross(0.5 * l1 * u1, m1 * (a1 - g)) + kin.cross(B - A, p * kin.perp(ei) + f2i))
        T.append(Ti)
        Ts.append(Tsi)
        inv_T.append(inv_Ti)
        fA.append(m1 * (a1 - g))
        e.append(ei)
        Co.append(Coi)
    T, Ts, inv_T, t0 = ca.vertcat(*T), ca.vertcat(*Ts), ca.vertcat(*inv_T), ca.vertcat(*t0)

    # platform Newton-Euler with the axial parts s_i of r_C as unknowns: W s = w0
    sum_f = sum(rC_fixed[1:], rC_fixed[0])
    sum_m = sum(kin.cross(Co[i], rC_fixed[i]) for i in range(n))
    f_ext, m_ext = _platform_wrench(loads, pose)
    w0 = ca.vertcat(data.platform.mass * (ao[0:2] - g) - sum_f - f_ext, data.platform.inertia * ao[2] - sum_m - m_ext)
    W = ca.horzcat(*[ca.vertcat(e[i], kin.cross(Co[i], e[i])) for i in range(n)])
    JT = W @ ca.diag(inv_T)  # = J^T
    tau_p = JT.T @ ca.solve(JT @ JT.T, w0 + JT @ t0)
    if n == 4:
        # Mechanism.null_space (unit cofactor vector of J^T) without forming J: with
        # J^T = W diag(1/T), cof_k(J^T) = cof_k(W) T_k / prod(T)
        cof = ca.vertcat(*[(-1) ** k * ca.det(W[:, [i for i in range(4) if i != k]]) for k in range(4)]) * Ts
        tau_n = ca.sign(Ts[0] * Ts[1] * Ts[2] * Ts[3]) * cof / ca.norm_2(cof)
    else:  # no redundancy: an empty family
        tau_n = ca.SX(n, 0)
    m = tau_n.shape[1]

    def reactions(tau, particular: bool):
        """Reactions (2, 3n) ordered A1..An, B1..Bn, C1..Cn for torques tau (n,)."""
        rA, rB, rC = [], [], []
        for i in range(n):
            s = (tau[i] - (t0[i] if particular else 0)) * inv_T[i]
            rc = s * e[i] + (rC_fixed[i] if particular else 0)
            rb = rc + (f2[i] if particular else 0)
            rA.append(rb + (fA[i] if particular else 0))
            rB.append(rb)
            rC.append(rc)
        return ca.horzcat(*rA, *rB, *rC)

    r_p = reactions(tau_p, True)
    r_n = ca.horzcat(*[reactions(tau_n[:, k], False) for k in range(m)]) if m else ca.SX(2, 0)
    return ca.Function("joint_reactions", [pose, pose_d, pose_dd], [tau_p, tau_n, r_p, r_n, T, JT.T],
                       ["pose", "pose_d", "pose_dd"], ["tau_p", "tau_n", "r_p", "r_n", "transmission", "J"])


def joint_reactions_function(mech: Mechanism, gravity=(0.0, 0.0), loads: tuple = ()) -> ca.Function:
    """SX Function 'joint_reactions': pose (3), pose_d (3), pose_dd (3) ->
    tau_p (n,) [N m], tau_n (n, n-3), r_p (2, 3n) [N], r_n (2, 3n (n-3)) [N],
    transmission (n,) [m] = (B_i - A_i) x e_i (0 at a serial singularity), J (n, 3): the
    Jacobian d theta = J d pose (from the same expressions, no angles).

    Reactions of all 3n ideal joints A1..An, B1..Bn, C1..Cn; column j + 3n k of r_n
    belongs to null-space direction k. gravity (2,) [m/s^2] (``Problem.gravity``); loads:
    constant loads on the platform, ((x, y) [m] platform frame, (fx, fy) [N], tz [N m],
    in_body_frame), as ``Problem.platform_loads``.
    """
    return _reactions(mech, tuple(float(v) for v in gravity), tuple(loads))


def _passive(mech: Mechanism, gravity: tuple[float, float], loads: tuple = ()) -> ca.Function:
    n = mech.n
    f = _reactions(mech, gravity, loads)
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    tau_p, tau_n, r_p, r_n = f(pose, pose_d, pose_dd)[:4]
    m = tau_n.shape[1]
    passive = list(range(n, 3 * n))
    r_n_passive = ca.horzcat(*[r_n[:, [3 * n * k + j for j in passive]] for k in range(m)]) if m else ca.SX(2, 0)
    return ca.Function("inverse_dynamics", [pose, pose_d, pose_dd], [tau_p, tau_n, r_p[:, passive], r_n_passive],
                       ["pose", "pose_d", "pose_dd"], ["tau_p", "tau_n", "r_p", "r_n"])


def inverse_dynamics_function(mech: Mechanism, gravity=(0.0, 0.0), loads: tuple = ()) -> ca.Function:
    """SX Function 'inverse_dynamics': pose (3) [m, m, rad], pose_d (3), pose_dd (3) ->
    tau_p (n,) [N m], tau_n (n, n-3), r_p (2, 2n) [N], r_n (2, 2n (n-3)) [N].

    Passive joints only, ordered B1..Bn, C1..Cn; column j + 2n k of r_n belongs to
    null-space direction k. For the 4-RRR: tau = tau_p + alpha tau_n and
    r_j = r_p[:, j] + alpha r_n[:, j], with tau_n = ``Mechanism.null_space(pose)``.
    r_j is the force the inboard body exerts on the outboard body (= -lambda_j).
    gravity (2,) [m/s^2] (``Problem.gravity``; ``Problem.inverse_dynamics`` passes it);
    loads: the constant loads on the platform (as :func:`joint_reactions_function`; a
    process load on the tool), which the efforts must balance. Built once per (mechanism,
    gravity, loads), cached on the mechanism (:meth:`rrr4.Mechanism.memo`).
    """
    g, loads = tuple(float(v) for v in gravity), tuple(loads)
    return mech.memo(("inverse_dynamics", g, loads), lambda: _passive(mech, g, loads))
