"""mechanism.joints of a graph scene: each joint's type, the two bodies it joins and its point
on each, a prismatic joint's axis and angle, a revolute joint's clearance (its journal, fit,
materials and, when it says, its own oil film and wear)."""

from __future__ import annotations

import math

from ...checks import describe, unknown_value
from ...errors import SceneError
from ..bearing import STEEL, read_fit, read_material
from ..fields import Section
from ..lubrication import read_lubrication
from ..names import read_name
from ..schema import JointSpec
from ..vocabulary import GROUND, JOINT_TYPES
from ..wear import read_wear

__all__ = ["read_joints"]

IDEAL = {"clearance": False, "journal_radius": 0.005, "radial_clearance": 1e-4,
         "journal_material": STEEL, "bearing_material": STEEL}  # a joint without clearance


def read_joints(sec: Section, points: dict[str, dict]) -> list[JointSpec]:
    """The joints of the mechanism section `sec`; `points`: {body name or 'ground': its named points}."""
    raw_joints = sec.raw("joints")
    if not isinstance(raw_joints, list) or not raw_joints:
        raise SceneError(f"{sec.key('joints')}: {describe(raw_joints)} is not allowed (a list of joints is required)")
    joints = []
    for i, raw in enumerate(raw_joints):
        j = Section(raw, f"{sec.key('joints')}[{i}]")
        name = read_name(j)
        if any(x.name == name for x in joints):
            raise SceneError(f"{j.key('name')}: {name!r} names a joint twice")
        kind = j.choice("type", JOINT_TYPES, "revolute")
        pair = _bodies(j, list(points))
        pts = _points(j, pair, points)
        extra = _prismatic(j) if kind == "prismatic" else {}
        cl = dict(IDEAL)
        if kind == "revolute" and j.raw("clearance") is not None:
            cl.update(_clearance(j.raw("clearance"), j.key("clearance"), tuple(pair)))
        j.done()
        joints.append(JointSpec(name, type=kind, bodies=tuple(pair), points=tuple(pts), **cl, **extra))
    return joints


def _bodies(j: Section, names: list[str]) -> list[str]:
    pair = j.raw("bodies")
    if not isinstance(pair, list) or len(pair) != 2:
        raise SceneError(f"{j.key('bodies')}: {describe(pair)} is not allowed (a list of two body names)")
    for b in pair:
        if b not in names:
            raise unknown_value(j.key("bodies"), "body", b, names)
    if pair[0] == pair[1]:
        raise SceneError(f"{j.key('bodies')}: {describe(pair)} is not allowed (two different bodies)")
    return pair


def _points(j: Section, pair: list[str], points: dict[str, dict]) -> list[tuple[float, float]]:
    """The joint's point on each of its bodies: a point name of that body or [x, y] in m."""
    raw_pts = j.raw("points", [[0.0, 0.0], [0.0, 0.0]])
    if not isinstance(raw_pts, list) or len(raw_pts) != 2:
        raise SceneError(f"{j.key('points')}: {describe(raw_pts)} is not allowed "
                         "(two points, one per body: a point name or [x, y] in m)")
    pts = []
    for k, (b, pt) in enumerate(zip(pair, raw_pts, strict=True)):
        if isinstance(pt, str):
            if pt not in points[b]:
                raise unknown_value(f"{j.key('points')}[{k}]", f"point of {b}", pt, list(points[b]) or ["(none)"])
            pts.append(points[b][pt])
        else:
            pts.append(Section({"p": pt}, f"{j.key('points')}[{k}]").vector("p", 2))
    return pts


def _prismatic(j: Section) -> dict:
    """A prismatic joint's unit axis and angle [rad]; it has no clearance."""
    axis = j.vector("axis", 2, [1.0, 0.0])
    norm = math.hypot(*axis)
    if not norm > 1e-12:
        raise SceneError(f"{j.key('axis')}: {list(axis)} is not allowed (a direction of non-zero length)")
    extra = {"axis": (axis[0] / norm, axis[1] / norm), "angle": math.radians(j.number("angle_deg", 0.0))}
    if j.has("clearance"):
        raise SceneError(f"{j.key('clearance')}: not allowed on a prismatic joint (revolute clearance only)")
    return extra


def _clearance(v, key: str, bodies: tuple[str, str]) -> dict:
    """The JointSpec fields of a revolute joint's clearance mapping `v` at `key`."""
    s = Section(v, key)
    journal = s.raw("journal", bodies[1])
    if journal not in bodies or journal == GROUND:
        raise unknown_value(s.key("journal"), "body", journal, [b for b in bodies if b != GROUND])
    rj, c = read_fit(s)
    out = {"clearance": True, "journal_radius": rj, "radial_clearance": c, "journal": bodies.index(journal),
           "journal_material": read_material(s.raw("journal_material", "steel"), s.key("journal_material")),
           "bearing_material": read_material(s.raw("bearing_material", "steel"), s.key("bearing_material"))}
    if s.has("lubrication"):
        out["lubrication"] = read_lubrication(s.raw("lubrication"), s.key("lubrication"))
    if s.has("wear"):
        out["wear"] = read_wear(s.raw("wear"), s.key("wear"))
    s.done()
    return out
