"""What an optimal time law costs, on the reference scene with the contact condition and one
contact sign (what ``optimal_time_law`` solves once per sign):

1. the solvers side by side at --compare N (1000) on the same coefficients in this process:
   rrr4's reachability analysis (TOPP-RA, the default) and its convex program (IPOPT), each
   as the whole ``optimal_time_law`` call and as its solve; the same reachability problem
   (alpha projected out by rrr4) solved by toppra (Pham and Pham 2018, its Cython Seidel);
   the same convex program (both sides of every point, alpha free) by cvxpy with clarabel.
   toppra and cvxpy + clarabel run where installed (``pip install -e .[bench]``). Ratios
   of wall times against rrr4's reachability on the projected rows (what toppra is given);
   the process's CPU time besides (the machine is shared);
2. both of rrr4's solvers at N grid intervals (--points): time, duration, growth in N, and
   their difference (the two discretisations converge to the same law);
3. a point-to-point motion's solve time at a few node counts.

Medians of --repeat runs in this process; the machine and its load average are printed with
the numbers.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_optimal.py [--compare 1000] \
        [--points 100 200 500 1000 2000] [--repeat 3]
"""

import argparse
import os
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.codegen.build import machine
from rrr4.optimal import optimal_motion, optimal_time_law
from rrr4.optimal.reachability import point_rows, project_out, time_optimal_speeds
from rrr4.optimal.time_law import SOLVERS, time_law_functions

ROOT = Path(__file__).resolve().parents[1]


def duration_of(b, ds) -> float:
    """The duration [s] of a law with b = s_dot^2 on a uniform grid (constant s_ddot per segment)."""
    sd = np.sqrt(np.maximum(b, 0.0))
    return float(np.sum(2 * ds / (sd[:-1] + sd[1:])))


CPU = {}   # name -> median CPU time [s] of this process (the machine is shared: wall times wait)


def median_run(f, repeat, name=None):
    """(median wall time [s], the last result) of f() over `repeat` runs; the median CPU time
    of the process goes to CPU[name]."""
    times, cpu, out = [], [], None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    CPU[name] = float(np.median(cpu))
    return float(np.median(times)), out


def rrr4_reachability(F, lo, hi, N):
    """rrr4's reachability analysis on the functions F: projection, sets and passes -> duration."""
    G, h, _ = point_rows(F, lo, hi, np.zeros(len(lo), bool))
    G2, h2 = project_out(G, h)
    b, _ = time_optimal_speeds(G2, h2, 1.0 / N, np.full(N + 1, 1e8), 0.0, 0.0)
    return duration_of(b, 1.0 / N)


def toppra_solve(G2, h2, N):
    """toppra's TOPPRA (its Cython Seidel solver) on rrr4's projected rows, with the scheme of
    rrr4's (interpolation: each point with the accelerations of both its segments) -> duration;
    None if not installed."""
    try:
        import toppra
        from toppra.constraint import DiscretizationType, LinearConstraint, canlinear_colloc_to_interpolate
    except ImportError:
        return None

    class Rows(LinearConstraint):
        def __init__(self):
            super().__init__()
            self.identical, self.discretization_type = True, DiscretizationType.Interpolation
            self.a, self.b, self.c = G2[0].T.copy(), G2[1].T.copy(), -h2.T.copy()
            self.F, self.g = np.eye(self.a.shape[1]), np.zeros(self.a.shape[1])

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            return canlinear_colloc_to_interpolate(self.a, self.b, self.c, self.F, self.g, None, None, gridpoints,
                                                   identical=True)

    s = np.linspace(0.0, 1.0, N + 1)
    path = toppra.SplineInterpolator(s, np.column_stack([s, s]))
    algo = toppra.algorithm.TOPPRA([Rows()], path, gridpoints=s, solver_wrapper="seidel")
    sdd, sd, _, _ = algo.compute_parameterization(0.0, 0.0, return_data=True)
    return None if sd is None else duration_of(np.asarray(sd) ** 2, 1.0 / N)


def cvxpy_program(F, lo, hi, N):
    """The convex program of rrr4's 'convex' solver in cvxpy (b, c <= sqrt(b), alpha per point;
    every function on both sides of every point): (problem, b) or None if not installed."""
    try:
        import cvxpy as cp
    except ImportError:
        return None
    ds, m = 1.0 / N, F.shape[2] - 3
    b, c = cp.Variable(N + 1), cp.Variable(N + 1)
    alpha = cp.Variable((N + 1, m)) if m else None
    a_seg = (b[1:] - b[:-1]) / (2 * ds)
    cons = [b[0] == 0, b[N] == 0, c >= 0, cp.square(c) <= b]
    for a in (cp.hstack([a_seg, a_seg[N - 1:]]), cp.hstack([a_seg[:1], a_seg])):
        for f in range(F.shape[1]):
            v = cp.multiply(F[:, f, 0], a) + cp.multiply(F[:, f, 1], b) + F[:, f, -1]
            if m:
                v = v + cp.sum(cp.multiply(F[:, f, 2:2 + m], alpha), axis=1)
            cons += [v <= hi[f]] if np.isfinite(hi[f]) else []
            cons += [v >= lo[f]] if np.isfinite(lo[f]) else []
    prob = cp.Problem(cp.Minimize(cp.sum(2 * ds * cp.inv_pos(c[:-1] + c[1:]))), cons)
    return prob, b


