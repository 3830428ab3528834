"""Time per simulated cycle with wear (the conformal contact over the worn arc), and for 1e5
cycles by cycle jumping, of the reference scene with wear, as ratios against the same cycle
with today's point contact (the scene without wear), all in one process.

    python benchmarks/bench_wear.py [SCENE] [--repeat R] [--cycles N]

- ``rrr4 wear``'s study (both arms, no jump-error check) to N cycles (default 1e5) with the
  default max change, timed once (after the warm-up runs below have compiled the stepping);
- one cycle (the path, 1 s) of the with-preload arm with the scene's wear: the conformal
  contact over the arc (:mod:`rrr4.contact.conformal`, the profiles' coefficients an input,
  Archard's law at every point of the arc integrated as quadratures at every step), on an
  unworn profile and on the grooves of 1e6 cycles (the study's profiles, scaled to 1e6
  cycles), against the same arm of the scene without ``effects.wear``, whose joints have the
  point contact (the baseline): medians of R repeats after one warm-up run (which compiles
  the stepping in the foreground, and is not counted).

The machine and its load (``uptime``) are printed with the numbers.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from dataclasses import replace
from pathlib import Path

import rrr4
from rrr4.scene import WearEffect
from rrr4.studies.study import arm_scene
from rrr4.studies.wear import wear_study

ROOT = Path(__file__).resolve().parents[1]


def median_time(fn, repeat: int) -> float:
    fn()  # warm-up: builds and compiles (jit=True: in the foreground)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle_wear.yaml"))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cycles", type=float, default=1e5)
    args = ap.parse_args(argv)
    scene = rrr4.load_scene(args.scene)
    problem = rrr4.build(scene)
    worn_arm = arm_scene(problem, "with_preload")
    dry_arm = replace(worn_arm, effects=replace(worn_arm.effects, wear=WearEffect()))
    eqs = problem.equations()
    rows = []
    base = median_time(lambda: rrr4.simulate(dry_arm, jit=True), args.repeat)
    rows.append(("point contact, no wear (baseline)", base))
    rows.append(("conformal contact and wear, unworn profile",
                 median_time(lambda: rrr4.simulate(worn_arm, jit=True), args.repeat)))
    rrr4.simulate(arm_scene(problem, "without_preload"), jit=True)  # compiles the other arm's stepping first
    t0 = time.perf_counter()
    study = wear_study(scene, args.cycles, check=False)
    total = time.perf_counter() - t0
    simulated = sum(len(a.records) for a in study.arms.values())
    scale = 1e6 / args.cycles
    grooves = {j: {s: scale * c for s, c in by.items()} for j, by in study.arms["with_preload"].profiles.items()}
    rows.append(("conformal contact and wear, grooves of 1e6 cycles",
                 median_time(lambda: rrr4.simulate(worn_arm, wear=grooves, jit=True), args.repeat)))

    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{platform.python_version()}; load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} "
          f"{os.getloadavg()[2]:.2f} (uptime)")
    print(f"scene: {scene.name}, one cycle = {scene.path.duration:g} s of motion, {len(eqs.worn)} wear profiles of "
          f"{eqs.worn[0][2]} nodes; medians of {args.repeat} repeats")
    for name, t in rows:
        print(f"  {name:<50s} {t:8.3f} s   x{t / base:.2f}")
    print(f"  {args.cycles:g} cycles by cycle jumping, {len(study.arms)} arms: {total:.1f} s "
          f"({simulated} cycles simulated, {total / simulated:.2f} s each, x{total / base:.1f} the baseline cycle)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
