"""Reading a lubricated joint's film from a scene: ``effects.lubrication`` (every clearance
joint's) and a clearance joint's own ``lubrication`` (replaces the scene's for that joint)::

    lubrication: {law: short-bearing, viscosity: 0.04, length: 0.04, threshold: 0.95}

law: 'none' (dry, the default), 'long-bearing' or 'short-bearing'; viscosity [Pa s] > 0 and
bearing length [m] > 0 are required with a film; threshold: the eccentricity ratio in
(0, 1) where the dry laws take over (default 0.95)."""

from __future__ import annotations

from ..errors import SceneError
from .fields import Section
from .schema import LubricationEffect
from .vocabulary import LUBRICATION_LAW_KEYS, choices

__all__ = ["read_lubrication"]


def read_lubrication(value, key: str) -> LubricationEffect:
    """The :class:`LubricationEffect` of the mapping `value` at scene key `key` (or the
    string 'none'); raises SceneError naming the key, the value and what is allowed."""
    if value == "none":
        return LubricationEffect()
    s = Section(value, key)
    law = s.choice("law", choices("lubrication law"), "none")
    takes = LUBRICATION_LAW_KEYS[law]
    for k in s.data:
        if k != "law" and k not in takes:
            raise SceneError(f"{s.key(k)}: not used by law '{law}' (it takes: {', '.join(('law', *takes))}); "
                             "remove it or choose a law that uses it")
    if law == "none":
        s.done()
        return LubricationEffect()
    out = LubricationEffect(law, s.number("viscosity", positive=True), s.number("length", positive=True),
                            s.number("threshold", 0.95, lo=0.0, hi=1.0, lo_open=True, hi_open=True))
    s.done()
    return out
