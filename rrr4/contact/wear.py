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
nodes with the weights of the profile's interpolation at the contact direction psi, so that
the profile's volume L R int w dpsi grows at exactly V_dot.

The profile: depths w_i [m] at M nodes psi_i = 2 pi i / M over the surface's angle
(periodic), interpolated piecewise-linearly (hat functions phi_i, sum 1, continuous):
w(psi) = sum w_i phi_i(psi), volume L R (2 pi / M) sum w_i. The worn clearance in the
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

__all__ = ["hat_weights", "hat_slopes", "profile_depth", "depth_at", "archard_volume_rate", "node_depth_rates",
           "profile_volume", "line_contact_pressure", "node_angles"]


def node_angles(nodes: int) -> np.ndarray:
    """psi_i = 2 pi i / M [rad] of a profile of M nodes."""
    return 2.0 * math.pi * np.arange(nodes) / nodes


def hat_weights(psi, nodes: int):
    """The M weights phi_i(psi) of periodic piecewise-linear interpolation at angle psi [rad]
    (any real): >= 0, sum 1, at most two non-zero, continuous in psi. CasADi SX in, SX (M,) out."""
    u = psi * (nodes / (2.0 * math.pi))
    out = []
    for i in range(nodes):
        d = u - i
        d = d - nodes * ca.floor(d / nodes + 0.5)  # wrapped to [-M/2, M/2)
        out.append(ca.fmax(0.0, 1.0 - ca.fabs(d)))
    return ca.vertcat(*out)


def hat_slopes(psi, nodes: int):
    """d phi_i / d psi [1/rad] (M,) of :func:`hat_weights` (0 at the nodes themselves, where a
    piecewise-linear profile has its kinks). CasADi SX in, SX (M,) out."""
    u = psi * (nodes / (2.0 * math.pi))
    out = []
    for i in range(nodes):
        d = u - i
        d = d - nodes * ca.floor(d / nodes + 0.5)
        out.append(ca.if_else(ca.fabs(d) < 1.0, -ca.sign(d) * (nodes / (2.0 * math.pi)), 0.0))
    return ca.vertcat(*out)


def profile_depth(depths, weights):
    """w(psi) = sum w_i phi_i(psi) [m] from the node depths (M,) and :func:`hat_weights`."""
    return ca.dot(depths, weights)


def depth_at(depths, psi) -> np.ndarray:
    """The profile's depth w(psi) [m] (numpy): its node depths (M,) interpolated periodically and
    piecewise-linearly at the angles psi [rad] (any real)."""
    depths = np.asarray(depths, float)
    m = len(depths)
    return np.interp(np.mod(psi, 2.0 * math.pi), np.r_[node_angles(m), 2.0 * math.pi], np.r_[depths, depths[0]])


def archard_volume_rate(coefficient, hardness, normal_force, slip_speed):
    """V_dot = k F |v_slip| / H [m^3/s]: k dimensionless, H [Pa], F [N] (>= 0), v_slip [m/s]."""
    return coefficient * normal_force * ca.fabs(slip_speed) / hardness


def node_depth_rates(volume_rate, weights, length, radius, nodes: int):
    """The nodes' depth rates [m/s] (M,) that add volume_rate [m^3/s] to a profile of a surface
    of radius R [m] and length L [m]: V_dot phi_i / (L R 2 pi / M)."""
    return volume_rate * weights / (length * radius * 2.0 * math.pi / nodes)


def profile_volume(depths, length: float, radius: float) -> float:
    """The worn volume [m^3] of a profile (its node depths (M,) [m]): L R (2 pi / M) sum w_i."""
    depths = np.asarray(depths, float)
    return float(length * radius * 2.0 * math.pi / len(depths) * depths.sum())


def line_contact_pressure(normal_force, length, journal_radius, bearing_radius, modulus):
    """The peak Hertzian pressure p_max = sqrt(F E* / (pi L R*)) [Pa] of a journal of radius
    R_J in a bearing of radius R_B > R_J (conformal line contact, 1/R* = 1/R_J - 1/R_B), F [N],
    L [m], E* [Pa] the contact modulus 1 / ((1 - nu_J^2)/E_J + (1 - nu_B^2)/E_B) (Johnson 1985,
    Contact Mechanics: two-dimensional Hertz contact of cylinders). Numpy."""
    r_star = journal_radius * bearing_radius / (bearing_radius - journal_radius)
    return np.sqrt(np.maximum(normal_force, 0.0) * modulus / (math.pi * length * r_star))