def compare_solvers(problem, N, repeat):
    """Section 1 of the module docstring."""
    print(f"solvers side by side at N = {N} (contact condition, sign +1; medians of {repeat}; times [s]):")
    rows = []
    for solver in SOLVERS:
        name = f"rrr4 {solver}: whole call"
        wall, law = median_run(lambda s=solver: optimal_time_law(problem, points=N, sign=1, solver=s), repeat, name)
        solve = float(np.median([optimal_time_law(problem, points=N, sign=1, solver=solver).statistics["solve_time_s"]
                                 for _ in range(repeat)]))
        rows += [(name, law.duration, wall), (f"rrr4 {solver}: solve", law.duration, solve)]
    fam, F, lo, hi, _ = time_law_functions(problem, N, sign=1)
    name = "rrr4 reachability on F (projection, sets, passes)"
    wall, T = median_run(lambda: rrr4_reachability(F, lo, hi, N), repeat, name)
    rows.append((name, T, wall))
    G, h, _ = point_rows(F, lo, hi, np.zeros(len(lo), bool))
    G2, h2 = project_out(G, h)
    name = "rrr4 reachability on the projected rows"
    wall, T = median_run(lambda: duration_of(time_optimal_speeds(G2, h2, 1.0 / N, np.full(N + 1, 1e8), 0.0, 0.0)[0],
                                             1.0 / N), repeat, name)
    rows.append((name, T, wall))
    toppra_solve(G2[:, :, ::100], h2[:, ::100], len(range(0, N + 1, 100)) - 1)   # its imports out of the way
    name = "toppra (seidel) on rrr4's projected rows"
    wall, T = median_run(lambda: toppra_solve(G2, h2, N), repeat, name)
    rows.append((name, T, wall) if T is not None else
                ("toppra: not installed (pip install -e .[bench])", None, None))
    built = cvxpy_program(F, lo, hi, N)
    if built is None:
        rows.append(("cvxpy + clarabel: not installed (pip install -e .[bench])", None, None))
    else:
        prob, b = built
        import cvxpy as cp
        cvxpy_program(F[::100], lo, hi, len(F[::100]) - 1)[0].solve(solver=cp.CLARABEL)   # its first-call costs
        name = "cvxpy + clarabel (canonicalisation and solve)"
        wall, _ = median_run(lambda: prob.solve(solver=cp.CLARABEL), repeat, name)
        rows.append((name, duration_of(b.value, 1.0 / N), wall))
        rows.append(("cvxpy + clarabel: clarabel's solve time", duration_of(b.value, 1.0 / N),
                     float(prob.solver_stats.solve_time)))
    base = dict((r[0], r[2]) for r in rows)["rrr4 reachability on the projected rows"]
    print(f"{'':52s} {'duration [s]':>13} {'wall [s]':>10} {'CPU [s]':>8} {'wall / rrr4 on the projected rows':>34}")
    for name, T, wall in rows:
        if T is None:
            print(f"{name}")
            continue
        cpu = f"{CPU[name]:.4f}" if name in CPU else ""
        print(f"{name:52s} {T:>13.9f} {wall:>10.4f} {cpu:>8} {wall / base:>34.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--points", type=int, nargs="+", default=[100, 200, 500, 1000, 2000])
    ap.add_argument("--nodes", type=int, nargs="*", default=[20, 40, 80])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--compare", type=int, default=1000, help="N of the side-by-side comparison (0: none)")
    a = ap.parse_args(argv)
    problem = rrr4.build(a.scene)
    for solver in SOLVERS:   # imports and first-call costs out of the way
        optimal_time_law(problem, points=50, sign=1, solver=solver)
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.2f} at the start")
    print(f"scene: {problem.name}; contact condition on, sign +1; medians of {a.repeat}")
    if a.compare:
        compare_solvers(problem, a.compare, a.repeat)
        print(f"load average {os.getloadavg()[0]:.2f}")
    durations = {}
    for solver in SOLVERS:
        print(f"rrr4 {solver}:")
        print(f"{'N':>6} {'duration [s]':>14} {'solve [s]':>10} {'build [s]':>10} {'total [s]':>10} "
              f"{'solve/N [ms]':>12}")
        rows = []
        for n in a.points:
            runs = []
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                law = optimal_time_law(problem, points=n, sign=1, solver=solver)
                runs.append((law.statistics["solve_time_s"], law.statistics["build_time_s"],
                             time.perf_counter() - t0))
            solve, build, total = np.median(np.array(runs), axis=0)
            rows.append((n, solve, total))
            durations[solver, n] = law.duration
            print(f"{n:>6} {law.duration:>14.9f} {solve:>10.4f} {build:>10.4f} {total:>10.4f} "
                  f"{1e3 * solve / n:>12.4f}")
        if len(rows) > 2:
            n, solve, total = (np.array(v, float) for v in zip(*rows, strict=True))
            print(f"solve time grows as N^{np.polyfit(np.log(n), np.log(solve), 1)[0]:.2f}, the whole call as "
                  f"N^{np.polyfit(np.log(n), np.log(total), 1)[0]:.2f} over N = {int(n[0])}..{int(n[-1])}")
    print("the two discretisations: relative difference of the durations (convex - reachability) / convex")
    for n in a.points:
        d = durations["convex", n] - durations["reachability", n]
        print(f"{n:>6} {d / durations['convex', n]:>12.3e}   N x difference {n * d / durations['convex', n]:.4f}")
    print(f"load average {os.getloadavg()[0]:.2f}")
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
