"""What one default ``rrr4.simulate(scene)`` call costs outside its stepping, in this tree and
in another (for instance the tree before a refactoring), measured the same way.

Each tree runs in its own process (the other tree first on ``sys.path``) and uses the public
API only (``rrr4.load_scene``, ``rrr4.simulate``), so any two trees compare. Per process: the
first call (a fresh process; the compiled libraries already in the on-disk cache: the
set-up a script or a sweep worker pays once per scene), then --repeat warm calls. Reported
per tree, medians over all processes: the first call's total and its part outside the
stepping; a warm call's stepping (``stats['wall_time']``), total, and the part outside the
stepping (building the run's inputs, the initial state and the outputs). The trees'
processes alternate, --rounds times, so that a change of the machine's load hits both.

    .venv/bin/python benchmarks/bench_setup.py --before-tree ../rrr4-old [--rounds 4] [--repeat 7]

(with ``git worktree add ../rrr4-old <commit>``).
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RUN = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
import rrr4
scene = rrr4.load_scene(sys.argv[2])
t0 = time.perf_counter()
sim = rrr4.simulate(scene)
first = (time.perf_counter() - t0, sim.stats["wall_time"])
warm = []
for _ in range(int(sys.argv[3])):
    t0 = time.perf_counter()
    sim = rrr4.simulate(scene)
    warm.append((time.perf_counter() - t0, sim.stats["wall_time"]))
print(json.dumps({"first": first, "warm": warm}))
"""


def run(tree: Path, scene: Path, repeat: int) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    env.pop("RRR4_JIT", None)
    out = subprocess.run([sys.executable, "-c", RUN, str(tree), str(scene), str(repeat)], check=True, cwd=tree,
                         env=env, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--before-tree", help="another checkout of rrr4 to compare with")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args(argv)
    trees = {"this tree": ROOT}
    if a.before_tree:
        trees = {"before": Path(a.before_tree).resolve(), **trees}
    runs = {k: [] for k in trees}
    for _ in range(a.rounds):
        for k, tree in trees.items():
            runs[k].append(run(tree, Path(a.scene).resolve(), a.repeat))
    from rrr4.codegen.build import machine
    print(f"{machine()}; load average {os.getloadavg()[0]:.2f}; {Path(a.scene).name}; {a.rounds} processes per "
          f"tree, {a.repeat} warm calls each, medians")
    print("| tree | first call [s] | first call outside stepping [s] | warm stepping [s] | warm total [s] | "
          "warm outside stepping [s] |")
    print("|---|---|---|---|---|---|")
    med = {}
    for k, rs in runs.items():
        first = np.array([r["first"] for r in rs])
        warm = np.array([w for r in rs for w in r["warm"]])
        med[k] = (np.median(first[:, 0]), np.median(first[:, 0] - first[:, 1]), np.median(warm[:, 1]),
                  np.median(warm[:, 0]), np.median(warm[:, 0] - warm[:, 1]))
        print(f"| {k} | " + " | ".join(f"{v:.4f}" for v in med[k]) + " |")
    if "before" in med:
        ratio = [b / t for b, t in zip(med["this tree"], med["before"], strict=True)]
        print("| this tree / before | " + " | ".join(f"{v:.3f}" for v in ratio) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
