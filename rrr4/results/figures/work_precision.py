"""The work-precision diagram of the integrators (:func:`rrr4.studies.bench.work_precision`)."""

from __future__ import annotations

import itertools
from pathlib import Path

import matplotlib.pyplot as plt

from ...integrators import METHODS
from ...problem import Problem
from .base import save_figure

__all__ = ["plot_work_precision"]


def plot_work_precision(rows: list[dict], problem: Problem, path: Path, t_end: float, machine: str) -> Path:
    """Error against the time of the stepping, log-log, one line per method (its settings'
    span in the legend, the settings where it blew up noted), the 1 um line and the reference's
    cross-checks. machine: the CPU the times were measured on (in the axis label)."""
    fig, ax = plt.subplots(figsize=(9, 7.8))
    markers = dict(zip(METHODS, itertools.cycle("osD^vP*Xhp<>"), strict=False))
    for method in dict.fromkeys(r["method"] for r in rows if r["status"] != "cross-check"):
        rs = [r for r in rows if r["method"] == method and r["status"] == "ok" and r["error_m"] > 0]
        if not rs:
            continue
        fixed = rs[0]["kind"] == "step"
        settings = [r["setting"] for r in rs]
        span = (f"h {max(settings):.1e}..{min(settings):.1e} s" if fixed
                else f"rtol {max(settings):.0e}..{min(settings):.0e}")
        unstable = [r["setting"] for r in rows if r["method"] == method and r["status"] == "unstable"]
        if unstable:
            span += f"; blows up at {', '.join(f'{v:.1e}' for v in unstable)} s"
        style = markers.get(method, "o") + ("-" if fixed else "--")
        ax.loglog([r["cpu_s"] for r in rs], [r["error_m"] for r in rs], style,
                  label=f"{method} ({'fixed step, compiled C' if fixed else 'adaptive'}: {span})", ms=5)
    ax.axhline(1e-6, color="grey", lw=0.9, ls=":", label="1 um")
    checks = [r for r in rows if r["status"] == "cross-check"]
    note = ", ".join(f"{r['method'].split(',')[0]} {'h' if r['kind'] == 'step' else 'rtol'} = {r['setting']:.2g}:"
                     f" {r['error_m']:.1e} m" for r in checks)
    ax.axhline(max(r["error_m"] for r in checks), color="black", lw=0.9, ls="-.",
               label=f"reference {rows[0]['reference']}; its distance to {note}")
    ax.set_xlabel(f"time of the stepping [s] (one core; {machine})")
    ax.set_ylabel(f"max {problem.model.task_label} position error [m]" if problem.model.task
                  else "max body position error [m]")
    ax.set_title(f"Work-precision on {problem.name}: the first {t_end:g} s of the path simulated, with preload")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2)
    return save_figure(fig, path, dpi=130, bbox_inches="tight")
