"""Normal contact-force laws for a journal in its bearing.

All laws share F = K delta^n + (dissipative part), and every law is clamped at 0 so a
contact can push but never pull. delta [m] penetration (> 0 in contact), delta_dot [m/s]
its rate, delta_dot0 [m/s] the approach velocity captured at contact onset (a discrete
state, see :mod:`rrr4.dynamics.builder`), K [N/m^n], exponent n, c_r restitution,
damping [N s/m] (Kelvin-Voigt only). Sources of the hysteresis factors chi(c_r) in
F = K delta^n (1 + chi delta_dot / delta_dot0):

- Hunt & Crossley (1975), chi = 3 (1 - c_r) / 2;
- Lankarani & Nikravesh (1990, J. Mech. Des. 112, eq. 17), chi = 3 (1 - c_r^2) / 4;
- Flores et al. (2011, Nonlinear Dyn. 65, eq. 32), chi = 8 (1 - c_r) / (5 c_r);
- Gonthier et al. (2004, Multibody Syst. Dyn. 11, eq. 25), chi = (1 - c_r^2) / c_r.

Hertz (1882) has no dissipation; Kelvin-Voigt adds a linear dashpot, F = K delta^n + D delta_dot.
Each function works on floats and on CasADi SX/MX alike.
"""

from __future__ import annotations

import casadi as ca

from ..scene.vocabulary import CONTACT_LAWS, registry

# Floor [m/s] of the captured approach velocity delta_dot0 (grazing / persistent contact).
V_MIN = 1e-3


def _pos(x):
    return ca.fmax(x, 0.0)


def hysteresis_factor(law: str, c_r):
    """chi(c_r) of the hysteresis-damping laws; 0 for Hertz; None for Kelvin-Voigt."""
    if law == "hertz":
        return 0.0
    if law == "hunt-crossley":
        return 1.5 * (1.0 - c_r)
    if law == "lankarani-nikravesh":
        return 0.75 * (1.0 - c_r**2)
    if law == "flores":
        return 1.6 * (1.0 - c_r) / c_r
    if law == "gonthier":
        return (1.0 - c_r**2) / c_r
    if law == "kelvin-voigt":
        return None
    raise KeyError(law)


def power(x, n):
    """x^n for x >= 0, as products and one sqrt when 2n is an integer (Hertz's 1.5, its
    potential's 2.5): a pow costs several times a product and a sqrt in the compiled RHS.
    The sqrt's argument is floored at 1e-300 so that its derivative stays finite at x = 0
    (x sqrt(x) differentiates to 0/0 there; the value is unchanged, 0)."""
    twice = 2 * float(n)
    if twice == int(twice) and 0 < twice <= 8:
        whole, half = divmod(int(twice), 2)
        out = ca.sqrt(ca.fmax(x, 1e-300)) if half else None
        for _ in range(whole):
            out = x if out is None else out * x
        return out
    return x ** n


def elastic_force(delta, stiffness, exponent):
    """K max(delta, 0)^n [N]: the conservative part, potential K delta^(n+1) / (n+1)."""
    return stiffness * power(_pos(delta), exponent)


def _hertz(delta, delta_dot, delta_dot0, K, n, c_r, damping, v_min):
    return elastic_force(delta, K, n)


def _kelvin_voigt(delta, delta_dot, delta_dot0, K, n, c_r, damping, v_min):
    return ca.if_else(delta > 0, _pos(elastic_force(delta, K, n) + damping * delta_dot), 0.0)


def _hysteresis(law):
    def f(delta, delta_dot, delta_dot0, K, n, c_r, damping, v_min):
        chi = hysteresis_factor(law, c_r)
        return _pos(elastic_force(delta, K, n) * (1.0 + chi * delta_dot / ca.fmax(delta_dot0, v_min)))
    f.__name__ = law.replace("-", "_")
    return f


# the registry, by the names of the scene's vocabulary
NORMAL_LAWS = registry(CONTACT_LAWS, {"hertz": _hertz, "kelvin-voigt": _kelvin_voigt, **{
    law: _hysteresis(law) for law in ("hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")}})


def normal_force(law: str, delta, delta_dot, delta_dot0, stiffness, exponent, restitution, damping=0.0,
                 v_min: float = V_MIN):
    """F_N >= 0 [N] of the named law (keys of :data:`NORMAL_LAWS`); the approach velocity
    delta_dot0 is floored at v_min [m/s] (the equations' own floor, default V_MIN)."""
    return NORMAL_LAWS[law](delta, delta_dot, delta_dot0, stiffness, exponent, restitution, damping, v_min)


def stiffness_internal_cylinder(journal_radius: float, bearing_radius: float, e_journal: float, nu_journal: float,
                                e_bearing: float, nu_bearing: float) -> float:
    """K [N/m^1.5] of a journal in a bearing (internal cylindrical contact),
    K = 4 / (3 (s_J + s_B)) sqrt(R_J R_B / (R_B - R_J)), s = (1 - nu^2) / E
    (Lankarani & Nikravesh 1990; Flores et al. 2006, Nonlinear Dyn. 46, eq. 13).
    Radii [m], Young's moduli [Pa]."""
    s = (1.0 - nu_journal**2) / e_journal + (1.0 - nu_bearing**2) / e_bearing
    return 4.0 / (3.0 * s) * (journal_radius * bearing_radius / (bearing_radius - journal_radius)) ** 0.5
