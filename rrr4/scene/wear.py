"""Reading a clearance joint's wear from a scene: ``effects.wear`` (every clearance joint's)
and a clearance joint's own ``wear`` (replaces the scene's for that joint)::

    wear: {surfaces: bearing, coefficient: 1.0e-5, hardness: 1.2e+9, length: 0.01, nodes: 72}

surfaces: 'none' (no wear, the default), 'bearing', 'journal' or 'both'; coefficient: Archard's
dimensionless wear coefficient k > 0; hardness [Pa] > 0 of the wearing surface; length [m] > 0
of the bearing; nodes: points of the wear profile over the bearing angle (integer, 8 to 720,
default 72)."""

from __future__ import annotations

from ..errors import SceneError
from .fields import Section
from .schema import WearEffect
from .vocabulary import choices

__all__ = ["read_wear"]

MIN_NODES, MAX_NODES = 8, 720


def read_wear(value, key: str) -> WearEffect:
    """The :class:`WearEffect` of the mapping `value` at scene key `key` (or the string
    'none'); raises SceneError naming the key, the value and what is allowed."""
    if value == "none":
        return WearEffect()
    s = Section(value, key)
    surfaces = s.choice("surfaces", choices("wear surfaces"), "none")
    if surfaces == "none":
        for k in s.data:
            if k != "surfaces":
                raise SceneError(f"{s.key(str(k))}: not used with surfaces 'none' (nothing wears); remove it or say "
                                 f"which surfaces wear (surfaces: {', '.join(choices('wear surfaces')[1:])})")
        return WearEffect()
    nodes = s.integer("nodes", 72)
    if not MIN_NODES <= nodes <= MAX_NODES:
        raise SceneError(f"{s.key('nodes')}: {nodes} is not allowed (an integer from {MIN_NODES} to {MAX_NODES})")
    out = WearEffect(surfaces, s.number("coefficient", positive=True, hi=1.0),
                     s.number("hardness", positive=True, big=True), s.number("length", positive=True), nodes)
    s.done()
    return out
