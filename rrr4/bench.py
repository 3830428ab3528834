"""What accuracy costs in time: work-precision of the integrators on one scene.

:func:`work_precision` runs each method over a range of steps (fixed-step methods) or
tolerances (adaptive methods) and measures

- error [m]: max over the output instants of the platform-position distance to a
  reference solution of the same discrete contact model: fixed-step methods (contact state
  updated every step) against RK4 at a step 10x below the finest one, adaptive methods
  (contact state updated at output instants) against cvodes at rtol = 1e-12;
- cost [s]: CPU time of the stepping (stats['wall_time']: graph building excluded, same
  process, no JIT, so the numbers compare methods, not compilers).

:func:`write_work_precision` writes the log-log figure and the CSV.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .scene import Scene
from .simulation import simulate

__all__ = ["work_precision", "write_work_precision", "DEFAULT_PLAN"]

# method -> ("step", [s]) or ("rtol", [-])
DEFAULT_PLAN = {
    "bathe": ("step", [4e-5, 2e-5, 1e-5, 5e-6]),
    "newmark": ("step", [4e-5, 2e-5, 1e-5, 5e-6]),
    "generalized-alpha": ("step", [4e-5, 2e-5, 1e-5, 5e-6]),
    "rk4": ("step", [2e-5, 1e-5, 5e-6, 2.5e-6]),
    "erk": ("rtol", [1e-5, 1e-7, 1e-9]),
    "cvodes": ("rtol", [1e-5, 1e-7, 1e-9]),
    "rosenbrock": ("rtol", [1e-5, 1e-7]),
    "rk45": ("rtol", [1e-5, 1e-7, 1e-9]),
}


def _preload(scene: Scene):
    if scene.actuation.mode != "torque":
        return None
    from .preload import solve_preload
    return solve_preload(scene)


def work_precision(scene: Scene, t_end: float = 0.02, plan: dict | None = None, progress: bool = False) -> list[dict]:
    """Rows {method, kind, setting, error_m, cpu_s, steps, reference} for each run of `plan`."""
    plan = DEFAULT_PLAN if plan is None else plan
    preload = _preload(scene)
    runs = [(m, kind, v) for m, (kind, vals) in plan.items() for v in vals]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(runs) + 2, desc=f"bench accuracy ({scene.name})", unit="run")
    finest = min([v for _, k, v in runs if k == "step"] or [scene.integrator.step])
    common = {"t_end": t_end, "preload": preload}
    refs = {"step": simulate(scene, "rk4", step=finest / 10, **common)}
    if bar is not None:
        bar.update()
    from .integrators import Cvodes
    refs["rtol"] = simulate(scene, Cvodes(rtol=1e-12, atol=1e-14), **common)
    if bar is not None:
        bar.update()
    names = {"step": f"rk4, h = {finest / 10:.2g} s", "rtol": "cvodes, rtol = 1e-12"}
    rows = []
    for method, kind, v in runs:
        if kind == "step":
            sim = simulate(scene, method, step=v, **common)
        else:
            from .integrators import METHODS
            sim = simulate(scene, METHODS[method](rtol=v, atol=v * 1e-3), **common)
        ref = refs[kind]
        err = np.linalg.norm(sim.pose[:, :2] - ref.pose[:, :2], axis=1)
        rows.append({"method": method, "kind": kind, "setting": v,
                     "error_m": float(np.max(err)) if np.all(np.isfinite(err)) else float("nan"),
                     "cpu_s": float(sim.stats["wall_time"]), "steps": int(sim.stats.get("steps", 0)),
                     "reference": names[kind]})
        if bar is not None:
            bar.update()
    if bar is not None:
        bar.close()
    return rows


def write_work_precision(rows: list[dict], scene: Scene, out_dir, t_end: float) -> list[Path]:
    """Write <scene>.csv and the log-log figure <scene>.png into out_dir; returns the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    csv_path, png_path = out / f"{scene.name}.csv", out / f"{scene.name}.png"
    with csv_path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    for method in dict.fromkeys(r["method"] for r in rows):
        rs = [r for r in rows if r["method"] == method and np.isfinite(r["error_m"]) and r["error_m"] > 0]
        if not rs:
            continue
        style = "o-" if rs[0]["kind"] == "step" else "s--"
        label = f"{method} ({'fixed step' if rs[0]['kind'] == 'step' else 'adaptive, rtol'})"
        ax.loglog([r["cpu_s"] for r in rs], [r["error_m"] for r in rs], style, label=label)
    ax.axhline(1e-6, color="grey", lw=0.8, ls=":")
    ax.text(ax.get_xlim()[0], 1e-6, " 1 um", va="bottom", color="grey", fontsize=8)
    ax.set_xlabel("CPU time of the stepping [s] (no JIT, one core)")
    ax.set_ylabel("max platform position error [m]")
    ax.set_title(f"Work-precision on {scene.name}: {t_end:g} s simulated, with preload")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=130)
    plt.close(fig)
    return [png_path, csv_path]
