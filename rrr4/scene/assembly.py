"""mechanism.assembly of a graph scene: the assembly mode, a list of conditions at revolute
joints (the sign of the bend or the stretch between the two bodies' lines), read into
:class:`~rrr4.scene.schema.AssemblyMode`."""

from __future__ import annotations

import math

from ..checks import describe, unknown_value
from ..errors import SceneError
from .fields import Section
from .schema import AssemblyMode, JointSpec
from .vocabulary import ASSEMBLY_MEASURES

__all__ = ["read_assembly"]

SIGNS = {"+": 1, "-": -1, 1: 1, -1: -1}


def read_assembly(sec: Section, joints: list[JointSpec], points: dict) -> tuple[AssemblyMode, ...]:
    """mechanism.assembly: the assembly mode, a list of {joint, bend | stretch: '+' | '-', points}."""
    raw = sec.raw("assembly", []) or []
    if not isinstance(raw, list):
        raise SceneError(f"{sec.key('assembly')}: {describe(raw)} is not allowed (a list of "
                         "{joint: <revolute joint>, bend: '+' or '-'} or {joint: ..., stretch: '+' or '-'})")
    revolute = [j.name for j in joints if j.type == "revolute"]
    out, seen = [], set()
    for i, r in enumerate(raw):
        e = Section(r, f"{sec.key('assembly')}[{i}]")
        name = e.raw("joint")
        if name not in revolute:
            raise unknown_value(e.key("joint"), "revolute joint", name, revolute)
        jt = next(j for j in joints if j.name == name)
        given = [m for m in ASSEMBLY_MEASURES if e.has(m)]
        if len(given) != 1:
            raise SceneError(f"{e.key('bend')}: {'both bend and stretch are' if given else 'neither is'} given "
                             "(exactly one of bend or stretch is allowed, each '+' or '-')")
        measure = given[0]
        sign = e.raw(measure)
        if not isinstance(sign, (str, int)) or isinstance(sign, bool) or sign not in SIGNS:
            raise SceneError(f"{e.key(measure)}: {describe(sign)} is not allowed (one of: '+', '-')")
        if (name, measure) in seen:
            raise SceneError(f"{e.key('joint')}: {name!r} is not allowed (its {measure} is already named)")
        seen.add((name, measure))
        raw_pts = e.raw("points")
        refs = []
        for k, body in enumerate(jt.bodies):
            where = f"{e.key('points')}[{k}]"
            if raw_pts is not None:
                if not isinstance(raw_pts, list) or len(raw_pts) != 2:
                    raise SceneError(f"{e.key('points')}: {describe(raw_pts)} is not allowed (two reference "
                                     f"points, one on {jt.bodies[0]} and one on {jt.bodies[1]}: a point name or "
                                     "[x, y] in m)")
                pt = raw_pts[k]
                if isinstance(pt, str):
                    if pt not in points[body]:
                        raise unknown_value(where, f"point of {body}", pt, list(points[body]) or ["(none)"])
                    ref = points[body][pt]
                else:
                    ref = Section({"p": pt}, where).vector("p", 2)
            else:  # the body's other joint, when it has exactly one
                other = [j for j in joints if j.name != name and body in j.bodies]
                if len(other) != 1:
                    raise SceneError(f"{e.key('points')}: missing; {body} has {len(other)} joints besides {name}, "
                                     f"so its line at {name} is not defined (give points: [a point of "
                                     f"{jt.bodies[0]}, a point of {jt.bodies[1]}])")
                ref = other[0].points[other[0].bodies.index(body)]
            if math.dist(ref, jt.points[k]) < 1e-12:
                raise SceneError(f"{where}: {list(ref)} is not allowed (it is {name}'s own point on {body}, so "
                                 f"{body}'s line at {name} has no direction: name another point)")
            refs.append(tuple(ref))
        e.done()
        out.append(AssemblyMode(name, measure, SIGNS[sign], (refs[0], refs[1])))
    return tuple(out)
