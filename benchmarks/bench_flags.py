"""What the compiler flags and the inlined fmax/fmin of the compiled stepping are worth.

The stepping libraries are compiled with :data:`rrr4.codegen.build.COMPILE_FLAGS`
(-O3 -march=native, no floating-point contraction, math functions without errno, CasADi's
helpers inlined) and, where a compiler refuses them, with ``PORTABLE_FLAGS`` (-O2); their C
computes fmax/fmin inline (:func:`rrr4.integrators.compiled.inline_min_max`). This script
builds the default call on a scene (and compiled RK4 at 2.5e-5 s) three ways: as cached
(fast flags, inline fmax/fmin), fast flags calling the C library's fmax/fmin, and portable
flags calling them (the build before either change); checks that all give the same states
bit for bit, and times their stepping (stats['wall_time']) interleaved in one process,
medians of --repeat, BLAS threads limited to 1. Prints real-time factors (RTF, simulated s
per wall s) and the ratios to the portable build, with the machine and its load.

    .venv/bin/python benchmarks/bench_flags.py [SCENE] [--repeat 7]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import rrr4  # noqa: E402
from rrr4.codegen import build  # noqa: E402
from rrr4.integrators import compiled  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# build -> (compiler flags, fmax/fmin inline)
FLAGS = {"cached": (build.COMPILE_FLAGS, True), "fast, libm fmax": (build.COMPILE_FLAGS, False),
         "portable": (build.PORTABLE_FLAGS, False)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    os.environ.pop("RRR4_JIT", None)
    scene = rrr4.load_scene(args.scene)
    T = scene.path.duration
    runs = {"default": {}, "compiled RK4 at 2.5e-5 s": {"integrator": "rk4", "step": 2.5e-5}}
    systems = rrr4.build(scene).structure("plant").memoized("system")
    frames, states = {}, {}
    for name, (flags, inline) in FLAGS.items():  # build and compile each, and keep what was built
        build.COMPILE_FLAGS, compiled.INLINE_MIN_MAX = flags, inline
        for s in systems:
            s.frames.clear()
        for k, kw in runs.items():
            states[name, k] = rrr4.simulate(scene, **kw).q
        systems = rrr4.build(scene).structure("plant").memoized("system")
        frames[name] = [(s, dict(s.frames)) for s in systems]
    same = all(np.array_equal(states["cached", k], states[name, k]) for k in runs for name in FLAGS)
    walls = {key: [] for key in states}
    for _ in range(args.repeat):
        for name in FLAGS:
            for s, f in frames[name]:
                s.frames.clear()
                s.frames.update(f)
            for k, kw in runs.items():
                walls[name, k].append(rrr4.simulate(scene, **kw).stats["wall_time"])
    med = {key: float(np.median(w)) for key, w in walls.items()}
    print(f"{build.machine()}, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; "
          f"{Path(args.scene).name}, {T:g} s, medians of {args.repeat}")
    print(f"| path | {' | '.join(f'{n} RTF' for n in FLAGS)} | {' | '.join(f'{n} / portable' for n in FLAGS)} |")
    print(f"|---|{'---|' * 2 * len(FLAGS)}")
    for k in runs:
        rtf = " | ".join(f"{T / med[n, k]:.2f}" for n in FLAGS)
        ratio = " | ".join(f"{med['portable', k] / med[n, k]:.2f}" for n in FLAGS)
        print(f"| {k} | {rtf} | {ratio} |")
    print(f"fast: {' '.join(FLAGS['cached'][0])}; portable: {' '.join(FLAGS['portable'][0])}; the same states bit "
          f"for bit: {'yes' if same else 'NO'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
