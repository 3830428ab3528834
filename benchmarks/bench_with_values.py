"""What changing a scene in memory costs: ``Scene.with_values`` against the path the studies
took before it (read the scene's YAML file again, set the dotted key in its data, parse it),
and against the setting and parsing alone (a sweep's cases, which kept the base data in
memory), on the reference scene, in one process.

    .venv/bin/python benchmarks/bench_with_values.py [--repeat 7] [--n 200]

Each arm changes the clearance to a new value `--n` times; the median over `--repeat` rounds
(the arms alternated in each round, so both see the same load) of the time per change, and
the ratios. Both baselines call today's ``parse_scene``, which keeps a copy of its data on the
scene (the copy costs the same in every arm).
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from pathlib import Path

import rrr4
from rrr4.scene import parse_scene, read_yaml, set_key

PAPER = Path(__file__).resolve().parents[1] / "problems" / "paper_circle.yaml"
KEY = "joints.radial_clearance"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--n", type=int, default=200)
    args = ap.parse_args()
    scene = rrr4.load_scene(PAPER)
    base = read_yaml(PAPER)

    def reread(v):
        data = read_yaml(PAPER)
        set_key(data, KEY, v)
        return parse_scene(data, name=scene.name)

    def in_memory(v):
        data = copy.deepcopy(base)
        set_key(data, KEY, v)
        return parse_scene(data, name=scene.name)

    arms = {"with_values": lambda v: scene.with_values({KEY: v}), "re-read file + set + parse": reread,
            "copy + set + parse (sweep before)": in_memory}
    for f in arms.values():  # the same scene from every arm
        assert f(1.1e-4) == arms["with_values"](1.1e-4)
    times = {k: [] for k in arms}
    for _ in range(args.repeat):
        for name, f in arms.items():
            t0 = time.perf_counter()
            for i in range(args.n):
                f(1e-4 + 1e-9 * i)
            times[name].append((time.perf_counter() - t0) / args.n)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"load average {os.getloadavg()[0]:.2f}, {args.n} changes x {args.repeat} rounds, medians per change:")
    for name, t in med.items():
        print(f"  {name:36s} {1e3 * t:7.3f} ms   ratio to with_values {t / med['with_values']:.2f}")


if __name__ == "__main__":
    main()
