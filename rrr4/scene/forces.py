"""Force elements of a scene (``forces:``, a list): spring-dampers, rotational
spring-dampers and external loads, read into :class:`ForceElement`::

    forces:
      - {type: spring_damper, name: s1, bodies: [ground, platform], points: [[-0.3, 0], [0, 0]],
         stiffness: 500.0, damping: 2.0, free_length: 0.3, preload: 0.0}
      - {type: rotational_spring_damper, joint: B1, stiffness: 0.5, damping: 0.01}
      - {type: load, body: platform, point: [0, 0], force: [-20.0, 0.0], torque: 0.0, frame: ground}
      - {type: load, body: platform, table: cutting.csv}       # columns t,fx,fy,tz
      - {type: load, body: platform, force: [0.0, 5.0], known: false}  # a disturbance

Units: stiffness N/m (translational) or N m/rad (rotational), damping N s/m or N m s/rad,
free_length m, free_angle rad, preload N (translational) or N m (rotational), force N,
torque N m, table rows t [s], fx, fy [N], tz [N m]. A spring's free length (free angle)
defaults to its length (angle) in the assembled initial pose; body and joint names, and
named points, are checked against the mechanism. A load is ``known`` (default true) to the
controller's model, which then balances it in the feed-forward and the preload (a constant
load on the task body of an n-RRR, or any constant load of a graph); false makes it a
disturbance. A tabulated load is interpolated linearly
in t and holds its first row before its first time and its last row after its last time.
Plain data and the reader only; :mod:`rrr4.dynamics.elements` builds their forces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..checks import describe, unknown_value
from ..errors import SceneError
from .fields import MAX_MAGNITUDE, Section, read_csv_rows
from .vocabulary import FORCE_ELEMENTS, GROUND, LOAD_FRAMES

__all__ = ["ForceElement", "read_forces", "read_load_table", "check_load_table", "LOAD_TABLE_COLUMNS",
           "FORCE_PARAMETERS"]

LOAD_TABLE_COLUMNS = ("t", "fx", "fy", "tz")
MAX_LOAD_ROWS = 100_000
# the numbers of an element that enter the equations as inputs, per element type
FORCE_PARAMETERS = {
    "spring_damper": ("stiffness", "damping", "free_length", "preload"),
    "rotational_spring_damper": ("stiffness", "damping", "free_length", "preload"),
    "load": ("fx", "fy", "torque", "unused"),
}
_KEYS = {
    "spring_damper": ("bodies", "points", "stiffness", "damping", "free_length", "preload"),
    "rotational_spring_damper": ("joint", "bodies", "stiffness", "damping", "free_angle", "preload"),
    "load": ("body", "point", "force", "torque", "frame", "table", "known"),
}


@dataclass(frozen=True)
class ForceElement:
    """One force element (see the module docstring). bodies: the two bodies of a
    (rotational) spring-damper (first may be 'ground'), or the loaded body alone; points
    (x, y) [m] in each body's frame (ground: global); free_length [m] or free angle [rad],
    None: from the assembled initial pose; preload [N or N m]: a constant force along the
    spring (positive: tension, pulling the points together, as if the free length were
    shorter by preload / stiffness) or torque (positive turns b clockwise against a); force
    (fx, fy) [N] in `frame`, torque [N m]; table: rows (t, fx, fy, tz) of a tabulated load,
    () for a constant one; known: whether the controller's model (feed-forward and preload)
    balances a load (one it does not know is a disturbance only the feedback meets)."""
    name: str
    type: str
    bodies: tuple[str, ...]
    points: tuple[tuple[float, float], ...] = ()
    stiffness: float = 0.0
    damping: float = 0.0
    free_length: float | None = None
    preload: float = 0.0
    force: tuple[float, float] = (0.0, 0.0)
    torque: float = 0.0
    frame: str = "ground"
    table: tuple[tuple[float, float, float, float], ...] = ()
    known: bool = True

    def values(self, free_length: float | None = None) -> tuple[float, float, float, float]:
        """The element's numbers in the order of :data:`FORCE_PARAMETERS` (`free_length`
        replaces a free length left to the initial pose)."""
        if self.type == "load":
            return (*self.force, self.torque, 0.0)
        free = self.free_length if self.free_length is not None else free_length
        return self.stiffness, self.damping, float("nan") if free is None else free, self.preload


def _point(raw, key: str, body: str, points: dict) -> tuple[float, float]:
    if isinstance(raw, str):
        if raw not in points.get(body, {}):
            raise unknown_value(key, f"point of {body}", raw, list(points.get(body, {})) or ["(none)"])
        return tuple(points[body][raw])
    return Section({"p": raw}, key).vector("p", 2)


def _body(sec: Section, k: str, value, names) -> str:
    if value not in names:
        raise unknown_value(sec.key(k), "body", value, names)
    return value


def read_load_table(path, key: str) -> tuple[tuple[float, float, float, float], ...]:
    """The rows (t, fx, fy, tz) of a load table file (CSV, header t,fx,fy,tz): t from 0 or
    later, increasing, every value finite and |value| <= the scene limit; SceneError naming
    the key, the file and the row otherwise."""
    raw = read_csv_rows(path, key, LOAD_TABLE_COLUMNS, MAX_LOAD_ROWS)
    if len(raw) > MAX_LOAD_ROWS:
        raise SceneError(f"{key}: {Path(path).name!r} has more than {MAX_LOAD_ROWS} rows (not allowed)")
    return check_load_table(raw, f"{key}: {Path(path).name!r}")


def check_load_table(raw, where: str) -> tuple[tuple[float, float, float, float], ...]:
    """The rows (t, fx, fy, tz) of `raw` (a list of 4 numbers, or of their text) checked as
    :func:`read_load_table` says; SceneError starting with `where` (the key, and the file)."""
    if not isinstance(raw, (list, tuple)) or len(raw) > MAX_LOAD_ROWS:
        raise SceneError(f"{where}: {describe(raw)} is not allowed (at most {MAX_LOAD_ROWS} rows t, fx, fy, tz)")
    rows = []
    for k, r in enumerate(raw):
        try:
            if isinstance(r, (str, bytes)) or len(r) != 4:
                raise TypeError
            v = tuple(float(x) for x in r)
        except (TypeError, ValueError):
            raise SceneError(f"{where} row {k}: {describe(r)} is not allowed (four numbers t,fx,fy,tz)") from None
        if not all(math.isfinite(x) and abs(x) <= MAX_MAGNITUDE for x in v):
            raise SceneError(f"{where} row {k}: {describe(r)} is not allowed (finite numbers, "
                             f"|value| <= {MAX_MAGNITUDE:g})")
        if rows and not v[0] > rows[-1][0]:
            raise SceneError(f"{where} row {k}: t = {v[0]:g} s is not allowed (t must increase)")
        rows.append(v)
    if len(rows) < 2:
        raise SceneError(f"{where} has {len(rows)} rows (at least 2 are required)")
    if rows[0][0] < 0:
        raise SceneError(f"{where} starts at t = {rows[0][0]:g} s (not allowed: t >= 0)")
    return tuple(rows)


def read_forces(raw, key: str, graph, base: Path = Path()) -> tuple[ForceElement, ...]:
    """The force elements of the scene list `raw` at `key` (``forces``), checked against
    the graph's bodies, joints and named points; table files are relative to `base`."""
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise SceneError(f"{key}: {describe(raw)} is not allowed (a list of force elements, each with a type: "
                         f"{', '.join(FORCE_ELEMENTS)})")
    bodies = [GROUND] + [b.name for b in graph.bodies]
    points = {b.name: dict(b.points) for b in graph.bodies}
    joints = {j.name: j for j in graph.joints}
    out, names = [], set()
    for i, item in enumerate(raw):
        s = Section(item, f"{key}[{i}]")
        kind = s.choice("type", FORCE_ELEMENTS)
        for k in s.data:
            if k not in ("type", "name", *_KEYS[kind]):
                raise SceneError(f"{s.key(str(k))}: not used by type '{kind}' (it takes: "
                                 f"{', '.join(('type', 'name', *_KEYS[kind]))})")
        name = s.raw("name", f"{kind}{i}")
        if not isinstance(name, str) or not name or not all(c.isalnum() or c in "_-" for c in name):
            raise SceneError(f"{s.key('name')}: {describe(name)} is not allowed (a name of letters, digits, '_' "
                             "and '-')")
        if name in names:
            raise SceneError(f"{s.key('name')}: {name!r} is not allowed (names a force element twice)")
        names.add(name)
        if kind == "load":
            out.append(_load(s, name, bodies, points, base))
            continue
        rotational = kind == "rotational_spring_damper"
        if rotational and s.has("joint"):
            if s.has("bodies"):
                raise SceneError(f"{s.key('bodies')}: not allowed with joint (give the joint or the two bodies)")
            j = s.raw("joint")
            revolute = [n for n, jt in joints.items() if jt.type == "revolute"]
            if j not in revolute:
                raise unknown_value(s.key("joint"), "revolute joint", j, revolute)
            pair = joints[j].bodies
        else:
            pair = s.raw("bodies")
            if not isinstance(pair, list) or len(pair) != 2:
                raise SceneError(f"{s.key('bodies')}: {describe(pair)} is not allowed (a list of two body names"
                                 + (", or give joint: a revolute joint)" if rotational else ")"))
            for b in pair:
                _body(s, "bodies", b, bodies)
            if pair[0] == pair[1]:
                raise SceneError(f"{s.key('bodies')}: {describe(pair)} is not allowed (two different bodies)")
        pts = ()
        if not rotational:
            rp = s.raw("points", [[0.0, 0.0], [0.0, 0.0]])
            if not isinstance(rp, list) or len(rp) != 2:
                raise SceneError(f"{s.key('points')}: {describe(rp)} is not allowed (two points, one per body: a "
                                 "point name or [x, y] in m)")
            pts = tuple(_point(p, f"{s.key('points')}[{k}]", b, points)
                        for k, (b, p) in enumerate(zip(pair, rp, strict=True)))
        free_key = "free_angle" if rotational else "free_length"
        free = s.number(free_key, nonneg=not rotational) if s.raw(free_key) is not None else None
        out.append(ForceElement(name, kind, tuple(pair), pts, s.number("stiffness", 0.0, nonneg=True),
                                s.number("damping", 0.0, nonneg=True), free, s.number("preload", 0.0)))
        if out[-1].stiffness == 0 and out[-1].damping == 0 and out[-1].preload == 0:
            raise SceneError(f"{s.key('stiffness')}: 0 is not allowed together with damping 0 and preload 0 (the "
                             "element would exert no force)")
        s.done()
    return tuple(out)


