"""The largest stable step of the explicit fixed-step methods.

A fixed-step method applied to y' = lambda y multiplies y by its stability function R(h
lambda) each step; the step is stable while |R(h lambda)| <= 1. For the explicit methods
R is a polynomial (RK4: the Taylor polynomial of exp to degree 4), so every eigenvalue
lambda of the linearised motion bounds the step: h <= h_max(lambda), the first h along the
ray h lambda where |R| exceeds 1 (RK4: 2.785 / |lambda| on the negative real axis, 2 sqrt 2
/ |lambda| on the imaginary one). The implicit methods of this package are A-stable: no
bound.

:func:`oscillator_eigenvalues` gives the eigenvalues of the spring-damper a stiff joint
makes, m x'' + c x' + k x = 0: a journal pressed into its bearing (the contact law's
stiffness and damping at its load) or held by an oil film (the film's squeeze damping and
wedge stiffness); :mod:`rrr4.simulation.foresight` says before a run when the scene's step
exceeds the bound.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["STABILITY_POLYNOMIALS", "stability_function", "largest_stable_step", "oscillator_eigenvalues"]

# R(z) = sum_k a_k z^k of each explicit fixed-step method (the methods named in rrr4.integrators.METHODS)
STABILITY_POLYNOMIALS = {"rk4": (1.0, 1.0, 1.0 / 2.0, 1.0 / 6.0, 1.0 / 24.0)}


def stability_function(method: str, z):
    """R(z) of an explicit method (`z` = h lambda, complex, any shape)."""
    z = np.asarray(z, complex)
    return sum(a * z**k for k, a in enumerate(STABILITY_POLYNOMIALS[method]))


def _ray_bound(method: str, lam: complex) -> float:
    """The first h > 0 where |R(h lam)| > 1 (inf for lam = 0), to 1e-12 relative."""
    size = abs(lam)
    if size == 0.0:
        return math.inf
    unit = lam / size
    grid = np.linspace(1e-6, 10.0, 20001)  # |z| up to 10: beyond every explicit method's region
    out = np.abs(stability_function(method, grid * unit)) > 1.0 + 1e-12
    if not out.any():
        return math.inf
    k = int(np.argmax(out))
    lo, hi = grid[max(k - 1, 0)], grid[k]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if abs(complex(stability_function(method, mid * unit))) <= 1.0 + 1e-12 else (lo, mid)
    return lo / size


def largest_stable_step(method: str, eigenvalues) -> float | None:
    """The largest step [s] with which `method` keeps every mode y' = lambda y of
    `eigenvalues` [1/s] (Re <= 0) from growing; None for a method without such a bound (the
    implicit ones); inf when no eigenvalue bounds it."""
    if method not in STABILITY_POLYNOMIALS:
        return None
    return min((_ray_bound(method, complex(lam)) for lam in np.ravel(eigenvalues)), default=math.inf)


def oscillator_eigenvalues(mass: float, stiffness: float, damping: float) -> np.ndarray:
    """The two eigenvalues [1/s] of m x'' + c x' + k x = 0 (m > 0, k, c >= 0)."""
    return np.roots([mass, damping, stiffness]).astype(complex) if stiffness or damping else np.zeros(2, complex)
