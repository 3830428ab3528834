"""Archard wear of a clearance joint, accumulated on a wear profile over the bearing angle.

Archard's law (Archard 1953, J. Appl. Phys. 24; Flores 2009, Mech. Mach. Theory 44): the
wear depth grows at h_dot = k p v_slip / H at a point of the contact, k the dimensionless
wear coefficient, H [Pa] the hardness of the wearing surface, p [Pa] the contact pressure
and v_slip [m/s] the relative surface speed. Over the Hertzian line contact of a journal in
its bearing (half-width b, length L) the pressure integrates to the normal force F, so the
worn volume grows at

    V_dot = int k p v_slip / H dA = k F |v_slip| / H            (Archard's k W s / H).

The contact patch (2 b, about 0.2 mm on the reference scene) is narrower than the profile's
node spacing, so the profile keeps what its nodes resolve: the depth rate is spread onto the
profile's coefficients with the weights of its basis at the contact direction psi, so that
the profile's volume L R int w dpsi grows at exactly V_dot.

The profile: a periodic cubic B-spline over the surface's angle with M coefficients c_i [m] on
the nodes psi_i = 2 pi i / M: w(psi) = sum c_i B_i(psi), B_i >= 0, sum 1, each of integral
2 pi / M, so the volume is L R (2 pi / M) sum c_i; w and its slope are continuous (C2), so the
worn surface's normal is too (a piecewise-linear profile turns it abruptly at every node,
which makes a journal resting in a groove chatter). Its depth at the nodes is
(c_{i-1} + 4 c_i + c_{i+1}) / 6 (:func:`node_depths`). The worn clearance in the
journal's direction is c(psi) = c0 + w_bearing(psi_B) + w_journal(psi_J), psi_B and psi_J the
direction of the eccentricity in the bearing's and the journal's body frames, so the
penetration is delta = |e| - c(psi). The normal force acts along the gradient of delta (the
worn surface's normal, tilted from the line of centres by the profile's slope), so that it
derives from the contact potential K delta^(n+1) / (n+1) and the energy audit closes on a worn
profile; delta's rate is the gradient's along the motion.

Every function works on floats, numpy arrays and CasADi SX alike (except where noted).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

__all__ = ["spline_weights", "spline_slopes", "profile_depth", "depth_at", "node_depths", "archard_volume_rate",
           "node_depth_rates", "profile_volume", "line_contact_pressure", "node_angles"]


def node_angles(nodes: int) -> np.ndarray:
    """psi_i = 2 pi i / M [rad] of a profile of M nodes."""
    return 2.0 * math.pi * np.arange(nodes) / nodes


def _offsets(psi, nodes: int):
    """d_i = (psi - psi_i) / (2 pi / M), wrapped to [-M/2, M/2): the distance to node i in nodes."""
    u = psi * (nodes / (2.0 * math.pi))
    out = []
    for i in range(nodes):
        d = u - i
        out.append(d - nodes * ca.floor(d / nodes + 0.5))
    return out


def spline_weights(psi, nodes: int):
    """The M periodic cubic B-spline weights B(d_i) at angle psi [rad] (any real): >= 0, sum 1,
    non-zero at the four nodes around psi, C2 in psi. CasADi SX in, SX (M,) out."""
    out = []
    for d in _offsets(psi, nodes):
        a = ca.fabs(d)
        out.append(ca.if_else(a < 1.0, (4.0 - 6.0 * a**2 + 3.0 * a**3) / 6.0,
                              ca.if_else(a < 2.0, (2.0 - a) ** 3 / 6.0, 0.0)))
    return ca.vertcat(*out)


def spline_slopes(psi, nodes: int):
    """d B(d_i) / d psi [1/rad] (M,) of :func:`spline_weights` (continuous). CasADi SX."""
    out = []
    for d in _offsets(psi, nodes):
        a = ca.fabs(d)
        out.append(ca.if_else(a < 1.0, -2.0 * d + 1.5 * d * a,
                              ca.if_else(a < 2.0, -0.5 * ca.sign(d) * (2.0 - a) ** 2, 0.0)) * (nodes / (2.0 * math.pi)))
    return ca.vertcat(*out)


def profile_depth(coefficients, weights):
    """w(psi) = sum c_i B_i(psi) [m] from the profile's coefficients (M,) and :func:`spline_weights`
    (or, with :func:`spline_slopes`, its slope dw/dpsi [m/rad])."""
    return ca.dot(coefficients, weights)


def depth_at(coefficients, psi) -> np.ndarray:
    """The profile's depth w(psi) [m] (numpy) at the angles psi [rad] (any real)."""
    c = np.asarray(coefficients, float)
    m = len(c)
    u = np.mod(np.asarray(psi, float), 2.0 * math.pi) * (m / (2.0 * math.pi))
    k = np.floor(u).astype(int)
    f = u - k
    basis = ((1 - f) ** 3 / 6, (3 * f**3 - 6 * f**2 + 4) / 6, (-3 * f**3 + 3 * f**2 + 3 * f + 1) / 6, f**3 / 6)
    return sum(b * c[(k + j - 1) % m] for j, b in enumerate(basis))


def node_depths(coefficients) -> np.ndarray:
    """The depths w(psi_i) [m] at the nodes: (c_{i-1} + 4 c_i + c_{i+1}) / 6."""
    c = np.asarray(coefficients, float)
    return (np.roll(c, 1) + 4.0 * c + np.roll(c, -1)) / 6.0


def archard_volume_rate(coefficient, hardness, normal_force, slip_speed):
    """V_dot = k F |v_slip| / H [m^3/s]: k dimensionless, H [Pa], F [N] (>= 0), v_slip [m/s]."""
    return coefficient * normal_force * ca.fabs(slip_speed) / hardness


def node_depth_rates(volume_rate, weights, length, radius, nodes: int):
    """The coefficients' rates [m/s] (M,) that add volume_rate [m^3/s] to a profile of a surface
    of radius R [m] and length L [m]: V_dot B_i / (L R 2 pi / M)."""
    return volume_rate * weights / (length * radius * 2.0 * math.pi / nodes)


def profile_volume(coefficients, length: float, radius: float) -> float:
    """The worn volume [m^3] of a profile (its coefficients (M,) [m]): L R (2 pi / M) sum c_i."""
    c = np.asarray(coefficients, float)
    return float(length * radius * 2.0 * math.pi / len(c) * c.sum())


def line_contact_pressure(normal_force, length, journal_radius, bearing_radius, modulus):
    """The peak Hertzian pressure p_max = sqrt(F E* / (pi L R*)) [Pa] of a journal of radius
    R_J in a bearing of radius R_B > R_J (conformal line contact, 1/R* = 1/R_J - 1/R_B), F [N],
    L [m], E* [Pa] the contact modulus 1 / ((1 - nu_J^2)/E_J + (1 - nu_B^2)/E_B) (Johnson 1985,
    Contact Mechanics: two-dimensional Hertz contact of cylinders). Numpy."""
    r_star = journal_radius * bearing_radius / (bearing_radius - journal_radius)
    return np.sqrt(np.maximum(normal_force, 0.0) * modulus / (math.pi * length * r_star))
