"""A driver's motion law: the scene keys of one entry of ``mechanism.drivers``.

A driver prescribes a joint coordinate in time. ``time_law: constant`` (the default) turns
it at a constant speed from t = 0 (``speed`` [rad/s or m/s], or ``speed_rpm`` on a revolute
joint): the classic prescribed crank, whose start is an impact. Any other law is a path's
time law (:data:`rrr4.scene.vocabulary.TIME_LAWS`) applied to the driver's coordinate: it
moves by ``travel_deg`` (``travel`` [m] on a prismatic joint) over ``duration`` [s],
quintic and cycloidal from rest to rest (a smooth start-up and run-down), or along the rows
(t, s, s_dot) of a ``time_table`` (a CSV file beside the scene with the path's columns
t,s,s_dot, or the list of rows; :mod:`.time_table`), the same tables ``rrr4 optimize``
writes, or along a ``speed_table`` (columns t,speed [rad/s or m/s], the speed linear between
rows, one sign throughout; the travel is its integral). After its duration the driver rests
at initial + travel.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import SceneError
from .fields import MAX_MAGNITUDE, Section, read_csv_rows
from .schema import DriverSpec
from .time_table import MAX_TABLE_ROWS, check_time_table, read_time_table
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
        table, duration = (), None
        if law == "table":
            travel, table = _tables(e, base, revolute)
            duration = table[-1][0]
            if e.has("duration"):
                raise SceneError(f"{e.key('duration')}: not allowed with time_law 'table' (the table ends at "
                                 f"{duration:.9g} s: its last row is the duration)")
        else:
            _refuse(e, law, ("time_table", "speed_table"), "only with time_law: table")
            travel = _travel(e, revolute)
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


def _tables(e: Section, base: Path, revolute: bool):
    """(travel, rows (t, s, s_dot)) of time_law 'table': a time_table with the travel, or a
    speed_table whose integral is the travel."""
    if e.has("time_table") == e.has("speed_table"):
        what = "not allowed with speed_table" if e.has("time_table") else "missing"
        raise SceneError(f"{e.key('time_table')}: {what} "
                         "(time_law 'table' reads one table: time_table, a CSV beside the scene with columns "
                         "t,s,s_dot or the list of [t, s, s_dot] rows, with the travel; or speed_table, columns "
                         "t,speed or [t, speed] rows)")
    if e.has("time_table"):
        raw = e.raw("time_table")
        key = e.key("time_table")
        table = (check_time_table(raw, key) if isinstance(raw, list) else
                 read_time_table(base / e.string("time_table"), key))
        return _travel(e, revolute), table
    _refuse(e, "table", ("travel_deg", "travel"), "with speed_table the travel is the speed's integral")
    return _speed_table(e, base)


def _speed_table(e: Section, base: Path):
    """(travel, rows (t, s, s_dot)) of a speed table: s the trapezoid integral of the speed
    over the travel, so the motion is the table's (the speed linear between rows)."""
    key, raw = e.key("speed_table"), e.raw("speed_table")
    if not isinstance(raw, list):
        raw = read_csv_rows(base / e.string("speed_table"), key, ("t", "speed"), MAX_TABLE_ROWS)
    rows = []
    for k, row in enumerate(raw):
        try:
            t, v = (float(x) for x in row)
        except (TypeError, ValueError):
            raise SceneError(f"{key}: row {k} {row!r} is not allowed (two numbers t [s], speed [rad/s or m/s])"
                             ) from None
        if not (math.isfinite(t) and math.isfinite(v) and abs(v) <= MAX_MAGNITUDE):
            raise SceneError(f"{key}: row {k} ({t}, {v}) is not allowed (finite numbers, |speed| <= "
                             f"{MAX_MAGNITUDE:g})")
        rows.append((t, v))
    if len(rows) < 2 or rows[0][0] != 0.0:
        raise SceneError(f"{key}: {len(rows)} rows from t = {rows[0][0] if rows else 'none'} is not allowed (at "
                         "least 2 rows, t from 0)")
    if min(v for _, v in rows) < 0 < max(v for _, v in rows):
        raise SceneError(f"{key}: speeds of both signs are not allowed (one direction per table)")
    travel, cum = 0.0, [0.0]
    for (ta, va), (tb, vb) in zip(rows, rows[1:], strict=False):
        if not tb > ta:
            raise SceneError(f"{key}: t = {tb:g} s is not allowed after {ta:g} s (t must increase)")
        travel += 0.5 * (tb - ta) * (va + vb)
        cum.append(travel)
    if travel == 0:
        raise SceneError(f"{key}: all speeds 0 is not allowed (the driver must move)")
    table = [(t, c / travel, v / travel) for (t, v), c in zip(rows, cum, strict=True)]
    return travel, check_time_table(table, key)
