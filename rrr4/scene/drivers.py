"""A driver's motion law: the scene keys of one entry of ``mechanism.drivers``.

A driver prescribes a joint coordinate in time. ``time_law: constant`` (the default) turns
it at a constant speed from t = 0 (``speed`` [rad/s or m/s], or ``speed_rpm`` on a revolute
joint): the classic prescribed crank, whose start is an impact. Any other law is a path's
time law (:data:`rrr4.scene.vocabulary.TIME_LAWS`) applied to the driver's coordinate: it
moves by ``travel_deg`` (``travel`` [m] on a prismatic joint) over ``duration`` [s],
quintic and cycloidal from rest to rest (a smooth start-up and run-down), or along the rows
(t, s, s_dot) of a ``time_table`` (a CSV file beside the scene with the path's columns
t,s,s_dot, or the list of rows; :mod:`.time_table`), the same tables ``rrr4 optimize``
writes. After its duration the driver rests at initial + travel.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import SceneError
from .fields import Section
from .schema import DriverSpec
from .time_table import check_time_table, read_time_table
from .vocabulary import DRIVER_LAWS

__all__ = ["read_driver"]


def read_driver(e: Section, name: str, joint: str, revolute: bool, base: Path = Path()) -> DriverSpec:
    """The DriverSpec of the entry `e` (its joint already checked) on a revolute (angles in
    degrees in the scene) or prismatic joint; one-line SceneError naming the key otherwise."""
    initial = math.radians(e.number("initial_deg", 0.0)) if revolute else e.number("initial", 0.0)
    law = e.choice("time_law", DRIVER_LAWS, "constant")
    if law == "constant":
        _refuse(e, law, ("travel_deg", "travel", "duration", "time_table"), "the speed sets the motion: give "
                "speed" + (" or speed_rpm" if revolute else ""))
        spec = DriverSpec(name, joint, initial, _speed(e, revolute))
    else:
        _refuse(e, law, ("speed", "speed_rpm"), "the law sets the speed: give travel_deg" if revolute else
                "the law sets the speed: give travel")
        travel = _travel(e, revolute)
        table, duration = (), None
        if law == "table":
            table = _table(e, base)
            duration = table[-1][0]
            if e.has("duration"):
                raise SceneError(f"{e.key('duration')}: not allowed with time_law 'table' (the time table ends at "
                                 f"{duration:.9g} s: its last row is the duration)")
        else:
            if e.has("time_table"):
                raise SceneError(f"{e.key('time_table')}: not allowed with time_law {law!r} (only with time_law: "
                                 "table)")
            duration = e.number("duration", positive=True)
        spec = DriverSpec(name, joint, initial, travel / duration, law, travel, duration, table)
    e.done()
    return spec


def _refuse(e: Section, law: str, keys: tuple[str, ...], why: str) -> None:
    for k in keys:
        if e.has(k):
            raise SceneError(f"{e.key(k)}: not allowed with time_law {law!r} ({why})")


def _speed(e: Section, revolute: bool) -> float:
    if e.has("speed_rpm"):
        if not revolute:
            raise SceneError(f"{e.key('speed_rpm')}: not allowed on a prismatic joint (give speed in m/s)")
        return e.number("speed_rpm") * 2 * math.pi / 60
    return e.number("speed")


def _travel(e: Section, revolute: bool) -> float:
    k = "travel_deg" if revolute else "travel"
    other = "travel" if revolute else "travel_deg"
    if e.has(other):
        raise SceneError(f"{e.key(other)}: not allowed on a {'revolute' if revolute else 'prismatic'} joint "
                         f"(give {k})")
    v = e.number(k)
    if v == 0:
        raise SceneError(f"{e.key(k)}: 0 is not allowed (the driver must move: a travel > 0 or < 0)")
    return math.radians(v) if revolute else v


def _table(e: Section, base: Path):
    raw = e.raw("time_table")
    if raw is None:
        raise SceneError(f"{e.key('time_table')}: missing (time_law 'table' reads a CSV file with columns t,s,s_dot, "
                         "relative to the scene file, or a list of [t, s, s_dot] rows)")
    if isinstance(raw, list):
        return check_time_table(raw, e.key("time_table"))
    return read_time_table(base / e.string("time_table"), e.key("time_table"))
