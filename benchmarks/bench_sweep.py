"""Cases per minute of `rrr4 sweep` on 1 and 2 local Dask workers, in one run on one machine.

    .venv/bin/python benchmarks/bench_sweep.py [--cases 12] [--t-end 0.2] [--repeat 3]

A grid of `--cases` clearances on the reference scene, both preload arms, `--t-end` s of
motion each; each worker count runs the same cases into its own temporary directory
(cluster start-up included), repeated, medians; once stepping in compiled C (the sweep's
default: the clearance is an input of the compiled code, so the first run compiles each arm's
stepping once into a fresh cache and the later runs find it there) and once in CasADi's
virtual machine (RRR4_JIT=0 in the workers). Prints the C libraries each run compiled.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=12)
    ap.add_argument("--t-end", type=float, default=0.2)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    from rrr4.studies.sweeps import sweep
    spec = {"scene": str(ROOT / "problems" / "paper_circle.yaml"), "t_end": args.t_end,
            "arms": ["with_preload", "without_preload"],
            "grid": {"joints.radial_clearance": [float(c) for c in np.linspace(6e-5, 1.4e-4, args.cases)]}}
    os.environ["RRR4_CACHE"] = tempfile.mkdtemp(prefix="rrr4-bench-cache-")  # the workers inherit it
    times = {(mode, w): [] for mode in ("compiled", "vm") for w in (1, 2)}
    built = {k: [] for k in times}
    for _ in range(args.repeat):
        for mode, workers in times:
            os.environ["RRR4_JIT"] = "1" if mode == "compiled" else "0"
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                r = sweep(spec, out=Path(tmp) / "o", workers=workers)
                times[mode, workers].append(time.perf_counter() - t0)
                built[mode, workers].append(r["compilations"])
                assert r["failed"] == 0 and r["skipped"] == 0
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    from rrr4.codegen.build import machine
    print(f"machine: {machine()}, load average {load}")
    print(f"{args.cases} cases x 2 arms x {args.t_end:g} s; medians of {args.repeat} (cluster start-up included)")
    rate = {k: args.cases / (np.median(t) / 60) for k, t in times.items()}
    for (mode, w), t in times.items():
        print(f"  {mode:8s} {w} worker{'s' if w > 1 else ' '}: {np.median(t):6.1f} s, {rate[mode, w]:6.1f} cases per "
              f"minute; C libraries compiled per run: {built[mode, w]}")
    for mode in ("compiled", "vm"):
        print(f"  {mode}: 2 workers / 1 worker {rate[mode, 2] / rate[mode, 1]:.2f}x")
    print(f"  compiled / vm: {rate['compiled', 1] / rate['vm', 1]:.2f}x on 1 worker, "
          f"{rate['compiled', 2] / rate['vm', 2]:.2f}x on 2")
    return 0


if __name__ == "__main__":
    sys.exit(main())
