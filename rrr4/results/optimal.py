"""The result of ``rrr4 optimize``: an optimal time law, the same law with actuator limits
only, the phase plane's limit curves, the replay (a study of the scene following the law)
and, where the replay lost contact, the f_min headroom that removes the losses; its
summary and its result directory."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..files import atomic_directory, write_atomic
from ..optimal import OptimalMotion, OptimalTimeLaw
from ..problem import Problem
from .figures.optimal import optimal_figures
from .output import write_results
from .study import Study
from .summary import study_summary

__all__ = ["Optimization", "optimization_summary", "write_optimization", "motion_csv", "MARKER"]

MARKER = "optimization.json"


@dataclass(frozen=True)
class Optimization:
    """law: the optimum with the contact condition (where the scene preloads; else with the
    actuator limits only): a time law along the path, or a point-to-point motion; limits_only:
    the optimum with the actuator limits only (None where
    `law` is that already); curves: :func:`rrr4.optimal.limits.limit_curves` (None for a
    motion: its path is free); replay: the
    study of the scene following `law` (None if not replayed); headroom: the f_min search
    (tried f_min values and the replay's contact losses at each; None if not needed)."""
    problem: Problem
    law: OptimalTimeLaw | OptimalMotion
    limits_only: OptimalTimeLaw | OptimalMotion | None
    curves: dict | None
    replay: Study | None = None
    headroom: dict | None = None
    statistics: dict = field(default_factory=dict)


def optimization_summary(opt: Optimization) -> dict:
    """JSON-ready summary: the optimal durations with the contact condition and with the
    actuator limits only, what keeping contact costs, each law's numbers, and per replayed
    arm (named like the study's arms) the study's metrics."""
    law, free = opt.law, opt.limits_only
    out = {"scene": opt.problem.name, "objective": law.objective,
           "optimal_duration_s": law.duration if law.contact else None,
           "optimal_duration_limits_only_s": free.duration if free is not None else law.duration,
           "law": law.summary(), "limits_only": free.summary() if free is not None else None}
    if law.contact and free is not None:
        out["contact_cost_ratio"] = law.duration / free.duration
    if opt.replay is not None:
        s = study_summary(opt.replay)
        out["replay"] = {name: s[name] for name in opt.replay.arms}
        out["replay_controller"] = s["controller"]
    out["headroom"] = opt.headroom
    out["statistics"] = opt.statistics
    return out


def motion_csv(motion) -> str:
    """CSV text of an optimal motion's nodes: t [s], the task pose and its rates, the efforts
    and the null-space efforts."""
    cols = {"t": motion.t[:, None]}
    for name, a in (("", motion.pose), ("_d", motion.pose_d), ("_dd", motion.pose_dd)):
        cols.update({f"{c}{name}": a[:, [i]] for i, c in enumerate(("x", "y", "phi"))})
    cols.update({f"effort_{n}": motion.efforts[:, [i]] for i, n in enumerate(motion.actuator_names)})
    cols.update({f"alpha_{k + 1}": motion.alpha[:, [k]] for k in range(motion.alpha.shape[1])})
    data = np.hstack(list(cols.values()))
    lines = [",".join(cols)] + [",".join(f"{v:.17g}" for v in row) for row in data]
    return "\n".join(lines) + "\n"


def _json(v):
    if isinstance(v, dict):
        return {str(k): _json(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def write_optimization(opt: Optimization, out, animate: bool = True, progress: bool = False) -> tuple[dict, list[str]]:
    """Write `out` atomically: optimization.json, time_law.csv (the table a scene carries),
    time_law_limits_only.csv, the figures (phase plane, efforts against their limits, contact
    margin) and, with a replay, the study's result in replay/. Returns (summary, names)."""
    summary = _json(optimization_summary(opt))
    names: list[str] = []

    def fill(tmp: Path) -> None:
        files = []
        for law, stem in ((opt.law, ""), (opt.limits_only, "_limits_only")):
            if isinstance(law, OptimalTimeLaw):
                files.append(law.save_table(tmp / f"time_law{stem}.csv"))
            elif law is not None:
                files.append(write_atomic(tmp / f"motion{stem}.csv", motion_csv(law)))
        files += optimal_figures(opt, tmp)
        (tmp / MARKER).write_text(json.dumps(summary, indent=2) + "\n")
        files.append(tmp / MARKER)
        names.extend(p.name for p in files)
        if opt.replay is not None:
            _, replay_files = write_results(opt.replay, tmp / "replay", animate=animate, progress=progress)
            names.extend(f"replay/{n}" for n in replay_files)

    atomic_directory(out, fill, MARKER)
    return summary, names
