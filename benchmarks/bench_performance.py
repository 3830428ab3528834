"""Performance on the reference scene: what 1 um of platform accuracy costs in time.

The reference scene (problems/paper_circle.yaml): all 8 clearance joints, Lankarani-Nikravesh
contact, Ambrosio friction, the scene's QP preload, journals seated at t = 0, the full 1 s
circle. One common reference solution: compiled RK4 at h = 1e-6 s, checked against RK4 at
2e-6 s (Richardson: their difference bounds the reference error by about 1/15 of it) and
against cvodes at rtol = 1e-10.

For each method the settings ladder runs from the cheapest (largest step, loosest tolerance)
to the most expensive; the first setting whose max platform-position error against the
reference is <= 1e-6 m is the method's cost at that accuracy. Reported: error, stepping wall
time (build and compilation excluded: compiled methods get a warm-up run first), real-time
factor (simulated / wall) and the ratio scipy time / method time at the same accuracy, all in
one process on one core (BLAS threads limited to 1).

    .venv/bin/python benchmarks/bench_performance.py [T_END] [--scipy-window S]

T_END defaults to 1 s (the full path). --scipy-window S times the scipy baselines on the
first S seconds only and scales their time by T_END / S (say so when quoting the numbers);
their error is then measured on that window.
"""

import argparse
import os
import platform

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import rrr4  # noqa: E402
from rrr4.integrators import RK4, RK45, Bathe, Cvodes, Radau  # noqa: E402

TARGET = 1e-6   # m, max platform-position error
LADDERS = {     # label -> (factory of the method for a setting, settings cheapest first, 'step' | 'rtol')
    "rk4 (C)": (lambda h: RK4(jit=True), [1e-4, 8e-5, 6.25e-5, 5e-5, 4e-5, 2.5e-5, 1e-5], "step"),
    "bathe (C)": (lambda h: Bathe(jit=True), [1e-3, 5e-4, 2.5e-4, 2e-4, 1e-4, 5e-5, 2.5e-5], "step"),
    "cvodes": (lambda r: Cvodes(rtol=r, atol=r * 1e-3), [1e-4, 1e-5, 1e-6, 1e-7, 1e-8], "rtol"),
    "scipy RK45": (lambda r: RK45(rtol=r, atol=r * 1e-3), [1e-3, 1e-4, 1e-5, 1e-6, 1e-7], "rtol"),
    "scipy Radau": (lambda r: Radau(rtol=r, atol=r * 1e-3), [1e-3, 1e-4, 1e-5, 1e-6, 1e-7], "rtol"),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("t_end", nargs="?", type=float, default=1.0)
    ap.add_argument("--scipy-window", type=float, default=None)
    args = ap.parse_args()
    T = args.t_end
    T_scipy = min(args.scipy_window or T, T)
    scene = rrr4.load_scene("problems/paper_circle.yaml")
    pre = rrr4.solve_preload(scene)
    print(f"machine: {platform.machine()} {platform.system()}, {os.cpu_count()} cores, one used; "
          f"{T:g} s simulated (scipy on {T_scipy:g} s{', time scaled' if T_scipy < T else ''})")

    def run(method, t_end, **kw):
        if getattr(method, "jit", False):
            rrr4.simulate(scene, method, t_end=0.002, preload=pre, **kw)   # warm-up: build and compile once
        return rrr4.simulate(scene, method, t_end=t_end, preload=pre, **kw)

    def error(sim, ref):
        k = len(sim.t)
        return float(np.max(np.linalg.norm(sim.pose[:, :2] - ref.pose[:k, :2], axis=1)))

    ref = run(RK4(jit=True), T, step=1e-6)
    half = run(RK4(jit=True), T, step=2e-6)
    cv = run(Cvodes(rtol=1e-10, atol=1e-13), T)
    print(f"reference: rk4 (C) h = 1e-6 s, {ref.stats['wall_time']:.2f} s; "
          f"|rk4 h=2e-6 - ref| = {error(half, ref):.1e} m, "
          f"|cvodes rtol=1e-10 - ref| = {error(cv, ref):.1e} m; contact losses in the reference: "
          f"{sum(ref.contact_loss_events.values())}")

    best = {}
    for label, (make, settings, kind) in LADDERS.items():
        t_run = T_scipy if label.startswith("scipy") else T
        for v in settings:
            try:
                sim = run(make(v), t_run, **({"step": v} if kind == "step" else {}))
            except rrr4.SimulationError as e:  # the step is beyond the method's stability limit
                print(f"  {label:12s} {kind} {v:8.2e}: {e}")
                continue
            err = error(sim, ref)
            wall = sim.stats["wall_time"] * T / t_run
            ok = err <= TARGET
            extra = ""
            if kind == "step":
                extra = f" {sim.stats['steps']} steps"
                if label.startswith("rk4"):
                    extra += f", {sim.stats['wall_time'] / (4 * sim.stats['steps']) * 1e9:.0f} ns per RHS"
                if "newton_iterations_per_step" in sim.stats:
                    extra += f", {sim.stats['newton_iterations_per_step']:.2f} Newton iterations/step"
            else:
                extra = f" {sim.stats.get('steps', 0)} steps, {sim.stats.get('rhs_evaluations', 0)} RHS"
            print(f"  {label:12s} {kind} {v:8.2e}: error {err:8.2e} m, wall {wall:8.3f} s, "
                  f"real-time factor {T / wall:7.2f}{extra}{'  <= 1 um' if ok else ''}", flush=True)
            if ok:
                best[label] = (v, kind, err, wall)
                break
        else:
            print(f"  {label}: no setting of the ladder reaches {TARGET:g} m")

    print(f"\ncheapest setting with max platform error <= {TARGET:g} m over {T:g} s:")
    scipy = {k: v[3] for k, v in best.items() if k.startswith("scipy")}
    base_label = min(scipy, key=scipy.get) if scipy else None
    for label, (v, kind, err, wall) in best.items():
        ratio = f"{scipy[base_label] / wall:8.1f}x" if base_label else "     n/a"
        print(f"  {label:12s} {kind} {v:8.2e}  error {err:8.2e} m  wall {wall:8.3f} s  real-time factor "
              f"{T / wall:7.2f}  {base_label} / method {ratio}")


if __name__ == "__main__":
    main()
