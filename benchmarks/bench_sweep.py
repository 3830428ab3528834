"""Cases per minute of `rrr4 sweep` on 1 and 2 local Dask workers, in one run on one machine.

    .venv/bin/python benchmarks/bench_sweep.py [--cases 12] [--t-end 0.2]

A grid of `--cases` clearances on the reference scene, both preload arms, `--t-end` s of
motion each; each worker count runs the same cases into its own temporary directory
(cluster start-up included), repeated, medians. Cases step in CasADi's virtual machine, so
nothing is compiled (the compile count printed is the number of new libraries in the
compiled-code cache during the run).
"""

from __future__ import annotations

import argparse
import os
import platform
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
    from rrr4.integrators.compiled import cache_dir
    from rrr4.sweeps import sweep
    spec = {"scene": str(ROOT / "problems" / "paper_circle.yaml"), "t_end": args.t_end,
            "arms": ["with_preload", "without_preload"],
            "grid": {"joints.radial_clearance": [float(c) for c in np.linspace(6e-5, 1.4e-4, args.cases)]}}
    libs = set(cache_dir().glob("*.so"))
    times = {1: [], 2: []}
    for _ in range(args.repeat):
        for workers in (1, 2):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                r = sweep(spec, out=Path(tmp) / "o", workers=workers)
                times[workers].append(time.perf_counter() - t0)
                assert r["failed"] == 0 and r["skipped"] == 0
    compiled = len(set(cache_dir().glob("*.so")) - libs)
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"machine: {platform.machine()} {platform.system()}, {os.cpu_count()} cores, load average {load}")
    print(f"{args.cases} cases x 2 arms x {args.t_end:g} s; medians of {args.repeat} (cluster start-up included)")
    rate = {w: args.cases / (np.median(t) / 60) for w, t in times.items()}
    for w in (1, 2):
        print(f"  {w} worker{'s' if w > 1 else ' '}: {np.median(times[w]):6.1f} s, {rate[w]:6.1f} cases per minute")
    print(f"  2 workers / 1 worker: {rate[2] / rate[1]:.2f}x; libraries compiled during the run: {compiled}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
