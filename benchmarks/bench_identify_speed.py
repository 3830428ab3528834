"""Speed of method 'staged' on the perturbed reference plant (issue 46, "Speed"): the dynamic
stage's Levenberg-Marquardt with the Jacobian reused (Broyden's update between runs with
sensitivities, refreshed by forward differences of runs without, the exact one asked only at
the estimate), its runs without sensitivities of a refresh and of the sensitivity check rolled
together (DynamicData.run_batch: each chunk of frames one call of the frame mapped over the runs
in CasADi threads) against the same fit with those runs one at a time (variant 'single'), on the
same measurements in one process; 'exact' and 'none' (the exact Jacobian at every accepted step,
the fit before the reuse) on request.

    .venv/bin/python benchmarks/bench_identify_speed.py [--t-end 1.0] [--repeats 1] [--variants differences,single]

The plant and its measurements are benchmarks/bench_identify_staged.py's (11 parameters: the
eight clearances, friction, stiffness, the second chain's driving link; 1 kHz, the noise levels
given). It prints the cost of one run with and without sensitivities and of 11 runs rolled
together, then for each variant the wall time of identify (medians of --repeats; the first call
of the process also loads the compiled frames), the runs with and without sensitivities, the
iterations, the refreshes by differences (batches of 11 runs) and the checks (of 22), and the
estimates' differences between the variants in their standard errors (zero for 'single': the
batch gives the same numbers). Load average before and after: the threads gain only where a
second core is free.

Measured at 1 s, --repeats 2 (2 cores shared with other jobs, load average 1.0 before, 1.4
after): one run 0.26 s, with the sensitivities to the 11 parameters 3.77 s, 11 runs rolled
together 2.62 s; identify 53.4 s (median of 54.4 and 52.5) against 57.2 s one at a time, 15
iterations, 3 runs with sensitivities and 223 without, 8 refreshes; the same estimates to the
last digit. Before this round's sensitivities and refresh rule: 90.3 s, 43 iterations, 331 runs
without sensitivities, 20 refreshes (see the "Speed" paragraph of docs/identification.md).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_identify_staged as staged  # noqa: E402

import rrr4  # noqa: E402
from rrr4.identify import identify, least_squares, resolve_parameters  # noqa: E402
from rrr4.identify.dynamic import DynamicData  # noqa: E402

IDENTIFY = importlib.import_module("rrr4.identify.identify")  # the module (the package exports the function)


class Counted:
    """Counts the simulations (cache misses) of the DynamicData objects made inside: those with
    sensitivities (DynamicData.run's) and without (DynamicData.runs, the counter, less those)."""

    def __init__(self):
        self.sens, self.seen, self.batches = 0, set(), []
        self.original, self.original_batch = DynamicData.run, DynamicData.run_batch

    @property
    def runs(self) -> dict:
        return {True: self.sens, False: sum(d.runs for d in self.seen) - self.sens}

    def __enter__(self):
        counter, original = self, self.original

        def run(data, p, sensitivities=True):
            counter.seen.add(data)
            before = data.runs
            out = original(data, p, sensitivities)
            counter.sens += (data.runs - before) if sensitivities else 0
            return out

        def run_batch(data, P):  # the batches' sizes: 11 a refresh, 22 the check
            counter.batches.append(len(P))
            return counter.original_batch(data, P)

        DynamicData.run, DynamicData.run_batch = run, run_batch
        return self

    def __exit__(self, *exc):
        DynamicData.run, DynamicData.run_batch = self.original, self.original_batch


def one_at_a_time(data, P):
    """DynamicData.run_batch as it was before the batch: one run after the other."""
    return [data.run(p, False)[0] for p in np.atleast_2d(P)]


def one_fit(nominal, m, noise, reuse: str | None, batched: bool = True):
    """identify (staged) with the dynamic stage's Levenberg-Marquardt reusing its Jacobian as
    `reuse` says (None: the exact one at every accepted step), the runs without sensitivities of a
    refresh and of the check rolled together (`batched`) or one at a time: (result, wall [s], runs)."""
    plain, batch = least_squares.levenberg_marquardt, DynamicData.run_batch

    def lm(*args, **kw):
        return plain(*args, **{**kw, "reuse": reuse if kw.get("reuse") else None})

    IDENTIFY.levenberg_marquardt = lm
    if not batched:
        DynamicData.run_batch = one_at_a_time
    try:
        with Counted() as counted:
            wall = time.perf_counter()
            res = identify(nominal, m, list(staged.TRUTH), noise=noise)
            wall = time.perf_counter() - wall
    finally:
        IDENTIFY.levenberg_marquardt, DynamicData.run_batch = plain, batch
    return res, wall, {**counted.runs, "batches": counted.batches}


def run_costs(nominal, m) -> tuple[float, float, float]:
    """Wall time [s] of one run of the record without and with sensitivities (11 directions), and
    of 11 runs without them rolled together (run_batch: a refresh by differences), medians of 3."""
    problem = rrr4.build(nominal)
    data = DynamicData(problem, m, resolve_parameters(problem, list(staged.TRUTH), nominal.data), nominal)
    p = np.array([q.nominal for q in data.params])
    out = []
    for sens in (False, True, "batch"):
        times = []
        for k in range(3):
            data._cache.clear()
            t = time.perf_counter()
            if sens == "batch":
                data.run_batch([data.shifted(p, i, 1e-3 * (k + 1)) for i in range(len(p))])
            else:
                data.run(p * (1 + 1e-9 * k), sens)
            times.append(time.perf_counter() - t)
        out.append(float(np.median(times)))
    return out[0], out[1], out[2]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--variants", default="differences,single",
                    help="comma-separated: differences (the default fit), single (the same with the runs without "
                         "sensitivities one at a time, not rolled together), exact, none (the exact Jacobian at every "
                         "accepted step: the fit before; about 7 min at 1 s)")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}", flush=True)
    nominal, _, m, noise = staged.measured(args.t_end)
    plain_run, sens_run, batch_run = run_costs(nominal, m)
    print(f"one run of {args.t_end:g} s: {plain_run:.2f} s, with 11 sensitivity directions {sens_run:.2f} s "
          f"({sens_run / plain_run:.0f} times); 11 runs rolled together {batch_run:.2f} s "
          f"({batch_run / plain_run:.1f} runs' time, {11 * plain_run / batch_run:.1f} times faster)", flush=True)
    results = {}
    for variant in args.variants.split(","):
        reuse = {"none": None, "single": "differences"}.get(variant, variant)
        walls = []
        for _ in range(args.repeats):
            res, wall, runs = one_fit(nominal, m, noise, reuse, batched=variant != "single")
            walls.append(wall)
            print(f"  reuse {variant}: {wall:.1f} s (seated {res.fit['stages'][0]['wall_time_s']:.1f} s, dynamic "
                  f"{res.fit['stages'][1]['wall_time_s']:.1f} s), runs with sensitivities {runs[True]}, without "
                  f"{runs[False]} (batches of 11, refreshes: {runs['batches'].count(11)}; of 22: "
                  f"{runs['batches'].count(22)}), iterations {res.fit['iterations']}, converged "
                  f"{res.fit['converged']}, chi^2 {res.fit['chi2']:.6f}, "
                  f"sensitivity disagreement {res.fit['sensitivity_disagreement']:.3g}", flush=True)
        results[variant] = res, float(np.median(walls))
        print(f"identify, reuse {variant}: median {results[variant][1]:.1f} s of {args.repeats}", flush=True)
    variants = list(results)
    new, t_new = results[variants[0]]
    for other in variants[1:]:
        old, t_old = results[other]
        print(f"reuse {other} against {variants[0]}: {t_old:.1f} s against {t_new:.1f} s, ratio {t_old / t_new:.1f}")
        print(f"{'parameter':45s} {variants[0]:>14s} {other:>14s} {'diff / se':>10s} {'se ratio':>9s}")
        for k in new.keys:
            i = new.keys.index(k)
            d = (new.estimate[i] - old.estimate[i]) / old.standard_error[i]
            print(f"{k:45s} {new.estimate[i]:14.8g} {old.estimate[i]:14.8g} {d:+10.2e} "
                  f"{new.standard_error[i] / old.standard_error[i]:9.6f}")
        lo = np.max(np.abs(new.interval - old.interval) / old.standard_error[:, None])
        print(f"largest difference of the 95 % intervals' ends: {lo:.2e} standard errors")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
