"""Constant block-diagonal mass matrix, gravity and actuator input matrix.

With reference points at the centres of mass, M = diag(m, m, I) per body and there
are no velocity-dependent inertia terms. Body order: 11, 12, 21, 22, ..., n1, n2, o.
"""

from __future__ import annotations

import numpy as np

from ..scene import Mechanism_


def _bodies(data: Mechanism_):
    for c in data.chains:
        yield c.driving.mass, c.driving.inertia
        yield c.following.mass, c.following.inertia
    yield data.platform.mass, data.platform.inertia


def mass_matrix(data: Mechanism_) -> np.ndarray:
    """M (nq x nq) [kg, kg m^2]."""
    return np.diag([v for m, inertia in _bodies(data) for v in (m, m, inertia)])


def gravity_forces(data: Mechanism_, gravity) -> np.ndarray:
    """Q_g (nq,) [N, N, N m] for an in-plane gravity vector (2,) [m/s^2]."""
    gx, gy = gravity
    return np.array([v for m, _ in _bodies(data) for v in (m * gx, m * gy, 0.0)])


def actuator_matrix(data: Mechanism_) -> np.ndarray:
    """B (nq x n): actuator torque tau_i acts on the rotation of driving link i1."""
    n = data.n_chains
    B = np.zeros((3 * (2 * n + 1), n))
    for i in range(n):
        B[6 * i + 2, i] = 1.0
    return B
