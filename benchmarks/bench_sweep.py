"""What a sweep case of the reference scene costs: a warm case in one process, and cases per
minute of `rrr4 sweep` on 1 and 2 local Dask workers, in one run on one machine.

    .venv/bin/python benchmarks/bench_sweep.py [--cases 12] [--t-end 0.2] [--repeat 3]
        [--before CHECKOUT] [--warm-only]
    .venv/bin/python benchmarks/bench_sweep.py --spec problems/sweeps/tolerances_2000.yaml [--repeat 1]

Warm case: the sweep's case function (``run_case``, both preload arms, `--t-end` s each) on
`--cases` clearances in one fresh process, the median time of the cases after the first two
(which build what every later case reuses), next to the stepping alone (the simulations'
``stats['wall_time']``); one process per repeat, medians. With `--before` (a checkout of an
earlier commit) the same measurement runs on that code too, its processes alternated with
this tree's, so both see the same load.

Cluster: a grid of `--cases` clearances, both preload arms; each worker count runs the same
cases into its own temporary directory (cluster start-up included), repeated, medians; once
stepping in compiled C (the sweep's default: the clearance is an input of the compiled code,
so the first run compiles each arm's stepping once into a fresh cache and the later runs find
it there) and once in CasADi's virtual machine (RRR4_JIT=0 in the workers). Prints the C
libraries each run compiled.

With `--spec SPEC` the cluster part runs that sweep spec instead (e.g. the 2 000-case
tolerance Monte Carlo), compiled, on 1 and on 2 local workers, and prints cases per minute
and the ratio; the warm-case part is skipped.

Measured on a 2-core AMD EPYC (load average 2.2 from other sessions), 12 cases of 0.2 s per
arm, medians of 3 alternated processes: a warm case took 0.220 s at cef457d (8.3x its
stepping) and 0.066 s once the preload's sign choice and the mechanism are shared per
structure (2.4x its stepping of 0.027 s; 3.3x less).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _spec(cases: int, t_end: float) -> dict:
    return {"scene": str(ROOT / "problems" / "paper_circle.yaml"), "t_end": t_end,
            "arms": ["with_preload", "without_preload"],
            "grid": {"joints.radial_clearance": [float(c) for c in np.linspace(6e-5, 1.4e-4, cases)]}}


def warm_case(cases: int, t_end: float) -> dict:
    """Median seconds of a warm case (run_case) and of its stepping, in this process. Runs on
    this tree and on trees before the problem layer (fe908c3: ``rrr4.sweeps``, ``rrr4.study``)."""
    import yaml

    from rrr4.scene import parse_scene
    from rrr4.simulation import default_jit, simulate
    if importlib.util.find_spec("rrr4.problem") is not None:
        from rrr4.problem import Problem
        from rrr4.studies.study import arm_scene
        from rrr4.studies.sweeps import case_options, case_scene, parse_spec, run_case
    else:  # a tree before the problem layer
        from rrr4.study import arm_scene
        from rrr4.sweeps import case_options, case_scene, parse_spec, run_case
        Problem = None
    spec = parse_spec(_spec(cases, t_end))
    jit, options = default_jit(), case_options(spec)
    if hasattr(spec, "scene"):  # a base Scene whose values the cases set
        texts = [case_scene(spec.scene, c)[1] for c in spec.cases]
    else:  # a tree whose cases set keys in the base file's data
        texts = [case_scene(spec.base, spec.scene_path, c)[1] for c in spec.cases]
    times = []
    for text in texts:
        t0 = time.perf_counter()
        rows = run_case(text, spec.scene_path.stem, t_end, spec.arms, jit, options)[0]
        times.append(time.perf_counter() - t0)
        assert all(r["status"] == "ok" for r in rows), rows
    scene = parse_scene(yaml.safe_load(texts[-1]), name="case", source="")
    built = scene if Problem is None else Problem.from_scene(scene)
    stepping = sum(simulate(arm_scene(built, a), t_end=t_end, **options).stats["wall_time"] for a in spec.arms)
    return {"case": float(np.median(times[2:])), "first": times[0], "stepping": stepping}


def _warm_in_process(tree: Path, args) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, __file__, "--warm-json", "--cases", str(args.cases), "--t-end",
                          str(args.t_end)], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=12)
    ap.add_argument("--t-end", type=float, default=0.2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--before", type=Path, help="a checkout of an earlier commit to measure the warm case on too")
    ap.add_argument("--warm-only", action="store_true", help="the warm case only, no cluster")
    ap.add_argument("--spec", type=Path, help="a sweep spec to time on 1 and 2 local workers instead")
    ap.add_argument("--warm-json", action="store_true", help=argparse.SUPPRESS)  # one measurement, as JSON
    args = ap.parse_args(argv)
    if args.warm_json:
        print(json.dumps(warm_case(args.cases, args.t_end)))
        return 0
    if args.spec:
        return scale_out(args.spec, args.repeat)
    from rrr4.codegen.build import machine
    trees = {"this tree": ROOT, **({"before": args.before.resolve()} if args.before else {})}
    warm = {name: [] for name in trees}
    for _ in range(args.repeat):
        for name, tree in trees.items():
            warm[name].append(_warm_in_process(tree, args))
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"machine: {machine()}, load average {load}")
    print(f"warm case ({args.cases} cases x 2 arms x {args.t_end:g} s in one process; medians of {args.repeat} "
          "processes):")
    for name, runs in warm.items():
        case, stepping = (float(np.median([r[k] for r in runs])) for k in ("case", "stepping"))
        first = float(np.median([r["first"] for r in runs]))
        print(f"  {name:9s}: {case:.4f} s per warm case ({case / stepping:.1f}x its stepping of {stepping:.4f} s); "
              f"first case {first:.2f} s")
    if args.before:
        ratio = np.median([r["case"] for r in warm["before"]]) / np.median([r["case"] for r in warm["this tree"]])
        print(f"  before / this tree: {ratio:.2f}x")
    if args.warm_only:
        return 0
    from rrr4.studies.sweeps import sweep
    spec = _spec(args.cases, args.t_end)
    os.environ["RRR4_CACHE"] = tempfile.mkdtemp(prefix="rrr4-bench-cache-")  # the workers inherit it
    times = {(mode, w): [] for mode in ("compiled", "vm") for w in (1, 2)}
    built = {k: [] for k in times}
    for _ in range(args.repeat):
        for mode, workers in times:
            os.environ["RRR4_JIT"] = "1" if mode == "compiled" else "0"
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                r = sweep(spec, out=Path(tmp) / "o", workers=workers)
                times[mode, workers].append(time.perf_counter() - t0)
                built[mode, workers].append(r["compilations"])
                assert r["failed"] == 0 and r["skipped"] == 0
    print(f"cluster ({args.cases} cases x 2 arms x {args.t_end:g} s; medians of {args.repeat}, cluster start-up "
          "included):")
    rate = {k: args.cases / (np.median(t) / 60) for k, t in times.items()}
    for (mode, w), t in times.items():
        print(f"  {mode:8s} {w} worker{'s' if w > 1 else ' '}: {np.median(t):6.1f} s, {rate[mode, w]:6.1f} cases per "
              f"minute; C libraries compiled per run: {built[mode, w]}")
    for mode in ("compiled", "vm"):
        print(f"  {mode}: 2 workers / 1 worker {rate[mode, 2] / rate[mode, 1]:.2f}x")
    print(f"  compiled / vm: {rate['compiled', 1] / rate['vm', 1]:.2f}x on 1 worker, "
          f"{rate['compiled', 2] / rate['vm', 2]:.2f}x on 2")
    print(f"load average at the end {', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


def scale_out(spec_path: Path, repeat: int) -> int:
    """`spec_path` swept on 1 and 2 local workers (compiled, start-up included, the C cache
    warm after a first untimed run of 2 cases): cases per minute and the 2 / 1 ratio."""
    import yaml

    from rrr4.codegen.build import machine
    from rrr4.studies.sweeps import parse_spec, sweep
    spec = yaml.safe_load(spec_path.read_text())
    spec["scene"] = str((spec_path.parent / spec["scene"]).resolve())
    n = len(parse_spec(spec).cases)
    os.environ["RRR4_JIT"] = "1"
    with tempfile.TemporaryDirectory() as tmp:  # compile once, untimed
        few = {**spec, "monte_carlo": {**spec["monte_carlo"], "samples": 2}} if "monte_carlo" in spec else spec
        sweep(few, out=Path(tmp) / "warm", workers=1)
    times = {1: [], 2: []}
    print(f"machine: {machine()}, load average {', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    for _ in range(repeat):
        for w in times:
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                r = sweep(spec, out=Path(tmp) / "o", workers=w, progress=False)
                times[w].append(time.perf_counter() - t0)
                assert r["failed"] == 0, r
    rate = {w: n / (np.median(t) / 60) for w, t in times.items()}
    for w, t in times.items():
        print(f"{spec_path.name}: {n} cases, {w} worker{'s' if w > 1 else ''}: {np.median(t):.0f} s, "
              f"{rate[w]:.0f} cases per minute (runs: {', '.join(f'{x:.0f}' for x in t)} s)")
    print(f"2 workers / 1 worker: {rate[2] / rate[1]:.2f}x; load average at the end "
          f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
