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

import functools

import casadi as ca

from ..mechanism import Mechanism
from ..mechanism import kinematics as kin
from ..scene import Scene

__all__ = ["inverse_dynamics_function", "joint_reactions_function"]

# |T_i| = l_i1 |sin(transmission angle)| below this [m] is treated as a serial singularity.
_SERIAL_EPS = 1e-12


def _as_model(model: Mechanism | Scene, gravity):
    """(Mechanism, gravity (2,) [m/s^2]) from a Mechanism or a Scene (whose gravity is used)."""
    if isinstance(model, Scene):
        g = model.effects.gravity if gravity is None else gravity
        return Mechanism.from_scene(model), tuple(float(v) for v in g)
    return model, tuple(float(v) for v in (gravity or (0.0, 0.0)))


def _guarded(x, eps):
    """x pushed away from zero to |x| >= eps, keeping its sign (sign(0) := +1)."""
    return ca.if_else(x >= 0, 1.0, -1.0) * ca.fmax(ca.fabs(x), eps)


@functools.cache
def _build(mech: Mechanism, gravity: tuple[float, float]) -> ca.Function:
    data, n = mech.data, mech.n
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    q, _, qdd = mech.body_motion_function(pose, pose_d, pose_dd)
    g = ca.DM(gravity)
    qo, ao = q[6 * n: 6 * n + 3], qdd[6 * n: 6 * n + 3]

    e, T, t0, rC_fixed, f2, fA = [], [], [], [], [], []
    for i, c in enumerate(data.chains):
        q1, q2 = q[6 * i: 6 * i + 3], q[6 * i + 3: 6 * i + 6]
        a1, a2 = qdd[6 * i: 6 * i + 3], qdd[6 * i + 3: 6 * i + 6]
        m1, I1, m2, I2 = c.driving.mass, c.driving.inertia, c.following.mass, c.following.inertia
        A = ca.DM(c.base)
        B = q1[0:2] + 0.5 * c.driving.length * kin.unit(q1[2])
        C = q2[0:2] + 0.5 * c.following.length * kin.unit(q2[2])
        ei = (C - B) / c.following.length
        # following link: r_B = r_C + m2 (a2 - g); moment about its CoM fixes the normal part p of r_C
        f2i = m2 * (a2[0:2] - g)
        p = (kin.cross(B - q2[0:2], f2i) - I2 * a2[2]) / c.following.length
        rC_fixed.append(p * kin.perp(ei))
        f2.append(f2i)
        # driving link, moment about the fixed pivot A_i: tau = I1 al1 + (G1 - A) x m1 (a1 - g) + (B - A) x r_B
        t0.append(I1 * a1[2] + kin.cross(q1[0:2] - A, m1 * (a1[0:2] - g)) + kin.cross(B - A, p * kin.perp(ei) + f2i))
        T.append(kin.cross(B - A, ei))
        fA.append(m1 * (a1[0:2] - g))
        e.append(ei)
    T = ca.vertcat(*T)
    Ts = _guarded(T, _SERIAL_EPS)
    t0 = ca.vertcat(*t0)

    # platform Newton-Euler with the axial parts s_i of r_C as unknowns: W s = w0
    Co = [kin.platform_point(data, i, qo) - qo[0:2] for i in range(n)]
    sum_f = sum(rC_fixed[1:], rC_fixed[0])
    sum_m = sum(kin.cross(Co[i], rC_fixed[i]) for i in range(n))
    w0 = ca.vertcat(data.platform.mass * (ao[0:2] - g) - sum_f, data.platform.inertia * ao[2] - sum_m)
    JT = ca.horzcat(*[ca.vertcat(e[i], kin.cross(Co[i], e[i])) / Ts[i] for i in range(n)])  # = J^T
    tau_p = JT.T @ ca.solve(JT @ JT.T, w0 + JT @ t0)
    if n == 4:
        tau_n = mech.null_space_function(pose)
    else:  # no redundancy: an empty family
        tau_n = ca.SX(n, 0)
    m = tau_n.shape[1]

    def reactions(tau, particular: bool):
        """Reactions (2, 3n) ordered A1..An, B1..Bn, C1..Cn for torques tau (n,)."""
        rA, rB, rC = [], [], []
        for i in range(n):
            s = (tau[i] - (t0[i] if particular else 0)) / Ts[i]
            rc = s * e[i] + (rC_fixed[i] if particular else 0)
            rb = rc + (f2[i] if particular else 0)
            rA.append(rb + (fA[i] if particular else 0))
            rB.append(rb)
            rC.append(rc)
        return ca.horzcat(*rA, *rB, *rC)

    r_p = reactions(tau_p, True)
    r_n = ca.horzcat(*[reactions(tau_n[:, k], False) for k in range(m)]) if m else ca.SX(2, 0)
    return ca.Function("joint_reactions", [pose, pose_d, pose_dd], [tau_p, tau_n, r_p, r_n, T],
                       ["pose", "pose_d", "pose_dd"], ["tau_p", "tau_n", "r_p", "r_n", "transmission"])


def joint_reactions_function(model: Mechanism | Scene, gravity=None) -> ca.Function:
    """SX Function 'joint_reactions': pose (3), pose_d (3), pose_dd (3) ->
    tau_p (n,) [N m], tau_n (n, n-3), r_p (2, 3n) [N], r_n (2, 3n (n-3)) [N],
    transmission (n,) [m] = (B_i - A_i) x e_i (0 at a serial singularity).

    Reactions of all 3n ideal joints A1..An, B1..Bn, C1..Cn; column j + 3n k of r_n
    belongs to null-space direction k. gravity (2,) [m/s^2] defaults to the scene's
    (or none for a bare Mechanism).
    """
    return _build(*_as_model(model, gravity))


@functools.cache
def _passive(mech: Mechanism, gravity: tuple[float, float]) -> ca.Function:
    n = mech.n
    f = _build(mech, gravity)
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    tau_p, tau_n, r_p, r_n, _ = f(pose, pose_d, pose_dd)
    m = tau_n.shape[1]
    passive = list(range(n, 3 * n))
    r_n_passive = ca.horzcat(*[r_n[:, [3 * n * k + j for j in passive]] for k in range(m)]) if m else ca.SX(2, 0)
    return ca.Function("inverse_dynamics", [pose, pose_d, pose_dd], [tau_p, tau_n, r_p[:, passive], r_n_passive],
                       ["pose", "pose_d", "pose_dd"], ["tau_p", "tau_n", "r_p", "r_n"])


def inverse_dynamics_function(model: Mechanism | Scene, gravity=None) -> ca.Function:
    """SX Function 'inverse_dynamics': pose (3) [m, m, rad], pose_d (3), pose_dd (3) ->
    tau_p (n,) [N m], tau_n (n, n-3), r_p (2, 2n) [N], r_n (2, 2n (n-3)) [N].

    Passive joints only, ordered B1..Bn, C1..Cn; column j + 2n k of r_n belongs to
    null-space direction k. For the 4-RRR: tau = tau_p + alpha tau_n and
    r_j = r_p[:, j] + alpha r_n[:, j], with tau_n = ``Mechanism.null_space(pose)``.
    r_j is the force the inboard body exerts on the outboard body (= -lambda_j).
    Pass a Scene to include its gravity, or gravity (2,) [m/s^2] explicitly.
    Built once per (mechanism, gravity) and cached.
    """
    return _passive(*_as_model(model, gravity))
