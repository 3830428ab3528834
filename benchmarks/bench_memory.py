"""Peak memory of `rrr4.simulate` against the simulated duration, in one run on one machine.

    .venv/bin/python benchmarks/bench_memory.py [SCENE] [--short 1] [--long 60] [--output-rate HZ] [--json]

Each duration runs in a fresh Python process (`--child`): import rrr4, load the scene,
one ``rrr4.simulate(scene, t_end=T)`` (its stepping compiled and cached on disk by a
warm-up run of 0.01 s first, so that no duration pays for the compiler), then the peak
resident set size of the process (``resource.getrusage(RUSAGE_SELF).ru_maxrss``). Prints
both peaks, their difference, and the bytes of the result's output arrays (every numpy
array a Simulation holds): what a long run may need above a short one (DESIGN section 9).
--output-rate overrides the scene's; --json prints the two runs' numbers as one JSON line
(tests/test_outputs.py runs it so).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MB = 1024 * 1024


def output_bytes(sim) -> int:
    """Bytes of every numpy array a Simulation holds (its fields and the energy terms)."""
    import numpy as np
    arrays = [v for v in vars(sim).values() if isinstance(v, np.ndarray)] + list(sim.energy.values())
    return int(sum(a.nbytes for a in arrays))


def child(scene_path: str, t_end: float, rate: float | None) -> None:
    """One simulate of `t_end` s in this process; prints its peak RSS and output bytes as JSON."""
    import resource

    import rrr4
    scene = rrr4.load_scene(scene_path)
    rrr4.simulate(scene, t_end=0.01, output_rate=rate)  # builds and compiles (or finds the cached library)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    sim = rrr4.simulate(scene, t_end=t_end, output_rate=rate)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(json.dumps({"t_end": t_end, "peak": peak, "before": before, "outputs": output_bytes(sim),
                      "frames": len(sim.t), "steps": sim.stats["steps"], "wall": sim.stats["wall_time"]}))


def measure(scene_path: str, t_end: float, rate: float | None) -> dict:
    """The child's numbers for one duration, in a fresh process."""
    rate_args = ["--output-rate", repr(rate)] if rate else []
    out = subprocess.run([sys.executable, __file__, scene_path, "--child", repr(t_end), *rate_args], check=True,
                         capture_output=True, text=True, env={**os.environ})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--short", type=float, default=1.0)
    ap.add_argument("--long", type=float, default=60.0)
    ap.add_argument("--output-rate", type=float, default=None)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--child", type=float, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        child(args.scene, args.child, args.output_rate)
        return 0
    runs = [measure(args.scene, t, args.output_rate) for t in (args.short, args.long)]
    if args.json:
        print(json.dumps(runs))
        return 0
    from rrr4.codegen.build import machine
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"machine: {machine()}, load average {load}; scene {Path(args.scene).name}"
          + (f", output rate {args.output_rate:g} Hz" if args.output_rate else ""))
    for r in runs:
        print(f"  {r['t_end']:6g} s: peak RSS {r['peak'] / MB:7.1f} MB (after a 0.01 s warm-up run: "
              f"{r['before'] / MB:6.1f} MB); output arrays {r['outputs'] / MB:6.1f} MB ({r['frames']} outputs, "
              f"{r['steps']} steps, stepping {r['wall']:.2f} s)")
    short, long = runs
    grew, arrays = (long["peak"] - short["peak"]) / MB, (long["outputs"] - short["outputs"]) / MB
    print(f"  {args.long:g} s - {args.short:g} s: peak RSS +{grew:.1f} MB, output arrays +{arrays:.1f} MB, "
          f"the rest +{grew - arrays:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
