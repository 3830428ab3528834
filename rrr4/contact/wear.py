"""Archard wear of a clearance joint, accumulated on a wear profile over the bearing angle.

Archard's law (Archard 1953, J. Appl. Phys. 24; Flores 2009, Mech. Mach. Theory 44): the
wear depth grows at h_dot = k p v_slip / H at a point of the contact, k the dimensionless
wear coefficient, H [Pa] the hardness of the wearing surface, p [Pa] the contact pressure
and v_slip [m/s] the relative surface speed. The pressure is distributed over the contact's
arc (the conformal contact of :mod:`rrr4.contact.conformal`): at its quadrature points psi_k
(spacing h = 2 pi / N), the point loads dF_k = p_k L R_B h [N] and slips v_k give the depth
rates k p_k |v_k| / H, spread onto each profile's coefficients with the weights of its basis
at the points (:func:`point_depth_rates`), so that the profile's volume L R int w dpsi grows
at exactly

    V_dot = k sum_k dF_k |v_k| / H                 (k F |v_slip| / H for a uniform slip).

The profile: a periodic cubic B-spline over the surface's angle with M coefficients c_i [m] on
the nodes psi_i = 2 pi i / M: w(psi) = sum c_i B_i(psi), B_i >= 0, sum 1, each of integral
2 pi / M, so the volume is L R (2 pi / M) sum c_i; w and its slope are continuous (C2), so the
worn surface's normal is too (a piecewise-linear profile turns it abruptly at every node,
which makes a journal resting in a groove chatter). Its depth at the nodes is
(c_{i-1} + 4 c_i + c_{i+1}) / 6 (:func:`node_depths`). The worn clearance in a
direction psi is c(psi) = c0 + w_bearing(psi - theta_B) + w_journal(psi - theta_J), each
profile read in its body's frame.

Numpy; the equations read the profile at the arc's points through
:func:`rrr4.contact.conformal.sampling_matrix`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["depth_at", "node_depths",
           "point_depth_rates", "profile_volume", "line_contact_pressure", "node_angles"]


def node_angles(nodes: int) -> np.ndarray:
    """psi_i = 2 pi i / M [rad] of a profile of M nodes."""
    return 2.0 * math.pi * np.arange(nodes) / nodes


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


def point_depth_rates(coefficient, hardness, projected, length, radius, nodes: int):
    """The coefficients' rates [m/s] (M,) of a profile of a surface of radius R [m] and length
    L [m] from the point loads times slips dF_k |v_k| [W] projected on its coefficients,
    S^T (dF |v|) (M,) (S the profile's depths at the points per coefficient, each row summing
    to 1: :func:`rrr4.contact.conformal.sampling_matrix`): k M / (2 pi H L R) S^T (dF |v|); they
    add exactly k sum dF_k |v_k| / H [m^3/s] to its volume."""
    return coefficient * nodes / (2.0 * math.pi * hardness * length * radius) * projected


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
