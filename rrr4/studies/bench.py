"""What accuracy costs in time: work-precision of the integrators on one scene.

:func:`work_precision` runs each method over a range of steps (fixed-step methods) or
tolerances (adaptive methods, atol = 1e-3 rtol) and measures

- error [m]: max over the output instants of the platform-position distance (without a
  task body: the largest centre-of-mass distance of any body) to one common reference
  solution for all methods: compiled RK4 at a step 4x below the finest RK4 setting
  of the plan, cross-checked against RK4 at twice that step (Richardson: the reference error
  is about 1/15 of their difference) and against cvodes at rtol = 1e-10; both checks are
  rows of the result (status 'cross-check');
- cost [s]: time of the stepping only (stats['wall_time'], one process, one core). The
  fixed-step methods step in compiled C (jit); a warm-up run builds and compiles each setting
  first (the library is cached), so compilation is excluded.

A setting whose state blows up (non-finite: beyond the method's stability limit, or the
solver gave up) is kept as a row with status 'unstable' instead of failing the bench.
:func:`write_work_precision` writes the log-log figure and the CSV.
"""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..codegen.build import machine
from ..errors import SimulationError
from ..files import write_atomic
from ..integrators import METHODS, RK4, Cvodes
from ..preload import solve_preload
from ..problem import Problem
from ..scene import Scene
from ..simulation import simulate

__all__ = ["work_precision", "write_work_precision", "DEFAULT_PLAN"]

CROSS_CHECK_RTOL = 1e-10    # cvodes tolerance of the reference's cross-check
_RATIO = 4                  # reference step = finest RK4 step / _RATIO

# method -> ("step", [s]) or ("rtol", [-]) from each method's capabilities; steps are rounded
# so whole steps fill an output interval
DEFAULT_PLAN = {name: ("rtol" if m.adaptive else "step", list(m.ladder)) for name, m in METHODS.items()}


def _preload(problem: Problem):
    return solve_preload(problem) if problem.mode == "torque" else None


def work_precision(scene: Scene | Problem, t_end: float | None = None, plan: dict | None = None,
                   progress: bool = False) -> list[dict]:
    """Rows {method, kind, setting, status, error_m, cpu_s, steps, reference} for each run of `plan`.

    kind: 'step' (setting = the step taken [s]) or 'rtol'; status: 'ok', 'unstable' (error and
    time NaN) or 'cross-check' (the two checks of the reference, first in the list).
    t_end [s] defaults to the path duration. The controller runs continuously (a sampled one
    would cap every step at its period) with the preload tabulated once, so only the
    integrators differ between runs.
    """
    scene = Problem.from_scene(scene).scene
    problem = Problem.from_scene(replace(scene, actuation=replace(scene.actuation, control_rate=None)))
    scene = problem.scene
    task = problem.model.task is not None
    plan = DEFAULT_PLAN if plan is None else plan
    t_end = scene.path.duration if t_end is None else float(t_end)
    preload = _preload(problem)
    runs = [(m, kind, v) for m, (kind, vals) in plan.items() for v in vals]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(runs) + 3, desc=f"bench accuracy ({scene.name}, {t_end:g} s)", unit="run")
    try:  # the bar is closed before an error reaches the user, so nothing prints after it
        warm_up = 2.0 / scene.path.sample_rate  # two output intervals: same step Function as the timed run

        def run(method, **kw):
            if method.jit:
                simulate(problem, method, t_end=warm_up, preload=preload, **kw)
            sim = simulate(problem, method, t_end=t_end, preload=preload, **kw)
            if bar is not None:
                bar.update()
            return sim

        finest = min([v for m, k, v in runs if m == "rk4"] or [scene.integrator.step])
        ref = run(RK4(jit=True), step=finest / _RATIO)
        name = f"rk4 (C), h = {ref.stats['step']:.3g} s"

        def error(sim) -> float:
            return float(np.max(np.linalg.norm(_positions(sim, task) - _positions(ref, task), axis=2)))

        def row(method, kind, setting, status, sim=None):
            return {"method": method, "kind": kind, "setting": setting, "status": status,
                    "error_m": error(sim) if sim is not None else float("nan"),
                    "cpu_s": float(sim.stats["wall_time"]) if sim is not None else float("nan"),
                    "steps": int(sim.stats.get("steps", 0)) if sim is not None else 0, "reference": name}

        rows = [row("rk4 (C), 2x reference step", "step", 2 * ref.stats["step"], "cross-check",
                    run(RK4(jit=True), step=2 * ref.stats["step"])),
                row("cvodes", "rtol", CROSS_CHECK_RTOL, "cross-check",
                    run(Cvodes(rtol=CROSS_CHECK_RTOL, atol=CROSS_CHECK_RTOL * 1e-3)))]
        for method, kind, v in runs:
            if kind == "step":
                integrator, kw = METHODS[method](jit=True), {"step": v}
            else:
                integrator, kw = METHODS[method](rtol=v, atol=v * 1e-3), {}
            try:
                sim = run(integrator, **kw)
            except SimulationError:  # non-finite state: beyond the stability limit, or the solver gave up
                if bar is not None:
                    bar.update()
                taken = _step_taken(scene.path.sample_rate, t_end, v) if kind == "step" else v
                rows.append(row(method, kind, taken, "unstable"))
                continue
            rows.append(row(method, kind, sim.stats["step"] if kind == "step" else v, "ok", sim))
    finally:
        if bar is not None:
            bar.close()
    return rows


def _positions(sim, task: bool) -> np.ndarray:
    """(N, k, 2) positions [m] the error is measured on: the task body's centre of mass, or
    without a task body (task False: a driven scene) every body's."""
    if task:
        return sim.pose[:, None, :2]
    q = sim.q.reshape(len(sim.t), -1, 3)
    return q[:, :, :2]


def _step_taken(sample_rate: float, t_end: float, h: float) -> float:
    """The step simulate takes for a requested step h [s] (whole steps per output interval of
    the path's sample rate [Hz])."""
    n_frames = max(int(round(t_end * sample_rate)), 1)
    dt_out = t_end / n_frames
    return dt_out / max(int(round(dt_out / h)), 1)


def write_work_precision(rows: list[dict], scene: Scene | Problem, out_dir, t_end: float) -> list[Path]:
    """Write <scene>.csv and the log-log figure <scene>.png
    (:func:`rrr4.results.figures.plot_work_precision`) into out_dir; returns the paths."""
    from ..results.figures import plot_work_precision
    problem = Problem.from_scene(scene)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    csv_path, png_path = out / f"{problem.name}.csv", out / f"{problem.name}.png"
    text = io.StringIO(newline="")
    w = csv.DictWriter(text, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    write_atomic(csv_path, text.getvalue())
    plot_work_precision(rows, problem, png_path, t_end, machine())
    return [png_path, csv_path]
