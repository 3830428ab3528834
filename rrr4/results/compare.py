"""Compare two result directories of `rrr4 run` (``rrr4 compare A B``): every number of their
``summary.json`` except what depends on the machine and the moment (wall and compile
times), so that a user's run can be checked against the committed result without
rewriting it (`make run` writes to ``runs/`` and compares). An arm whose verdict changed
(``converged``, :mod:`rrr4.simulation.verdict`) always differs, whatever the tolerance, and
is listed first."""

from __future__ import annotations

import math
import os
from pathlib import Path

from ..errors import Rrr4Error
from ..files import read_json

__all__ = ["RUN_SPECIFIC", "VERDICT", "compare_results", "flatten"]

# summary.json keys (last part of the dotted path) whose values belong to the run, not to the result
RUN_SPECIFIC = ("wall_time_s", "compile_time_s", "stepping", "scene_file")
VERDICT = "converged"  # an arm's verdict: a change is a difference at any tolerance


def flatten(data, prefix: str = "") -> dict:
    """{dotted key: leaf value} of nested dicts and lists (list items as [i])."""
    out = {}
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else None
    if items is None:
        return {prefix: data}
    for k, v in items:
        key = f"{prefix}[{k}]" if isinstance(k, int) else (f"{prefix}.{k}" if prefix else str(k))
        out.update(flatten(v, key))
    return out


def _summary(d: Path) -> dict:
    f = Path(d) / "summary.json"
    if not os.path.lexists(f):
        raise Rrr4Error(f"{d}: not a result directory of rrr4 run (no summary.json)")
    return flatten(read_json(f, "result file"))


def _differs(a, b, rtol: float, atol: float) -> bool:
    numeric = (int, float)
    if isinstance(a, numeric) and isinstance(b, numeric) and not isinstance(a, bool) and not isinstance(b, bool):
        if math.isnan(a) and math.isnan(b):
            return False
        return not abs(a - b) <= atol + rtol * max(abs(a), abs(b))
    return a != b


def compare_results(a, b, rtol: float = 1e-2, atol: float = 1e-12) -> tuple[int, list[tuple[str, object, object]]]:
    """(numbers compared, [(key, value in a, value in b)] of those that differ beyond
    atol + rtol max(|a|, |b|), or that one side lacks), over both summaries without
    :data:`RUN_SPECIFIC` keys; a changed verdict (:data:`VERDICT`) first."""
    fa, fb = _summary(a), _summary(b)
    keys = [k for k in dict.fromkeys([*fa, *fb]) if k.rsplit(".", 1)[-1] not in RUN_SPECIFIC]
    missing = object()
    diffs = []
    for k in keys:
        va, vb = fa.get(k, missing), fb.get(k, missing)
        if va is missing or vb is missing or _differs(va, vb, rtol, atol):
            diffs.append((k, "(absent)" if va is missing else va, "(absent)" if vb is missing else vb))
    diffs.sort(key=lambda d: d[0].rsplit(".", 1)[-1] != VERDICT)  # stable: verdicts first, then file order
    return len(keys), diffs
