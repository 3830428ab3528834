"""Time per path point of each preload method, as ratios against the exact closed form,
all measured in one run on one machine.

    .venv/bin/python benchmarks/bench_preload.py [SCENE] [--repeat R]

Each pointwise method is its CasADi Function mapped over all N path samples
(``Function.map(N)``, one call), evaluated on the same inverse-dynamics outputs; the QP
rows use ``casadi.conic`` with each plugin. The NLP row is one ipopt solve over the whole
horizon (every sample), initialised with the qrqp solution. The inverse dynamics itself
is listed for scale. Times are the best of R repeats after one warm-up call; Functions
are built before timing.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import rrr4
from rrr4 import load_scene
from rrr4.preload.exact import exact_preload_function
from rrr4.preload.nlp import solve_trajectory_nlp
from rrr4.preload.qp import qp_preload_function
from rrr4.trajectory import sample_path

ROOT = Path(__file__).resolve().parents[1]


def best_time(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    scene = load_scene(args.scene)
    s = sample_path(scene.path)
    N = len(s.t)
    fam = rrr4.build(scene).effort_family(s.pose, s.pose_d, s.pose_dd)
    raw, tau_p, tau_n, r_p, r_n = fam.raw, fam.tau_p, fam.tau_n, fam.r_p, fam.r_n
    pre = scene.actuation.preload

    rows: list[tuple[str, float, str]] = []
    inv = rrr4.build(scene).inverse_dynamics().map(N)
    rows.append(("inverse dynamics (for scale)", best_time(lambda: inv(s.pose.T, s.pose_d.T, s.pose_dd.T),
                                                           args.repeat), "SX, map"))
    exact = exact_preload_function(rrr4.build(scene)).map(N)
    rows.append(("exact", best_time(lambda: exact(*raw), args.repeat), "closed form, SX, map"))
    alpha0 = None
    for solver in ("qrqp", "osqp", "daqp", "qpoases"):
        f = qp_preload_function(rrr4.build(scene), solver, 1.0).map(N)
        rows.append((f"qp {solver}", best_time(lambda f=f: f(*raw), args.repeat), "conic, map"))
        if solver == "qrqp":
            alpha0 = np.array(f(*raw)[0]).T

    def nlp():
        solve_trajectory_nlp(s.t, tau_p, tau_n, r_p, r_n, f_min=pre.min_force, weights=pre.weights,
                             limits=scene.torque_limit, smoothness_weight=pre.smoothness_weight,
                             max_turn_rate=pre.max_turn_rate, alpha0=alpha0)
    rows.append(("nlp (ipopt, whole horizon)", best_time(nlp, max(1, args.repeat // 2)), f"{N} grid points"))

    base = dict((r[0], r[1]) for r in rows)["exact"]
    print(f"# preload time per path point: {scene.name}, N = {N} samples, best of {args.repeat}")
    print(f"# machine: {platform.machine()} {platform.system()}, {os.cpu_count()} cores, "
          f"Python {sys.version.split()[0]}, CasADi {ca.__version__}")
    print("| method | time per point [us] | ratio to exact | note |")
    print("| --- | ---: | ---: | --- |")
    for name, t, note in rows:
        print(f"| {name} | {1e6 * t / N:.2f} | {t / base:.2f} | {note} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
