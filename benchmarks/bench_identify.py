"""Wall time of rrr4.identify on the reference scene (issue 33: method 'seated' on 1 s of data
at 1 kHz, 8 clearances + friction + stiffness, aim under 5 s; method 'dynamic' on a 0.1 s
window), medians of repeated runs in one process, with the machine and its load named.

    .venv/bin/python benchmarks/bench_identify.py [SCENE] [--repeats N]

Cases:
- 'synthetic, 10 parameters': measurements from the seated model itself (1 um on the pose,
  1 % on the efforts), fitted for the 8 per-joint clearances, the friction coefficient and
  the contact stiffness (an unidentifiable set: the B/C pairs of a chain; the verdict says
  so, the time is what counts here);
- 'synthetic, 3 parameters': clearance, friction coefficient, contact stiffness;
- 'simulated, 3 parameters': a 1 s simulation of the mechanism with 20 % more clearance
  under the nominal preloaded controller (the simulation's time not counted).
- 'dynamic, 0.1 s window': method 'dynamic' (single shooting through the compiled stepping
  with its forward sensitivities) on the first 0.1 s of that simulated run, clearance and
  friction.
- 'dynamic, 30 ms' and 'dynamic, 30 ms, 3 windows': the clearance from the first 30 ms of
  that run, by single shooting and by multiple shooting over 3 windows of 10 ms (the states at
  10 and 20 ms as 76 extra unknowns), a span both can do: their estimates, standard errors
  and times side by side.
The first fit of a parameter layout builds its CasADi Function (reported apart; method
'dynamic' compiles its sensitivity frame once, cached on disk); the repeats reuse it, as a
user's second call does.

Then one Jacobian of method 'dynamic' on that window: the forward sensitivities (one run
with a direction per parameter gives the residuals and their Jacobian) against forward
differences of whole runs (one run plus one per parameter: how the method differentiated
before) and central differences (two runs per parameter: what the method checks its
sensitivities with), medians of the repeats, as ratios.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

import rrr4
from rrr4.codegen.build import machine
from rrr4.identify import identify, measurements_from_simulation, resolve_parameters
from rrr4.identify.dynamic import DynamicData
from rrr4.identify.seated import seated_measurements
from rrr4.studies.robustness import perturbed
from rrr4.studies.study import arm_scene

ROOT = Path(__file__).resolve().parents[1]
CLEARANCES = [f"joints.per_joint.{j}.radial_clearance" for j in ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")]
DEFAULT = ["joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness"]


def synthetic(problem, keys, seed=0):
    params = resolve_parameters(problem, keys)
    rng = np.random.default_rng(seed)
    truth = [q.value(q.coordinate(q.nominal) + 0.1 * rng.standard_normal()) for q in params]
    t = np.linspace(0.0, 1.0, 1001)
    clean = seated_measurements(problem, params, truth, t)
    noise = {"x_m": 1e-6, "y_m": 1e-6, "theta_rad": 1e-5}
    noise.update({c: 0.01 * float(np.sqrt(np.mean(v ** 2))) for c, v in clean.columns.items() if c.startswith("tau_")})
    return seated_measurements(problem, params, truth, t, noise, rng)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    problem = rrr4.build(rrr4.load_scene(args.scene))
    plant = rrr4.build(perturbed(problem, "clearance +20 %"))
    sim = rrr4.simulate(arm_scene(plant, "with_preload"), t_end=1.0, model=arm_scene(problem, "with_preload"))
    measured = measurements_from_simulation(sim)
    cases = {"synthetic, 10 parameters": (synthetic(problem, CLEARANCES + DEFAULT[1:]), CLEARANCES + DEFAULT[1:],
                                          "seated"),
             "synthetic, 3 parameters": (synthetic(problem, DEFAULT), DEFAULT, "seated"),
             "simulated, 3 parameters": (measured, DEFAULT, "seated"),
             "dynamic, 0.1 s window": (measured.window(0.0, 0.1), DEFAULT[:2], "dynamic"),
             "dynamic, 30 ms": (measured.window(0.0, 0.03), DEFAULT[:1], "dynamic"),
             "dynamic, 30 ms, 3 windows": (measured.window(0.0, 0.03), DEFAULT[:1], ("dynamic", 3))}
    print(f"machine: {machine()}; load average {', '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"scene {problem.name}, medians of {args.repeats} runs (dynamic: {min(args.repeats, 3)})")
    print(f"{'case':28s} {'samples':>7s} {'params':>6s} {'first [s]':>9s} {'median [s]':>10s} {'iters':>5s} "
          f"{'verdict':>16s}  the first parameter's estimate +- standard error")
    medians = {}
    for name, (m, keys, method) in cases.items():
        method, windows = method if isinstance(method, tuple) else (method, 1)
        t0 = time.perf_counter()
        identify(problem, m, keys, method=method, windows=windows)
        first = time.perf_counter() - t0
        walls = []
        for _ in range(args.repeats if method == "seated" else min(args.repeats, 3)):
            t0 = time.perf_counter()
            res = identify(problem, m, keys, method=method, windows=windows)
            walls.append(time.perf_counter() - t0)
        medians[name] = statistics.median(walls)
        verdict = "identifiable" if res.verdict["identifiable"] else "not identifiable"
        print(f"{name:28s} {len(m):7d} {len(keys):6d} {first:9.2f} {medians[name]:10.2f} "
              f"{res.fit['iterations']:5d} {verdict:>16s}  {res.estimate[0]:.9g} +- {res.standard_error[0]:.3g}")
    print(f"3 windows against single shooting on 30 ms: time ratio "
          f"{medians['dynamic, 30 ms, 3 windows'] / medians['dynamic, 30 ms']:.2f}")
    m, keys, _ = cases["dynamic, 0.1 s window"]
    data = DynamicData(problem, m, resolve_parameters(problem, keys))
    p = np.array([q.nominal for q in data.params])
    sigma = data.initial_noise()
    walls = {"forward sensitivities": [], "forward differences": [], "central differences": []}
    for k in range(args.repeats):
        at = [p + [(k + f) * 1e-9, 0.0] for f in (0.25, 0.5, 0.75)]  # fresh points: no cached run
        t0 = time.perf_counter()
        data.residuals(at[0], sigma)
        walls["forward sensitivities"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        r0 = data.residuals(at[1], sigma, jacobian=False)["r"]
        for i in range(len(keys)):
            data.residuals(data.shifted(at[1], i), sigma, jacobian=False)["r"] - r0
        walls["forward differences"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        data.central_differences(at[2], sigma)
        walls["central differences"].append(time.perf_counter() - t0)
    sens, fd, cd = (statistics.median(v) for v in walls.values())
    print(f"one Jacobian of method 'dynamic' on 0.1 s ({len(keys)} parameters, {data.n_frames} frames, medians of "
          f"{args.repeats}): forward sensitivities {sens:.3f} s; forward differences of whole runs (the method's "
          f"Jacobian before, {len(keys) + 1} runs) {fd:.3f} s, ratio {fd / sens:.2f}; central differences "
          f"({2 * len(keys)} runs) {cd:.3f} s, ratio {cd / sens:.2f}")
    print(f"load average after: {', '.join(f'{v:.2f}' for v in os.getloadavg())}")

if __name__ == "__main__":
    main()
