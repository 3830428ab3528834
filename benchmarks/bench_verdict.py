"""What the verdict costs on the default path (issue 47: "the verdict reuses the energy audit").

In one process, on the reference scene with no options (1 s, Bathe at 1e-4 s, compiled):
times the whole `rrr4.simulate(scene)` call (building, stepping, outputs; warm: the library
is cached by a warm-up run), the verdict read from its energy terms (`sim.verdict`), and the
warnings said before a run (`foresight_lines`: the contact law's effective restitution, the
stiffest contact vibration at the planned loads, with and without the preload's reactions),
medians of `--repeat` runs each, with the machine and its load. The verdict and the warnings
are quoted as fractions of the simulate call.

    python benchmarks/bench_verdict.py [SCENE] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np

import rrr4
from rrr4.contact.validity import effective_restitution
from rrr4.preload import solve_preload
from rrr4.problem import Problem
from rrr4.simulation.foresight import foresight_lines

ROOT = Path(__file__).resolve().parents[1]


def median_time(f, repeat: int) -> float:
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return float(np.median(out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    scene = rrr4.load_scene(a.scene)
    problem = Problem.from_scene(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pre = solve_preload(problem, branch="auto")
    sim = rrr4.simulate(scene)  # warm-up: builds and compiles (cached on disk)
    t_sim = median_time(lambda: rrr4.simulate(scene), a.repeat)
    t_verdict = median_time(lambda: sim.verdict, max(a.repeat, 20))
    t_fore = median_time(lambda: foresight_lines(problem, preload=pre), max(a.repeat, 20))
    t_fore_cold = median_time(lambda: (effective_restitution.cache_clear(), foresight_lines(problem)), a.repeat)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f}; {scene.name}: {sim.t[-1]:g} s, {sim.stats['method']} at {sim.stats['step']:g} s; "
          f"medians of {a.repeat}+")
    print(f"verdict: {sim.verdict.text()}")
    print(f"rrr4.simulate (warm)                         {t_sim:9.4f} s   1")
    print(f"sim.verdict (from the energy terms)          {t_verdict:9.2e} s   {t_verdict / t_sim:.2e}")
    print(f"foresight_lines (preload given, law cached)  {t_fore:9.2e} s   {t_fore / t_sim:.2e}")
    print(f"foresight_lines (cold: effort family, law)   {t_fore_cold:9.2e} s   {t_fore_cold / t_sim:.2e}")


if __name__ == "__main__":
    main()
