"""How long the C compiler takes on each generated C file of a scene's runs, per -O level.

For each scene: the study (``rrr4 run``'s arms, a short t_end: the generated C does not depend
on it; a wear scene's frames are those ``rrr4 wear`` steps), in a new empty compile cache with
the background compiler replaced by a recorder, so every library the runs ask for is staged and
none compiled there. Then each staged source is compiled by itself, one compiler at a time (one
core), with the project's flags at each -O level; the compiler's CPU time (user + system of the
child, so the machine's load hardly enters), the source's size (with the C files compiled in,
e.g. a generated controller's) and the level the compile policy gives that size
(:func:`rrr4.codegen.policy.level`; 'not compiled': the policy steps it in the virtual machine)
are reported. The
controllers (``controller``) are the generated C in the loop, the frames (``frame``,
``interval``) the compiled stepping. The issue's limit: no generated file over a minute.

    .venv/bin/python benchmarks/bench_compile_time.py [SCENE ...] [--levels -O0 -O1 -O3]
"""

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("problems/paper_circle.yaml", "problems/paper_circle_graph.yaml", "problems/paper_circle_wear.yaml",
          "problems/flores_slider_crank.yaml", "problems/xyt_table.yaml")


def _staged(scene: str, cache: Path) -> list[tuple[str, Path, list[str]]]:
    """(library stem, staged source directory, extra C files) of every library the scene's runs ask for."""
    os.environ["RRR4_CACHE"] = str(cache)
    import rrr4
    from rrr4.codegen import build, policy
    from rrr4.studies.study import run_study
    seen = []

    def record(args, alive):  # the staged sources, kept: compiled below, one at a time
        lib, staged, _options, *extra = args
        keep = Path(staged).with_suffix(".kept")
        shutil.copytree(staged, keep, ignore=shutil.ignore_patterns(build.ALIVE))
        seen.append((Path(lib).stem.rsplit("_", 1)[0], keep, extra))
        shutil.rmtree(staged)

    build.spawn, spawn = record, build.spawn
    pays, policy.PAYBACK_RUNS = policy.PAYBACK_RUNS, 1e12  # every library staged, however short the run
    big, policy.O0_MAX_BYTES = policy.O0_MAX_BYTES, 1e12  # even those the policy leaves to the VM
    try:
        sc = rrr4.load_scene(ROOT / scene)
        run_study(sc, t_end=0.002)  # a wear scene's frames are those `rrr4 wear` steps (profiles are inputs)
    finally:
        build.spawn, policy.PAYBACK_RUNS, policy.O0_MAX_BYTES = spawn, pays, big
    return seen


def _compile_cpu(src: Path, extra: list[str], level: str) -> float:
    """CPU seconds of the C compiler on the .c files of `src` (and `extra`) at `level`."""
    from rrr4.codegen.build import COMPILE_FLAGS
    flags = [level if f.startswith("-O") else f for f in COMPILE_FLAGS]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(["gcc", *flags, *map(str, sorted(src.glob("*.c"))), *extra, "-o", f"{out}/lib.so", "-lm"],
                       check=True, cwd=src)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--levels", nargs="+", default=["-O0", "-O1", "-O3"])
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from rrr4.codegen.build import machine
    print(f"machine: {machine()}, load {os.getloadavg()[0]:.1f}")
    from rrr4.codegen.policy import level
    print(f"| scene | library | C source [MB] | the policy's level | "
          f"{' | '.join(f'compile {lv} [s CPU]' for lv in args.levels)} |")
    print(f"|---|---|---|---|{'---|' * len(args.levels)}")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in args.scenes:
            cache = Path(tmp) / Path(scene).stem
            cache.mkdir()
            for stem, src, extra in _staged(scene, cache):
                nbytes = sum(p.stat().st_size for p in [*src.glob("*.c"), *map(Path, extra)])
                times = [_compile_cpu(src, extra, lv) for lv in args.levels]
                own = sum(p.stat().st_size for p in src.glob("*.c"))  # what the level follows
                print(f"| {Path(scene).stem} | {stem} | {nbytes / 1e6:.2f} | {level(own) or 'not compiled'} | "
                      f"{' | '.join(f'{t:.1f}' for t in times)} |", flush=True)
    print(f"load at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