def _load(s: Section, name: str, bodies, points, base: Path) -> ForceElement:
    body = _body(s, "body", s.raw("body"), bodies[1:])
    point = _point(s.raw("point", [0.0, 0.0]), s.key("point"), body, points)
    frame = s.choice("frame", LOAD_FRAMES, "ground")
    table = ()
    if s.raw("table") is not None:
        for k in ("force", "torque"):
            if s.has(k):
                raise SceneError(f"{s.key(k)}: not allowed with table (the table gives fx, fy and tz)")
        rows = s.raw("table")  # a file, or its rows themselves (a sweep's cases carry them so)
        table = (check_load_table(rows, s.key("table")) if isinstance(rows, list) else
                 read_load_table(base / s.string("table"), s.key("table")))
        force, torque = (0.0, 0.0), 0.0
    else:
        if not (s.has("force") or s.has("torque")):
            raise SceneError(f"{s.key('force')}: missing (a load needs force [fx, fy] in N, torque in N m, or a "
                             "table file with columns t,fx,fy,tz)")
        force, torque = s.vector("force", 2, [0.0, 0.0]), s.number("torque", 0.0)
    known = s.raw("known", True)
    if not isinstance(known, bool):
        raise SceneError(f"{s.key('known')}: {describe(known)} is not allowed (true or false)")
    s.done()
    return ForceElement(name, "load", (body,), (point,), force=force, torque=torque, frame=frame, table=table,
                        known=known)
