"""Performance of the reference scene (all 8 clearance joints, friction, preload).

Runs, in one process and on one core, the compiled fixed-step path (RK4 and Bathe, JIT C,
compile excluded by a warm-up run), the CasADi cvodes plugin and scipy solve_ivp RK45 on
the same equations, and reports each run's platform-position error against a tight cvodes
reference of the same contact-update model, its stepping time and the ratios
real-time / wall and scipy / method.

    .venv/bin/python benchmarks/bench_performance.py [T_END]   (default 0.05 s)
"""

import platform
import sys
import time

import numpy as np

import rrr4
from rrr4.integrators import RK45, Bathe, Cvodes

T = float(sys.argv[1]) if len(sys.argv) > 1 else 0.05
scene = rrr4.load_scene("problems/paper_circle.yaml")
pre = rrr4.solve_preload(scene)
print(f"machine: {platform.machine()} {platform.system()}, window {T:g} s simulated")
ref_adaptive = rrr4.simulate(scene, Cvodes(rtol=1e-12, atol=1e-14), t_end=T, preload=pre)
ref_fixed = rrr4.simulate(scene, "rk4", t_end=T, step=2.5e-7, preload=pre, jit=True)
runs = {
    "rk4 h=2.5e-6 (C)": ("rk4", dict(step=2.5e-6, jit=True), ref_fixed),
    "bathe h=5e-6 (C)": (Bathe(jit=True), dict(step=5e-6), ref_fixed),
    "cvodes rtol=1e-7": (Cvodes(rtol=1e-7, atol=1e-10), {}, ref_adaptive),
    "scipy RK45 rtol=1e-7": (RK45(rtol=1e-7, atol=1e-10), {}, ref_adaptive),
}
res = {}
for label, (method, kw, ref) in runs.items():
    if kw.get("jit") or getattr(method, "jit", False):
        rrr4.simulate(scene, method, t_end=T, preload=pre, **kw)       # warm-up: compile once (cached)
    t0 = time.process_time()
    s = rrr4.simulate(scene, method, t_end=T, preload=pre, **kw)
    cpu = time.process_time() - t0
    err = float(np.max(np.linalg.norm(s.pose[:, :2] - ref.pose[:, :2], axis=1)))
    res[label] = s.stats["wall_time"]
    print(f"{label:24s} error {err:9.2e} m  stepping {s.stats['wall_time']:7.3f} s  (cpu incl. build {cpu:6.2f} s)"
          f"  real-time factor {T / s.stats['wall_time']:6.3f}")
base = res["scipy RK45 rtol=1e-7"]
for label, w in res.items():
    print(f"scipy RK45 / {label}: {base / w:6.1f}x")
