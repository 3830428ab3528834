"""What a process load costs: the reference scene against the same scene with a constant load
on the platform (problems/process_load_circle.yaml), in one run on one machine.

    python benchmarks/bench_force_elements.py [--repeats N]

For each scene: SX instructions of the equations' acceleration (machine-independent), and
the wall time of `rrr4.simulate` (1 s, Bathe, compiled stepping, warmed once so the C compile
is not counted), the two scenes run in turns in the same process, medians of N repeats, and
their ratio. Prints the machine and its load (uptime) with the numbers.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import time
from pathlib import Path

import numpy as np

import rrr4

ROOT = Path(__file__).resolve().parents[1]
SCENES = {"paper_circle (no load)": "paper_circle.yaml", "process_load_circle (10 N load)": "process_load_circle.yaml"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    scenes = {k: rrr4.load_scene(ROOT / "problems" / v) for k, v in SCENES.items()}
    for name, scene in scenes.items():
        eqs = rrr4.build(scene).equations()
        print(f"{name}: acceleration {eqs.acceleration.n_instructions()} SX instructions; "
              f"terms: {', '.join(eqs.terms)}")
        rrr4.simulate(scene, jit=True)  # compile once (cached)
    times = {k: [] for k in scenes}
    for _ in range(args.repeats):
        for name, scene in scenes.items():
            t0 = time.perf_counter()
            rrr4.simulate(scene, jit=True)
            times[name].append(time.perf_counter() - t0)
    base = np.median(times[next(iter(scenes))])
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"uptime: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")
    for name, ts in times.items():
        print(f"{name}: simulate median {np.median(ts):.3f} s (min {min(ts):.3f}, max {max(ts):.3f}) over "
              f"{len(ts)} repeats, ratio {np.median(ts) / base:.2f}")


if __name__ == "__main__":
    main()
