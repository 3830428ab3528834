"""Symbolic kinematics of a planar n-RRR mechanism (CasADi SX expressions).

Coordinates follow Zhang & Zhang (2017), eq. (3)-(4): every body has reference-point
coordinates [x, y, theta] at its centre of mass; q = [q_11, q_12, ..., q_n1, q_n2, q_o].
Link i1 (driving) runs from A_i to B_i, link i2 (following) from B_i to C_i; the platform
point C_i sits at o + r_i [cos, sin](theta_o + phi_i).
"""

from __future__ import annotations

import casadi as ca

from ..scene import NRRRSpec
from .model import perp


def unit(a):
    return ca.vertcat(ca.cos(a), ca.sin(a))


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def platform_point(data: NRRRSpec, i: int, pose):
    c = data.chains[i]
    return pose[0:2] + c.attachment_radius * unit(pose[2] + c.attachment_angle)


def chain_ik(data: NRRRSpec, i: int, pose, mode, shift=None):
    """Closed-form IK of chain i: B_i is the intersection of circle(A_i, l_i1) and
    circle(C_i - shift, l_i2); mode = +1 picks theta_i1 = atan2(C - A) + acos(...).
    shift (2,) [m] moves the target (used for journals off-centre in clearance joints).

    Returns (theta_i1, cos_arg, B_i, C_i); |cos_arg| <= 1 where the chain reaches.
    """
    c = data.chains[i]
    l1, l2 = c.driving.length, c.following.length
    a = ca.DM(c.base)
    C = platform_point(data, i, pose)
    d = C - a - (0 if shift is None else shift)
    dist2 = ca.dot(d, d)
    dist = ca.sqrt(dist2)
    cos_arg = (l1**2 + dist2 - l2**2) / (2 * l1 * dist)
    theta1 = ca.atan2(d[1], d[0]) + mode * ca.acos(cos_arg)
    B = a + l1 * unit(theta1)
    return theta1, cos_arg, B, C


def body_coordinates(data: NRRRSpec, pose, modes, eccentricity=None):
    """q (3(2n+1),) of all bodies for a platform pose, from the closed-form IK.

    eccentricity (2, 2n) [m], optional: joint gaps of B1..Bn, C1..Cn (outboard point -
    inboard point); the platform stays at `pose` and each chain closes around the gaps.
    """
    n = data.n_chains
    blocks = []
    for i, c in enumerate(data.chains):
        e_b = 0 if eccentricity is None else eccentricity[:, i]
        e_c = 0 if eccentricity is None else eccentricity[:, n + i]
        th1, _, B, C = chain_ik(data, i, pose, modes[i], None if eccentricity is None else e_b + e_c)
        start = B + e_b
        u2 = C - e_c - start
        th2 = ca.atan2(u2[1], u2[0])
        blocks += [ca.DM(c.base) + 0.5 * c.driving.length * unit(th1), th1,
                   start + 0.5 * c.following.length * unit(th2), th2]
    blocks.append(pose)
    return ca.vertcat(*blocks)


def joint_points(data: NRRRSpec, q):
    """Joint positions implied by q: for each joint the point on the inboard body
    (nearer the ground) and on the outboard body. Returns a list of
    (name, inboard_point, outboard_point), ordered A1..An, B1..Bn, C1..Cn.
    """
    n = data.n_chains
    qo = q[6 * n: 6 * n + 3]
    rows_a, rows_b, rows_c = [], [], []
    for i, c in enumerate(data.chains):
        q1 = q[6 * i: 6 * i + 3]
        q2 = q[6 * i + 3: 6 * i + 6]
        h1, h2 = 0.5 * c.driving.length, 0.5 * c.following.length
        rows_a.append((f"A{i + 1}", ca.DM(c.base), q1[0:2] - h1 * unit(q1[2])))
        rows_b.append((f"B{i + 1}", q1[0:2] + h1 * unit(q1[2]), q2[0:2] - h2 * unit(q2[2])))
        rows_c.append((f"C{i + 1}", q2[0:2] + h2 * unit(q2[2]), platform_point(data, i, qo)))
    return rows_a + rows_b + rows_c


