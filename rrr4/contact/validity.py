"""Contact laws inside the range they were derived for.

A hysteresis-damping law F = K delta^n (1 + chi(c_r) delta_dot / delta_dot0) is built to
return a single impact with the restitution c_r it is given. Lankarani-Nikravesh and
Hunt-Crossley derive chi for c_r near 1; at low c_r they dissipate far less than asked
(Flores et al. 2011, Nonlinear Dyn. 65: the reason the Flores and Gonthier forms exist).
:func:`effective_restitution` measures what a law really returns: the restitution of one
impact of a mass on the law, which depends only on chi and n (in the units K = m =
delta_dot0 = 1 the impact is x'' = -x^n (1 + chi x'), x(0) = 0, x'(0) = 1). A law whose
effective restitution misses the scene's by more than :data:`RESTITUTION_MISS` is used
outside its range, and :func:`law_outside_range` says so in one line with the law to use.
"""

from __future__ import annotations

import functools

from scipy.integrate import solve_ivp

from ..scene.vocabulary import CONTACT_LAW_KEYS
from .normal import hysteresis_factor

__all__ = ["effective_restitution", "law_outside_range", "RESTITUTION_MISS", "LOW_RESTITUTION_LAWS"]

RESTITUTION_MISS = 0.05  # largest |effective - requested| restitution of a law used inside its range
LOW_RESTITUTION_LAWS = ("flores", "gonthier")  # the forms derived for the whole range of c_r


@functools.lru_cache(maxsize=256)
def effective_restitution(law: str, restitution: float, exponent: float = 1.5) -> float:
    """The restitution one impact on `law` at `restitution` and `exponent` really returns:
    the separation over the approach velocity (1.0 for Hertz)."""
    chi = hysteresis_factor(law, restitution)
    if chi is None:
        raise ValueError(f"law {law!r} has no hysteresis factor")

    def rhs(_t, y):
        x, v = y
        return [v, -max(max(x, 0.0) ** exponent * (1.0 + chi * v), 0.0)]

    def separation(t, y):
        return y[0] if t > 1e-9 else 1.0
    separation.terminal, separation.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1e3), [0.0, 1.0], events=separation, rtol=1e-9, atol=1e-12)
    return float(-sol.y_events[0][0][1]) if sol.y_events[0].size else 0.0


def law_outside_range(law: str, restitution: float, exponent: float) -> str | None:
    """One line when a hysteresis-damping `law` at `restitution` returns an impact whose
    restitution misses it by more than :data:`RESTITUTION_MISS`, naming the law to use
    (the one of :data:`LOW_RESTITUTION_LAWS` that misses least); None inside its range."""
    if "restitution" not in CONTACT_LAW_KEYS.get(law, ()):
        return None
    got = effective_restitution(law, restitution, exponent)
    if abs(got - restitution) <= RESTITUTION_MISS:
        return None
    others = {o: effective_restitution(o, restitution, exponent) for o in LOW_RESTITUTION_LAWS}
    best = min(others, key=lambda o: abs(others[o] - restitution))
    return (f"effects.contact.law: {law} at restitution {restitution:g} is outside its range: one impact returns "
            f"c_r = {got:.3g} (derived for c_r near 1); use law {best} (returns {others[best]:.3g})")
