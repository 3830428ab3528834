"""What the -O level of the compiled stepping is worth: the scene's default run compiled at each
level (the rest of :data:`rrr4.codegen.build.COMPILE_FLAGS` as it is), the states checked bit
for bit against -O3's, the stepping (stats['wall_time']) timed interleaved in one process,
medians of --repeat, and the compiler's CPU time per level. With the virtual machine's
stepping (jit=False) as the baseline: RTF (simulated s per wall s) and ratios.

    .venv/bin/python benchmarks/bench_opt_level.py [SCENE] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import resource  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LEVELS = ("-O1", "-O2", "-O3")


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    os.environ.pop("RRR4_JIT", None)
    os.environ["RRR4_CACHE"] = tempfile.mkdtemp(prefix="rrr4-opt-level-")  # every level compiled here
    import rrr4
    from rrr4.codegen import build
    scene = rrr4.load_scene(args.scene)
    fast = tuple(build.COMPILE_FLAGS)
    systems = rrr4.build(scene).structure("plant").memoized("system")
    frames, states, compile_cpu = {}, {}, {}
    for level in (None, *LEVELS):  # None: the virtual machine
        build.COMPILE_FLAGS = tuple(level if f.startswith("-O") else f for f in fast) if level else fast
        for s in systems:
            s.frames.clear()
        cpu = _cpu()
        states[level] = rrr4.simulate(scene, jit=level is not None).q
        compile_cpu[level] = _cpu() - cpu
        systems = rrr4.build(scene).structure("plant").memoized("system")
        frames[level] = [(s, dict(s.frames)) for s in systems]
    same = all(np.array_equal(states["-O3"], q) for q in states.values())
    walls = {level: [] for level in states}
    for _ in range(args.repeat):
        for level, kept in frames.items():
            for s, f in kept:
                s.frames.clear()
                s.frames.update(f)
            walls[level].append(rrr4.simulate(scene, jit=level is not None).stats["wall_time"])
    build.COMPILE_FLAGS = fast
    T = scene.path.duration
    print(f"{Path(args.scene).name}, median of {args.repeat}; machine: {build.machine()}, "
          f"load {os.getloadavg()[0]:.1f}; states bit for bit equal at every level and in the VM: {same}")
    print("| stepping | compiler CPU [s] | stepping wall [s] | RTF | speed-up over the VM |")
    print("|---|---|---|---|---|")
    vm = float(np.median(walls[None]))
    for level, w in walls.items():
        m = float(np.median(w))
        print(f"| {level or 'virtual machine'} | {compile_cpu[level]:.1f} | {m:.3f} | {T / m:.3g} | {vm / m:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
