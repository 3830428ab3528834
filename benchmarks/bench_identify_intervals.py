"""Wall time of method 'seated' with its intervals (issue 46): what the profile likelihood and
the graph model cost, as ratios against the plain seated fit in the same process, medians of
repeated runs, the machine's load named.

    .venv/bin/python benchmarks/bench_identify_intervals.py [--repeats N] [--instants N]

Cases (measurements from the seated model itself at the true parameters, 1 um on the pose,
1e-5 rad on the orientation, 1 % on the efforts, noise seed 0):
- 'reference, clearance + friction + link' (baseline): every interval linearised (Wald);
- 'reference, + stiffness (K / 20)': the stiffness, fitted in log, gets its profile interval;
- 'five-bar, clearance + friction': the graph seated model (loops closed by chord iterations).
The first call of a parameter layout builds its CasADi Function (reported apart).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.identify import Measurements, identify, resolve_parameters
from rrr4.identify.seated import seated_measurements

ROOT = Path(__file__).resolve().parents[1]
C, F, K, L = ("joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness",
              "mechanism.chains[0].driving_link.length")
SHIFTS = {C: 0.15, F: 0.5, K: np.log(0.05), L: 0.3}


def case(scene: str, keys: list[str], instants: int):
    problem = rrr4.build(rrr4.load_scene(ROOT / "problems" / scene))
    params = resolve_parameters(problem, keys)
    truth = [q.value(q.coordinate(q.nominal) + SHIFTS[q.key]) for q in params]
    clean = seated_measurements(problem, params, truth, np.linspace(0.0, 1.0, instants))
    rng = np.random.default_rng(0)
    noise = {"x_m": 1e-6, "y_m": 1e-6, "theta_rad": 1e-5,
             **{c: 0.01 * float(np.sqrt(np.mean(v ** 2))) for c, v in clean.columns.items() if c.startswith("tau_")}}
    m = Measurements(clean.t, {c: v + noise[c] * rng.standard_normal(v.size) if c in noise else v
                               for c, v in clean.columns.items()})
    return problem, m, keys


def timed(problem, m, keys, repeats: int):
    t0 = time.perf_counter()
    res = identify(problem, m, keys, method="seated")
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        identify(problem, m, keys, method="seated")
        times.append(time.perf_counter() - t0)
    return first, statistics.median(times), res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--instants", type=int, default=1001)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    cases = [("reference, clearance + friction + link", "paper_circle.yaml", [C, F, L]),
             ("reference, + stiffness (K / 20)", "paper_circle.yaml", [C, F, K, L]),
             ("five-bar, clearance + friction", "redundant_five_bar.yaml", [C, F])]
    base = None
    print(f"{'case':42s} {'first [s]':>10s} {'median [s]':>11s} {'ratio':>6s}  intervals")
    for name, scene, keys in cases:
        first, med, res = timed(*case(scene, keys, args.instants), args.repeats)
        base = base or med
        how = ", ".join(f"{k.split('.')[-1]} {v}" for k, v in res.fit["intervals"].items())
        print(f"{name:42s} {first:10.2f} {med:11.2f} {med / base:6.2f}  {how}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
