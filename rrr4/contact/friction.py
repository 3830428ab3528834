"""Friction laws at a clearance joint: tangential force f_t [N] on the journal along the
contact tangent t, opposing the slip velocity v_t [m/s]; f_n >= 0 [N] is the normal force.

- coulomb: f_t = -mu f_n sign(v_t);
- ambrosio: f_t = -c_d(v_t) mu f_n sign(v_t), with the dynamic correction c_d = 0 for
  |v_t| <= v0, a cubic step between v0 and v1, 1 above v1 (Ambrosio 2003, Virtual
  Nonlinear Multibody Systems, eq. 12);
- smooth: f_t = -mu f_n tanh(v_t / v0) (a tanh-regularised Coulomb law);
- stribeck: f_t = -f_n (mu + (mu_s - mu) exp(-(v_t / v_s)^2)) tanh(v_t / v0)
  (Stribeck curve with tanh regularisation; Andersson et al. 2007, Tribol. Int. 40, eq. 6).

"none" has no entry: the builder then builds no friction term at all.
Each function works on floats and on CasADi SX/MX alike.
"""

from __future__ import annotations

import casadi as ca

from ..scene import FrictionEffect
from ..scene.vocabulary import FRICTION_LAWS as FRICTION_LAW_NAMES
from ..scene.vocabulary import registry


def _coulomb(v_t, f_n, p: FrictionEffect):
    return -p.coefficient * f_n * ca.sign(v_t)


def _ambrosio(v_t, f_n, p: FrictionEffect):
    v = ca.fabs(v_t)
    s = ca.fmin(ca.fmax((v - p.v0) / (p.v1 - p.v0), 0.0), 1.0)
    c_d = s**2 * (3.0 - 2.0 * s)
    return -c_d * p.coefficient * f_n * ca.sign(v_t)


def _smooth(v_t, f_n, p: FrictionEffect):
    return -p.coefficient * f_n * ca.tanh(v_t / p.v0)


def _stribeck(v_t, f_n, p: FrictionEffect):
    mu = p.coefficient + (p.static_coefficient - p.coefficient) * ca.exp(-(v_t / p.stribeck_velocity) ** 2)
    return -mu * f_n * ca.tanh(v_t / p.v0)


# the registry, by the names of the scene's vocabulary ('none' has no entry)
FRICTION_LAWS = registry(FRICTION_LAW_NAMES, {"coulomb": _coulomb, "ambrosio": _ambrosio, "smooth": _smooth,
                                              "stribeck": _stribeck})


def friction_force(p: FrictionEffect, v_t, f_n):
    """f_t [N] of the scene's friction law (not for law 'none', which has no term)."""
    return FRICTION_LAWS[p.law](v_t, f_n, p)
