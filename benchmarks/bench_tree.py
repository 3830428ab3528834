"""Do tree coordinates pay? (issue: fast contact dynamics, item 5)

Times ``rrr4.simulate`` of each scene with ``integrator.coordinates: reference-point`` (every
body's [x, y, theta], the ideal joints as Baumgarte-stabilised constraints) and ``tree``
(minimal coordinates of the ideal joints' spanning tree, see :mod:`rrr4.mechanism.tree`),
compiled, the two interleaved in one process, medians of repeats; prints the stepping time
of each (the run's ``wall_time``, compiling excluded), their ratio, the coordinates and SX
instructions of each ODE, the implicit methods' Newton figures, and the largest
platform-position (or, without a task, body-position) difference between the two motions,
which integrate the same physics.

    .venv/bin/python benchmarks/bench_tree.py [SCENE ...] [--repeats 5]

Default scenes: the reference scene at its default (Bathe at 1e-4 s, controller at 10 kHz),
the same without preload (the journals rattle: more Newton work), and Flores's slider-crank at
its default (RK4 at 1e-6 s).
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rrr4  # noqa: E402
from rrr4.codegen.build import machine  # noqa: E402


def _coordinates(scene, c):
    return replace(scene, integrator=replace(scene.integrator, coordinates=c))


def compare(scene, repeats: int) -> None:
    runs = {c: _coordinates(scene, c) for c in ("reference-point", "tree")}
    for s in runs.values():
        rrr4.simulate(s, jit=True)  # compile
    times = {c: [] for c in runs}
    last = {}
    for _ in range(repeats):
        for c, s in runs.items():
            last[c] = rrr4.simulate(s, jit=True)
            times[c].append(last[c].stats["wall_time"])
    a, b = last["reference-point"], last["tree"]
    model = rrr4.Model.of(scene.graph)
    if model.task is not None:
        diff, what = np.max(np.linalg.norm(a.pose[:, :2] - b.pose[:, :2], axis=1)), "platform position"
    else:
        diff, what = np.max(np.abs(a.q - b.q)), "coordinate"
    med = {c: float(np.median(v)) for c, v in times.items()}
    print(f"{scene.name}: {a.stats['method']} at h = {a.stats['step']:g} s over {a.t[-1]:g} s")
    for c, sim in last.items():
        newton = {k: sim.stats[k] for k in ("newton_iterations_per_step", "jacobians_per_step") if k in sim.stats}
        n = sim.stats["graph"]["ode"]["inputs"]
        print(f"  {c:16s} ODE {sim.stats['graph']['ode']['instructions']} SX instructions ({n} inputs), "
              f"stepping {med[c]:.4f} s {newton}")
    print(f"  tree / reference-point stepping time: {med['tree'] / med['reference-point']:.2f}; largest "
          f"{what} difference between the two motions {diff:.2e} m")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    if a.scenes:
        scenes = [rrr4.load_scene(p) for p in a.scenes]
    else:
        paper = rrr4.load_scene(ROOT / "problems" / "paper_circle.yaml")
        act = paper.actuation
        bare = replace(paper, name="paper_circle without preload",
                       actuation=replace(act, preload=replace(act.preload, method="none")))
        scenes = [paper, bare, rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")]
    print(f"{machine()}, load average {', '.join(f'{v:.1f}' for v in os.getloadavg())}; "
          f"medians of {a.repeats}, interleaved in one process")
    for s in scenes:
        compare(s, a.repeats)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