def jacobian_parts(data: NRRRSpec, pose, modes):
    """Velocity relation of each chain: den_i * dtheta_i = a_i^T dpose, with
    a_i = [(C-B); (C-B) x (C-o)] and den_i = (C-B) . (l_i1 E u_i1).

    den_i -> 0 is a serial (type-1) singularity; rank loss of A = [a_i^T] a parallel
    (type-2) one. Returns (A (n x 3), den (n,)).
    """
    rows, dens = [], []
    for i, c in enumerate(data.chains):
        th1, _, B, C = chain_ik(data, i, pose, modes[i])
        w = C - B
        rows.append(ca.horzcat(w[0], w[1], cross(C - pose[0:2], w)))
        dens.append(ca.dot(w, c.driving.length * perp(unit(th1))))
    return ca.vertcat(*rows), ca.vertcat(*dens)


# ----------------------------------------------------------------------------- chain motion without angles

# |T_i| = l_i1 |sin(transmission angle)| below this [m] is treated as a serial singularity.
SERIAL_EPS = 1e-12


def guarded(x, eps):
    """x pushed away from zero to |x| >= eps, keeping its sign (sign(0) := +1)."""
    return ca.if_else(x >= 0, 1.0, -1.0) * ca.fmax(ca.fabs(x), eps)


def chain_motion(c, o, w_o, al_o, cs):
    """Closed-form motion of one chain for a platform motion, without angles or AD.

    c: chain data; o, w_o, al_o: platform position (2,) [m], angular rate [rad/s] and
    acceleration [rad/s^2]; cs: (cos theta_o, sin theta_o) [-]; the platform's linear
    velocity and acceleration enter through (o_d, o_dd) in the caller's C_d, C_dd.
    Returns (u1, e, Co, Cd_rel, Cdd_rel, B): unit vectors of the driving (A -> B) and
    following (B -> C) link, C - o [m] and the rotational parts of C's velocity and
    acceleration [m/s, m/s^2], and B [m].

    u1 = cos(acos k) d/|d| + mode sin(acos k) E d/|d| with d = C - A and
    k = (l1^2 + |d|^2 - l2^2)/(2 l1 |d|): the IK of :func:`chain_ik`
    written with unit vectors.
    """
    l1, l2 = c.driving.length, c.following.length
    cphi, sphi = ca.cos(c.attachment_angle), ca.sin(c.attachment_angle)
    u = ca.vertcat(cs[0] * cphi - cs[1] * sphi, cs[1] * cphi + cs[0] * sphi) * c.attachment_radius
    C = o + u
    d = C - ca.DM(c.base)
    dist2 = ca.sumsqr(d)
    inv_dist = 1 / ca.sqrt(dist2)
    k = (l1**2 - l2**2 + dist2) * inv_dist / (2 * l1)
    u1 = (k * d + c.working_mode * ca.sqrt(1 - k**2) * perp(d)) * inv_dist
    B = ca.DM(c.base) + l1 * u1
    e = (C - B) / l2
    return u1, e, u, w_o * perp(u), al_o * perp(u) - w_o**2 * u, B


def transmission(c, u1, e):
    """(T, T guarded away from 0, 1 / guarded T) [m, m, 1/m], T = (B - A) x e = l1 (u1 x e)."""
    T = c.driving.length * cross(u1, e)
    Ts = guarded(T, SERIAL_EPS)
    return T, Ts, 1 / Ts


def link_rates(c, u1, e, v, inv_T):
    """Rates (w1, w2) of the driving and following link [rad/s] with
    v = l1 w1 E u1 + l2 w2 E e (v = C_d); with v = C_dd + l1 w1^2 u1 + l2 w2^2 e, the
    angular accelerations [rad/s^2]. Dot products with e and u1, u1 x e = T / l1."""
    return ca.dot(e, v) * inv_T, -ca.dot(u1, v) * inv_T * (c.driving.length / c.following.length)
