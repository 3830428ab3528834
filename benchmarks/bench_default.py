"""The default path: `rrr4.simulate(scene)` with no options on the reference scene.

Times the stepping (stats['wall_time']) of the default call, which compiles its stepping
when a C compiler exists, against the same call in CasADi's virtual machine (jit=False),
in one process, medians of `--repeat` runs after a warm-up (the warm-up builds and
compiles; the library is cached on disk). Prints the real-time factor (simulated s per
wall s) of both and their ratio, with the machine.

    .venv/bin/python benchmarks/bench_default.py [SCENE] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

import numpy as np

import rrr4

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    os.environ.pop("RRR4_JIT", None)
    scene = rrr4.load_scene(args.scene)
    T = scene.path.duration
    runs = {"default": {}, "virtual machine (jit=False)": {"jit": False}}
    for kw in runs.values():
        rrr4.simulate(scene, **kw)  # warm-up: build, compile (cached on disk)
    walls = {k: [] for k in runs}
    for _ in range(args.repeat):
        for k, kw in runs.items():
            sim = rrr4.simulate(scene, **kw)
            walls[k].append(sim.stats["wall_time"])
            walls[k + " jit"] = sim.stats["jit"]
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; scene {scene.name}, "
          f"{T:g} s, {scene.integrator.method} at {scene.integrator.step:g} s; medians of {args.repeat}")
    med = {k: float(np.median(walls[k])) for k in runs}
    for k in runs:
        print(f"  {k:28s} (jit {walls[k + ' jit']}): stepping {med[k]:.3f} s, real-time factor {T / med[k]:.2f}")
    print(f"  default / virtual machine speed: {med['virtual machine (jit=False)'] / med['default']:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
