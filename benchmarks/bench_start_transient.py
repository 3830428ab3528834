"""The start of Flores's slider-crank with clearance: an instant start against a smooth one.

problems/flores_slider_crank.yaml turns its crank at 5000 rpm from t = 0 (the classic
benchmark: the start is an impact). Here the same mechanism runs up from rest under the
driver's quintic law (mechanism.drivers[].time_law: quintic), whose speed peaks at 5000 rpm
at half its duration T (travel = 5000 rpm * T / 1.875); the instant start turns at 5000 rpm
from t = 0. Both are measured over the run-up, t in [0, T/2] (both end it at 5000 rpm):
contact losses at the clearance joint, the peak contact force, the deepest penetration,
the peak driver torque and the free-flight fraction; and the smooth start over its whole
duration (run-up and run-down to rest).

    .venv/bin/python benchmarks/bench_start_transient.py [--duration 0.1] [--step 1e-6]

About a minute on a 2-core machine (two compiled RK4 runs, 1e-6 s steps).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
from pathlib import Path

import numpy as np

import rrr4

ROOT = Path(__file__).resolve().parents[1]
RPM = 5000.0


def measure(sim, t_to: float) -> dict:
    """The start transient of `sim` over t <= t_to: losses, peak force, penetration, torque."""
    k = sim.t <= t_to + 1e-12
    fn = sim.normal_force[k, 0]
    losses = int(np.sum(np.diff((fn > 0).astype(int)) < 0))  # contact -> free flight
    return {"losses": losses, "peak_force_N": float(np.max(fn)),
            "max_penetration_um": 1e6 * float(np.max(sim.penetration[k, 0])),
            "peak_torque_Nm": float(np.max(np.abs(sim.driver_effort[k, 0]))),
            "free_flight_pct": 100.0 * float(np.mean(fn <= 0))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=0.1, help="T [s] of the quintic law")
    ap.add_argument("--step", type=float, default=1e-6, help="RK4 step [s]")
    args = ap.parse_args(argv)
    scene = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    omega = RPM * 2 * math.pi / 60
    T = args.duration
    d = scene.graph.drivers[0]
    smooth_driver = dataclasses.replace(d, time_law="quintic", travel=omega * T / 1.875, duration=T,
                                        speed=omega / 1.875)
    graph = dataclasses.replace(scene.graph, drivers=(smooth_driver,))
    smooth = dataclasses.replace(scene, graph=graph, path=dataclasses.replace(scene.path, duration=T))
    instant = dataclasses.replace(scene, path=dataclasses.replace(scene.path, duration=T / 2))
    print(f"Flores's slider-crank with clearance, RK4 at {args.step:g} s; run-up window [0, {T / 2:g}] s; "
          f"load average {os.getloadavg()[0]:.2f}")
    h, rate = args.step, 1 / args.step  # every step an output: each loss counted
    up = rrr4.simulate(smooth, step=h, output_rate=rate)
    runs = {"instant start (5000 rpm from t = 0)": (rrr4.simulate(instant, step=h, output_rate=rate), T / 2),
            f"quintic from rest, run-up (peak 5000 rpm at {T / 2:g} s)": (up, T / 2)}
    runs[f"quintic from rest, whole law (to rest at {T:g} s)"] = (up, T)
    cols = ("losses", "peak_force_N", "max_penetration_um", "peak_torque_Nm", "free_flight_pct")
    print("| start | " + " | ".join(cols) + " |")
    print("| --- |" + " --- |" * len(cols))
    for name, (sim, t_to) in runs.items():
        m = measure(sim, t_to)
        print(f"| {name} | " + " | ".join(f"{m[c]:.4g}" for c in cols) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
