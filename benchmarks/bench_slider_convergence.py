"""Convergence of Flores's slider-crank with clearance under step refinement.

Two questions, both on problems/flores_slider_crank.yaml (compiled RK4, a step across a
contact onset or loss re-taken as `--refine` sub-steps):

1. The motion: max distance of the slider's centre of mass to a reference run (the finest
   step / 2) over the first 1, 2 and 3 ms (the first impacts), for steps 2e-6 .. 1.25e-7 s.
2. The statistics of the rattling over `--revolutions` crank revolutions after the first
   (the start transient): impacts per revolution, the free-flight fraction, the median over
   revolutions of the peak slider acceleration and of the peak contact force, per step;
3. the same statistics at h = 1e-6 s with the crank's start angle moved by 1e-7 .. 3e-7 rad:
   the spread the chaos of the rattling gives by itself.

    .venv/bin/python benchmarks/bench_slider_convergence.py [--revolutions 20] [--refine 16]

About 2.5 minutes on a 2-core machine with the defaults.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.integrators import RK4

ROOT = Path(__file__).resolve().parents[1]
STEPS = (2e-6, 1e-6, 5e-7, 2.5e-7, 1.25e-7)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--revolutions", type=int, default=20)
    ap.add_argument("--refine", type=int, default=16)
    args = ap.parse_args(argv)
    scene = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    model = rrr4.Model.of(scene.graph)
    x = model.coordinates("slider").start
    n = args.revolutions
    rev = 2 * np.pi / abs(scene.graph.drivers[0].speed)

    def run(h, t_end, rate, sc=scene):
        return rrr4.simulate(sc, RK4(jit=True, refine=args.refine), step=h, output_rate=rate, t_end=t_end)

    def statistics(sim):
        k = np.floor(sim.t / rev).astype(int)
        keep = k >= 1
        c = sim.penetration[:, 0] > 0
        onsets = np.flatnonzero(~c[:-1] & c[1:]) + 1
        onsets = onsets[keep[onsets]]
        peaks = [np.abs(sim.qdd[k == r, x]).max() for r in range(1, n + 1)]
        forces = [sim.normal_force[k == r, 0].max() for r in range(1, n + 1)]
        return (f"{len(onsets) / n:.2f} | {np.mean(~c[keep]):.3f} | {np.median(peaks):.4g} | "
                f"{np.median(forces):.4g}")

    print(f"1. slider position against the run at h = {STEPS[-1] / 2:.3g} s (refine {args.refine}):")
    ref = run(STEPS[-1] / 2, 3e-3, 1e5)
    print("| step [s] | first 1 ms [m] | first 2 ms [m] | first 3 ms [m] |\n|---|---|---|---|")
    for h in STEPS:
        sim = run(h, 3e-3, 1e5)
        d = np.abs(sim.q[:, x] - ref.q[:, x])
        print(f"| {h:.3g} | " + " | ".join(f"{d[ref.t <= w].max():.2e}" for w in (1e-3, 2e-3, 3e-3)) + " |")

    print(f"\n2. statistics over revolutions 2..{n + 1} (refine {args.refine}):")
    print("| step [s] | impacts per revolution | free-flight fraction | median peak slider acceleration [m/s^2] "
          "| median peak contact force [N] | wall [s] |\n|---|---|---|---|---|---|")
    for h in STEPS[1:]:
        t0 = time.perf_counter()
        sim = run(h, (n + 1) * rev, 1 / h)
        wall = time.perf_counter() - t0
        print(f"| {h:.3g} | {statistics(sim)} | {wall:.1f} |", flush=True)

    print("\n3. at h = 1e-6 s, the crank's start angle moved:")
    print("| start angle [rad] | impacts per revolution | free-flight fraction | median peak slider acceleration "
          "[m/s^2] | median peak contact force [N] |\n|---|---|---|---|---|")
    for d_angle in (1e-7, 2e-7, 3e-7):
        driver = dataclasses.replace(scene.graph.drivers[0], initial=scene.graph.drivers[0].initial + d_angle)
        moved = dataclasses.replace(scene, graph=dataclasses.replace(scene.graph, drivers=(driver,)))
        print(f"| {d_angle:.0e} | {statistics(run(1e-6, (n + 1) * rev, 1e6, moved))} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
