"""A tabulated time law: the path progress s(t) as a table of (t, s, s_dot).

Between two rows the progress has a constant acceleration s_ddot = (s_dot[k+1] - s_dot[k]) / h,
the motion of a time-optimal law on a grid (b = s_dot^2 linear in s on each segment), so
the table is exact, not interpolated: ``rrr4.trajectory`` evaluates s(t) piecewise
quadratic, s_dot(t) piecewise linear, s_ddot(t) piecewise constant. A scene carries it as
``path.time_law: table`` with ``path.time_table: FILE.csv`` (relative to the scene file);
the optimal-control layer writes it (:meth:`rrr4.optimal.OptimalTimeLaw.save_table`).

The file is CSV with the header ``t,s,s_dot`` (more columns, e.g. ``s_ddot``, are ignored):
t [s] from 0, increasing; s [-] from 0 to 1, non-decreasing; s_dot [1/s] >= 0; and each
row consistent with constant acceleration, s[k+1] - s[k] = h (s_dot[k] + s_dot[k+1]) / 2.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from ..errors import SceneError
from .fields import read_csv_rows

__all__ = ["TIME_TABLE_COLUMNS", "MAX_TABLE_ROWS", "read_time_table", "check_time_table", "time_table_text"]

TIME_TABLE_COLUMNS = ("t", "s", "s_dot")
MAX_TABLE_ROWS = 1_000_000
# relative mismatch allowed between a row's s step and the trapezoid of its s_dot (rounding of the CSV)
CONSISTENCY_TOL = 1e-6


def check_time_table(rows, key: str = "time_table") -> tuple[tuple[float, float, float], ...]:
    """The rows (t, s, s_dot) as a tuple of float triples, checked (see the module docstring);
    SceneError naming the row and the rule otherwise."""
    if isinstance(rows, (str, bytes, Mapping)) or not isinstance(rows, Iterable):
        raise SceneError(f"{key}: {rows!r} is not allowed (a list of rows (t, s, s_dot))")
    rows = list(rows)
    table = []
    for k, row in enumerate(rows):
        try:
            t, s, sd = row
            table.append((float(t), float(s), float(sd)))
        except (TypeError, ValueError):
            raise SceneError(f"{key}: row {k} {row!r} is not allowed (three numbers t [s], s [-], s_dot [1/s])"
                             ) from None
    table = tuple(table)
    if len(table) < 2:
        raise SceneError(f"{key}: {len(table)} rows is not allowed (at least 2)")
    if len(table) > MAX_TABLE_ROWS:
        raise SceneError(f"{key}: {len(table)} rows is not allowed (at most {MAX_TABLE_ROWS})")
    for k, (t, s, sd) in enumerate(table):
        if not all(math.isfinite(v) for v in (t, s, sd)):
            raise SceneError(f"{key}: row {k} ({t}, {s}, {sd}) is not allowed (finite numbers only)")
        if sd < 0:
            raise SceneError(f"{key}: row {k}: s_dot = {sd:g} is not allowed (>= 0: the path is followed forwards)")
    t0, s0, s1 = table[0][0], table[0][1], table[-1][1]
    if t0 != 0.0 or abs(s0) > 1e-12 or abs(s1 - 1.0) > 1e-9:
        raise SceneError(f"{key}: starts at t = {t0:g}, s = {s0:g} and ends at s = {s1:g}, which is not allowed "
                         "(t from 0, s from 0 to 1)")
    for k in range(len(table) - 1):
        (ta, sa, va), (tb, sb, vb) = table[k], table[k + 1]
        h = tb - ta
        if not h > 0:
            raise SceneError(f"{key}: t at row {k + 1} ({tb:g} s) is not allowed (t must increase)")
        if sb < sa:
            raise SceneError(f"{key}: s at row {k + 1} ({sb:g}) is not allowed (s must not decrease)")
        step = 0.5 * h * (va + vb)
        if abs((sb - sa) - step) > CONSISTENCY_TOL * max(abs(sb - sa), 1e-9):
            raise SceneError(f"{key}: rows {k} and {k + 1} are not allowed (s step {sb - sa:.9g} but h (s_dot[k] + "
                             f"s_dot[k+1]) / 2 = {step:.9g}: not a constant acceleration)")
    return table


def read_time_table(path: str | os.PathLike, key: str = "path.time_table") -> tuple[tuple[float, float, float], ...]:
    """The checked rows of the time table file `path` (CSV, header t,s,s_dot); SceneError
    naming the key and the file otherwise."""
    rows = read_csv_rows(path, key, TIME_TABLE_COLUMNS, MAX_TABLE_ROWS)
    return check_time_table(rows, f"{key} ({Path(path).name})")


def time_table_text(t, s, s_dot, s_ddot=None) -> str:
    """The CSV text of a time table (17 significant digits, so reading it back is exact)."""
    head = ["t", "s", "s_dot"] + ([] if s_ddot is None else ["s_ddot"])
    cols = [t, s, s_dot] + ([] if s_ddot is None else [s_ddot])
    lines = [",".join(head)]
    lines += [",".join(f"{float(v):.17g}" for v in row) for row in zip(*cols, strict=True)]
    return "\n".join(lines) + "\n"

