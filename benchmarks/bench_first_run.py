"""The first run of a new scene: `rrr4 run SCENE` with an empty compile cache against the same
command with the cache warm, in one script on one machine, under each compile policy.

Per round and policy: a new, empty cache directory (``RRR4_CACHE``); the command once (cold);
the background compilers it left finish (their staged sources gone); the command again (warm).
Policies: the default (``RRR4_JIT`` unset: the stepping compiles in a process of its own while
CasADi's virtual machine steps, and a later run uses the library) and ``RRR4_JIT=1`` (compile
first, then step: the behaviour before the policy). The rounds alternate the policies, so that
a change of the machine's load hits both. Reported: medians of cold and warm wall times and
their ratio per policy, and whether the cold and warm results agree with each other and with
the committed result ``results/<scene name>`` where it exists (``rrr4 compare``, rtol 1e-9).

    .venv/bin/python benchmarks/bench_first_run.py [problems/paper_circle.yaml] [--rounds 3]
        [--policies default compile-first]
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RRR4 = str(Path(sys.executable).with_name("rrr4"))
POLICIES = {"default": ("default (background)", None), "compile-first": ("RRR4_JIT=1 (compile first)", "1")}


def _run(scene: str, out: Path, cache: Path, jit) -> float:
    env = {**os.environ, "RRR4_CACHE": str(cache)}
    env.pop("RRR4_JIT", None)
    if jit is not None:
        env["RRR4_JIT"] = jit
    t0 = time.perf_counter()
    subprocess.run([RRR4, "run", scene, "--out", str(out)], env=env, check=True, capture_output=True, cwd=ROOT)
    return time.perf_counter() - t0


def _settle(cache: Path, timeout: float = 3600.0) -> float:
    """Wait for the background compilers to finish (no staged sources left); the seconds waited."""
    t0 = time.perf_counter()
    while list(cache.glob("*.staged")) and time.perf_counter() - t0 < timeout:
        time.sleep(1.0)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default="problems/paper_circle.yaml")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--policies", nargs="+", choices=tuple(POLICIES), default=list(POLICIES))
    args = ap.parse_args()
    policies = {name: jit for key, (name, jit) in POLICIES.items() if key in args.policies}
    sys.path.insert(0, str(ROOT))
    from rrr4.codegen.build import machine
    times = {p: {"cold": [], "warm": [], "settle": []} for p in policies}
    agree = {}
    committed = ROOT / "results" / Path(args.scene).stem
    print(f"load at the start {os.getloadavg()[0]:.1f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for policy, jit in policies.items():
                cache = Path(tmp) / f"cache_{r}_{jit}"
                cache.mkdir()
                cold, warm = Path(tmp) / f"cold_{r}_{jit}", Path(tmp) / f"warm_{r}_{jit}"
                times[policy]["cold"].append(_run(args.scene, cold, cache, jit))
                times[policy]["settle"].append(_settle(cache))
                times[policy]["warm"].append(_run(args.scene, warm, cache, jit))
                # cold against warm, and against the committed result where there is one
                pairs = [(cold, warm)] + [(committed, cold)] * committed.is_dir()
                same = all(subprocess.run([RRR4, "compare", str(a), str(b), "--rtol", "1e-9"],
                                          capture_output=True).returncode == 0 for a, b in pairs)
                agree[policy] = agree.get(policy, True) and same
                shutil.rmtree(cache)
                print(f"round {r + 1} {policy}: cold {times[policy]['cold'][-1]:.1f} s, warm "
                      f"{times[policy]['warm'][-1]:.1f} s", flush=True)
    print(f"\n{args.scene}, {args.rounds} rounds; machine: {machine()}, load {os.getloadavg()[0]:.1f}")
    print("| policy | cold [s] | warm [s] | cold / warm | background compile after the cold run [s] | same results |")
    print("|---|---|---|---|---|---|")
    for policy, t in times.items():
        c, w, s = (float(np.median(t[k])) for k in ("cold", "warm", "settle"))
        print(f"| {policy} | {c:.1f} | {w:.1f} | {c / w:.2f} | {s:.1f} | {'yes' if agree[policy] else 'NO'} |")


if __name__ == "__main__":
    main()
