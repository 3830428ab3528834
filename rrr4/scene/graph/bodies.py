"""mechanism.ground and mechanism.bodies of a graph scene: the named points of the ground and
of each body (in its own frame, m), each body's mass, inertia and starting pose."""

from __future__ import annotations

from ...checks import describe
from ...errors import SceneError
from ..field_specs import read_fields
from ..fields import Section
from ..names import read_name
from ..schema import Body
from ..vocabulary import GROUND

__all__ = ["read_bodies"]


def read_points(sec: Section, k: str) -> tuple[tuple[str, tuple[float, float]], ...]:
    """The named points at key `k` of `sec`: a mapping of point name to [x, y] in m."""
    raw = sec.raw(k, {}) or {}
    if not isinstance(raw, dict):
        raise SceneError(f"{sec.key(k)}: expected a mapping of point name to [x, y] in m, got {describe(raw)}")
    ps = Section(raw, sec.key(k))
    return tuple((str(name), ps.vector(name, 2)) for name in raw)


def read_bodies(sec: Section) -> tuple[list[Body], dict[str, dict]]:
    """(the bodies, {body name or 'ground': {point name: (x, y)}}) of the mechanism section `sec`."""
    ground = dict(read_points(sec.section("ground"), "points"))
    sec.section("ground").done(["points"])
    raw_bodies = sec.raw("bodies")
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise SceneError(f"{sec.key('bodies')}: {describe(raw_bodies)} is not allowed (a list of bodies is required)")
    bodies, points = [], {GROUND: ground}
    for i, raw in enumerate(raw_bodies):
        b = Section(raw, f"{sec.key('bodies')}[{i}]")
        name = read_name(b)
        if name in points:
            raise SceneError(f"{b.key('name')}: {name!r} is not allowed (names a body twice, or the ground)")
        pts = read_points(b, "points")
        bodies.append(Body(name, points=pts, **read_fields(b, Body, ("mass", "inertia", "pose"))))
        points[name] = dict(pts)
        b.done()
    return bodies, points
