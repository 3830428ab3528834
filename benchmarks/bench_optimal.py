"""What an optimal time law costs: IPOPT's solve time and the set-up around it at N grid
intervals, on the reference scene, with the contact condition and one contact sign (what
``optimal_time_law`` solves once per sign), and how both grow with N; plus the duration at
each N (its convergence); then a point-to-point motion's solve time at a few node counts.
Medians of --repeat runs in this process; the machine and its
load average are printed with the numbers.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_optimal.py [--points 100 200 500 1000 2000] [--repeat 3]
"""

import argparse
import os
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.codegen.build import machine
from rrr4.optimal import optimal_motion, optimal_time_law

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--points", type=int, nargs="+", default=[100, 200, 500, 1000, 2000])
    ap.add_argument("--nodes", type=int, nargs="*", default=[20, 40, 80])
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    problem = rrr4.build(a.scene)
    optimal_time_law(problem, points=50, sign=1)  # imports and first-call costs out of the way
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.2f} at the start")
    print(f"scene: {problem.name}; contact condition on, sign +1; medians of {a.repeat}")
    print(f"{'N':>6} {'duration [s]':>14} {'iterations':>10} {'solve [s]':>10} {'build [s]':>10} {'total [s]':>10} "
          f"{'solve/N [ms]':>12}")
    rows = []
    for n in a.points:
        runs = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            law = optimal_time_law(problem, points=n, sign=1)
            runs.append((law.statistics["solve_time_s"], law.statistics["build_time_s"], time.perf_counter() - t0))
        solve, build, total = np.median(np.array(runs), axis=0)
        rows.append((n, law.duration, law.statistics["iterations"], solve, build, total))
        print(f"{n:>6} {law.duration:>14.9f} {law.statistics['iterations']:>10} {solve:>10.3f} {build:>10.3f} "
              f"{total:>10.3f} {1e3 * solve / n:>12.3f}")
    if len(rows) > 2:
        n, solve = np.array([r[0] for r in rows], float), np.array([r[3] for r in rows])
        slope = np.polyfit(np.log(n), np.log(solve), 1)[0]
        print(f"solve time grows as N^{slope:.2f} over N = {int(n[0])}..{int(n[-1])}")
    print("point-to-point (optimal_motion), 20 mm along x, contact condition, sign +1:")
    print(f"{'nodes':>6} {'duration [s]':>14} {'iterations':>10} {'solve [s]':>10} {'warm start [s]':>14} "
          f"{'total [s]':>10}")
    for n in a.nodes:
        runs = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            mo = optimal_motion(problem, (0.02, 0.0, 0.0), nodes=n, sign=1)
            runs.append((mo.statistics["solve_time_s"], mo.statistics["warm_start_time_s"], time.perf_counter() - t0))
        solve, warm, total = np.median(np.array(runs), axis=0)
        print(f"{n:>6} {mo.duration:>14.9f} {mo.statistics['iterations']:>10} {solve:>10.3f} {warm:>14.3f} "
              f"{total:>10.3f}")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
