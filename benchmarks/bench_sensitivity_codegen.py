"""Size and compile time of the generated C of method 'dynamic' (issue 44: nine parameters and
ten windows gave a sensitivity frame of 28 MB of C in one file, gcc -O3 still compiling after
12 minutes).

    .venv/bin/python benchmarks/bench_sensitivity_codegen.py [SCENE] [--directions N ...] [--inputs geometry]

What the method compiles: the frame with its outputs ('sensitivity_step'), and the frame's
forward derivative in a block of d directions ('sensitivity_directions', d the next multiple of
BLOCK at or above the direction count), built on FixedStepIntegrator.derivative_frame_function:
the frame evaluated once per call, its leaves' one-direction derivatives called d times, so the
C hardly grows with d. For each it prints the generated C's size (characters, lines) and the
time gcc takes with the project's flags (rrr4.codegen.build.COMPILE_FLAGS), compiled here in a
temporary directory (not the cache), for each --directions N (default 1, 12 and 40). For
comparison it prints the size (only) of the frame as it was generated before issue 46, the
plain frame's forward(10) unrolled in one Function. Load average before and after.

Measured (paper_circle, 2 cores shared with other jobs): sensitivity_step 0.57 MB; the
derivative in 4 directions 0.94 MB, in 12 1.02 MB, in 40 1.31 MB; before, forward(10) unrolled
7.09 MB.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import tempfile
import time
from pathlib import Path

import casadi as ca

import rrr4
from rrr4.codegen.build import COMPILE_FLAGS
from rrr4.identify.dynamic import BLOCK, sensitivity_frame

ROOT = Path(__file__).resolve().parent.parent


def c_of(f: ca.Function) -> str:
    cg = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    cg.add(f)
    return cg.dump()


def compile_seconds(text: str, name: str) -> tuple[float, float]:
    """(wall, CPU) seconds of gcc on `text` (the CPU time counts on a loaded machine)."""
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / f"{name}.c"
        src.write_text(text)
        t, before = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(["gcc", *COMPILE_FLAGS, "-o", str(Path(d) / f"{name}.so"), str(src), "-lm"], check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return time.perf_counter() - t, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--directions", type=int, nargs="*", default=[1, 12, 40])
    ap.add_argument("--inputs", choices=("contact", "geometry"), default="contact",
                    help="geometry: the frames for link lengths and base positions")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    problem = rrr4.build(rrr4.load_scene(args.scene))
    frame, system, loop, eqs, tree, method, dt = sensitivity_frame(problem, 1, 1e-3, jit=False, inputs=args.inputs)
    step = problem.memo(("identify_sensitivity", dt, False, args.inputs), lambda: None)[0]  # built just now
    print(f"scene {problem.name}: frame {1e3 * dt:g} ms, state {system.ny + system.nz + 1} entries, BLOCK = {BLOCK}")
    print(f"{'function':44s} {'C [MB]':>8s} {'lines':>9s} {'gcc wall [s]':>13s} {'gcc CPU [s]':>12s}")
    blocks = []
    for nd in args.directions:
        sensitivity_frame(problem, nd, 1e-3, jit=False, inputs=args.inputs)
        d = BLOCK * -(-nd // BLOCK)
        blocks.append((f"sensitivity_directions, {d} directions",
                       problem.memo(("identify_sensitivity_directions", d, dt, False, args.inputs), lambda: None)))
    for name, f in [("sensitivity_step", step), *blocks]:
        text = c_of(f)
        wall, cpu = compile_seconds(text, f.name())
        print(f"{name:44s} {len(text) / 1e6:8.2f} {text.count(chr(10)):9d} {wall:13.1f} {cpu:12.1f}", flush=True)
    spf = max(int(round(dt / problem.scene.integrator.step)), 1)
    unit = method.frame_function(system, dt / spf, spf)
    nx, nu = unit.size1_in(0), unit.size1_in(1)
    x, u, S = ca.MX.sym("x", nx), ca.MX.sym("u", nu), ca.MX.sym("S", nx, 10)
    x1 = unit(x, u)
    old = ca.Function("sensitivity_frame", [x, S, u], [x1, unit.forward(10)(x, u, x1, S, ca.MX.zeros(nu, 10))])
    text = c_of(old)
    print(f"{'before: forward(10) unrolled in one frame':44s} {len(text) / 1e6:8.2f} {text.count(chr(10)):9d} "
          f"{'(not compiled)':>13s}", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
