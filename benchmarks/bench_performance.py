"""Performance on the reference scene: what 1 um of platform accuracy costs in time.

The reference scene (problems/paper_circle.yaml): all 8 clearance joints, Lankarani-Nikravesh
contact, Ambrosio friction, the scene's QP preload, journals seated at t = 0, the full 1 s
circle. The runs, the common reference solution and its cross-checks are those of
``rrr4 bench accuracy`` (:func:`rrr4.bench.work_precision`), on the ladders below.

For each method the settings ladder runs from the cheapest (largest step, loosest tolerance)
to the most expensive; the first setting whose max platform-position error against the
reference is <= 1e-6 m is the method's cost at that accuracy. Reported: error, stepping wall
time (build and compilation excluded: compiled methods get a warm-up run first), real-time
factor (simulated / wall) and the ratio scipy time / method time at the same accuracy, all in
one process on one core (BLAS threads limited to 1).

    .venv/bin/python benchmarks/bench_performance.py [T_END]

T_END defaults to 1 s (the full path).
"""

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import rrr4  # noqa: E402
from rrr4.bench import machine, work_precision  # noqa: E402

TARGET = 1e-6   # m, max platform-position error
LADDERS = {     # method -> ('step' | 'rtol', settings cheapest first)
    "rk4": ("step", [1e-4, 8e-5, 6.25e-5, 5e-5, 4e-5, 2.5e-5, 1e-5]),
    "bathe": ("step", [1e-3, 5e-4, 2.5e-4, 2e-4, 1e-4, 5e-5, 2.5e-5]),
    "cvodes": ("rtol", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8]),
    "rk45": ("rtol", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]),
    "radau": ("rtol", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]),
}
SCIPY = ("rk45", "radau")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("t_end", nargs="?", type=float, default=1.0)
    T = ap.parse_args().t_end
    scene = rrr4.load_scene("problems/paper_circle.yaml")
    print(f"machine: {machine()}, one used; {T:g} s simulated")
    rows = work_precision(scene, t_end=T, plan=LADDERS, progress=True)
    for r in rows:
        if r["status"] == "cross-check":
            print(f"reference {r['reference']}: distance to {r['method']} = {r['error_m']:.1e} m")
    best = {}
    for method in LADDERS:
        for r in (r for r in rows if r["method"] == method and r["status"] != "cross-check"):
            wall = r["cpu_s"]
            ok = r["status"] == "ok" and r["error_m"] <= TARGET
            print(f"  {method:8s} {r['kind']} {r['setting']:8.2e}: {r['status']:8s} error {r['error_m']:8.2e} m, "
                  f"wall {wall:8.3f} s, {r['steps']} steps{'  <= 1 um' if ok else ''}")
            if ok:
                best[method] = r
                break
        else:
            print(f"  {method}: no setting of the ladder reaches {TARGET:g} m")

    print(f"\ncheapest setting with max platform error <= {TARGET:g} m over {T:g} s:")
    scipy = {k: v["cpu_s"] for k, v in best.items() if k in SCIPY}
    base = min(scipy, key=scipy.get) if scipy else None
    for method, r in best.items():
        ratio = f"{scipy[base] / r['cpu_s']:8.1f}x" if base else "     n/a"
        print(f"  {method:8s} {r['kind']} {r['setting']:8.2e}  error {r['error_m']:8.2e} m  wall {r['cpu_s']:8.3f} s  "
              f"real-time factor {T / r['cpu_s']:7.2f}  {base} / method {ratio}")
    return 0 if np.isfinite([r["cpu_s"] for r in best.values()]).all() else 1


if __name__ == "__main__":
    main()
