"""Where a control period of the compiled stepping spends its instructions.

Builds the stepping of one control period exactly as ``rrr4.simulate`` does for a scene and
method (the default: the scene's own integrator; --method rk4 --step 2.5e-5 for the RK4
baseline), takes the state and frame inputs of a real run (the first --periods control periods
of the scene), generates C for those periods folded into one Function with CasADi's ``main``
(inputs read from a file), compiles it with the stepping's flags minus ``-march=native``
(valgrind does not decode every instruction a native build may use) and counts instructions
with ``valgrind --tool=callgrind``. Instruction counts do not depend on the machine's load.
Prints, per control period, the inclusive count of every named CasADi Function in the code
(right-hand side ``ode``, the Newton pieces, the controller, ...) and of the math library.

    .venv/bin/python benchmarks/bench_profile.py [SCENE] [--method rk4 --step 2.5e-5] [--periods 2000]

Needs valgrind (Debian: ``apt install valgrind``); without it, says so and exits 2.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import casadi as ca
import numpy as np

import rrr4
import rrr4.integrators.base as base
from rrr4.codegen.build import COMPILE_FLAGS

ROOT = Path(__file__).resolve().parents[1]


def captured_run(scene, method: str | None, step: float | None, periods: int):
    """(integrator, system, initial state with the method's own entries, frame inputs (periods,
    nu), h, steps per frame) of the scene's run, as simulate hands them to the integrator."""
    seen = {}
    roll = base.FixedStepIntegrator.roll

    def record(self, system, x0, u_frames, h, steps_per_frame, *args, **kw):
        seen.update(method=self, system=system, x0=np.array(x0, float), u=np.array(u_frames[:periods], float), h=h,
                    spf=steps_per_frame)
        return roll(self, system, x0, u_frames, h, steps_per_frame, *args, **kw)

    base.FixedStepIntegrator.roll = record
    try:
        kw = {"step": step} if step else {}
        rrr4.simulate(scene, method, t_end=periods / scene.actuation.control_rate, jit=False, **kw)
    finally:
        base.FixedStepIntegrator.roll = roll
    return seen


def function_names(c_source: str) -> dict[str, str]:
    """casadi_fN -> the CasADi Function's name, from the comments CasADi writes above each."""
    names, last = {}, None
    for line in c_source.splitlines():
        m = re.match(r"/\* (\w+):\(", line)
        if m:
            last = m.group(1)
        m = re.match(r"static int casadi_(f\d+)\(", line)
        if m and last:
            names[m.group(1)] = last
    return names


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--method", default=None, help="integrator (default: the scene's)")
    ap.add_argument("--step", type=float, default=None, help="step [s] (default: the scene's)")
    ap.add_argument("--periods", type=int, default=2000, help="control periods counted (default 2000)")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("bench_profile: valgrind is not installed (it counts the instructions)", file=sys.stderr)
        return 2
    try:
        scene = rrr4.load_scene(args.scene)
    except rrr4.Rrr4Error as e:
        print(f"bench_profile: {e}", file=sys.stderr)
        return 2
    if scene.actuation.control_rate is None:
        print("bench_profile: the scene has no actuation.control_rate (a control period to count)", file=sys.stderr)
        return 2
    run = captured_run(scene, args.method, args.step, args.periods)
    frame = run["method"].frame_function(run["system"], run["h"], run["spf"])
    x, u = ca.MX.sym("x", frame.size1_in(0)), ca.MX.sym("u", frame.size1_in(1), args.periods)
    periods = ca.Function("periods", [x, u], [frame.fold(args.periods)(x, u)])
    flags = [f for f in COMPILE_FLAGS if f not in ("-march=native", "-fPIC", "-shared")]
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator("periods.c", {"main": True, "with_header": False})
        cg.add(periods)
        cg.generate(tmp + os.sep)
        src = Path(tmp, "periods.c").read_text()
        Path(tmp, "in.txt").write_text(" ".join(f"{v:.17g}" for v in np.r_[run["x0"], run["u"].ravel()]))
        subprocess.run(["gcc", *flags, "-g", "periods.c", "-o", "periods", "-lm"], cwd=tmp, check=True)
        with open(Path(tmp, "in.txt")) as stdin:
            subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=cg.out", "./periods", "periods"],
                           cwd=tmp, stdin=stdin, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        report = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", "cg.out"], cwd=tmp,
                                capture_output=True, text=True, check=True).stdout
    names = function_names(src)
    counts: dict[str, float] = defaultdict(float)
    for line in report.splitlines():
        m = re.match(r"\s*([\d,]+) \([^)]*\)\s+(\S+)", line)
        if not m:
            continue
        n, where = int(m.group(1).replace(",", "")), m.group(2)
        f = re.search(r"periods_(f\d+)", where)
        if f and f.group(1) in names:  # inclusive: its own code and what it calls
            counts[names[f.group(1)]] = max(counts[names[f.group(1)]], n)
        elif "/math/" in where or "libm" in line:
            counts["(math library: sin, cos, atan2, fmax, ... ; exclusive)"] += n
    # one control period is the Function 'frame'; the folds around it (fold_frame, frame_acc...)
    # are this script's loop over the periods, not the simulation's
    total = counts.pop("frame")
    counts = {k: n for k, n in counts.items() if not (k.startswith("fold_") or "_acc" in k)}
    sc = run["method"]
    print(f"{Path(args.scene).name}: {sc.name} at {run['h']:g} s, {run['spf']} step(s) per control period; "
          f"callgrind, {args.periods} periods from t = 0, compiled with {' '.join(flags)} -g")
    print(f"instructions per control period (the Function 'frame'): {total / args.periods:,.0f}")
    print("| Function (inclusive: with what it calls) | instructions per period | share |")
    print("|---|---|---|")
    for k, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        if n / total >= 0.005:
            print(f"| {k} | {n / args.periods:,.0f} | {n / total:.1%} |")
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
