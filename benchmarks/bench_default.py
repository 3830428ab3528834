"""The default path: `rrr4.simulate(scene)` with no options on the reference scene.

Times the stepping (stats['wall_time']) of the default call, which compiles its stepping
when a C compiler exists, against the same call in CasADi's virtual machine (jit=False),
in one process, medians of `--repeat` runs after a warm-up (the warm-up builds and
compiles; the library is cached on disk). Prints the real-time factor (simulated s per
wall s) of both and their ratio, with the machine and its load.

With --work-precision, also the candidates for the default path, compiled, interleaved in
the same process: the default (Bathe, simplified Newton), ROS2 (the linearly implicit
W-method, :mod:`rrr4.integrators.ros2`) at the control period and half of it with its
Jacobian held for 1 to 1000 steps, and ROS2 with the other L-stable gamma; each with its
max platform-position error against RK4 at 1e-6 s of the same physics and controller, its
stepping time, RTF, and Jacobians per step. Next to them the physical floor: one controller
step plus one held-effort right-hand side per control period, each timed compiled in a
chain of K dependent calls on a state and references of the run (as benchmarks/bench_rhs.py
does), medians of repeats. Then ROS2 where journals fly (the scene without preload, 0.08 s):
error and contact losses against RK4 at 1e-6 s, with Bathe for scale.

    python benchmarks/bench_default.py [SCENE] [--repeat 3] [--work-precision]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import rrr4
from rrr4.errors import SimulationError
from rrr4.integrators import Ros2
from rrr4.integrators.compiled import compiled
from rrr4.integrators.implicit import second_order_split
from rrr4.integrators.ros2 import GAMMA, w_matrix

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1e-6  # m, max platform-position error


class Recorded(Ros2):
    """ROS2 that keeps the system, initial state and frame inputs of its last run (for the floor)."""

    def run(self, system, x0, u_frames, *args, **kw):
        self.seen = (system, np.asarray(x0, float), np.asarray(u_frames[:1], float)[0])
        return super().run(system, x0, u_frames, *args, **kw)


def chained(f: ca.Function, K: int) -> ca.Function:
    """Compiled 'chain': K dependent calls of f (its first input y <- y + 1e-12 sum(f(y, ...))), the loop in C."""
    ins = [ca.MX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    step = ca.Function("link", ins, [ins[0] + 1e-12 * ca.sum1(f(*ins))])
    fixed = [ca.repmat(a, 1, K) for a in ins[1:]]
    out = step.mapaccum("acc", K)(ins[0], *fixed)
    return compiled(ca.Function("chain", ins, [out[:, -1]]))


def ns_per_call(f: ca.Function, args: list, K: int = 2000, reps: int = 21) -> float:
    fc = chained(f, K)
    fc(*args)
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        fc(*args)
        times.append((time.perf_counter() - t0) / K * 1e9)
    return float(np.median(times))


def floor(scene) -> dict:
    """ns per call, compiled, on a state and references of the run: the controller step, the
    held-effort RHS (the two make the floor), and the linear algebra of a linearly implicit
    step (a solve with the factors; a Jacobian and its factorisation)."""
    rec = Recorded(jit=True)
    rrr4.simulate(scene, rec, t_end=10 / scene.actuation.control_rate)
    system, x0, u0 = rec.seen
    ny, nz = system.ny, system.nz
    t, y, z = x0[0], x0[1:1 + ny], x0[1 + ny:1 + ny + nz]
    held = np.array(system.control(y, z, u0)).ravel()
    # each Function chained through its first input
    ys, zs, us = ca.MX.sym("y", ny), ca.MX.sym("z", nz), ca.MX.sym("u", u0.size)
    control = ca.Function("control", [ys, zs, us], [system.control(ys, zs, us)])
    ts, hs = ca.MX.sym("t"), ca.MX.sym("u", held.size)
    ode = ca.Function("ode", [ys, ts, zs, hs], [system.ode(ts, ys, zs, hs)])
    mat = w_matrix(system, second_order_split(system))
    c = GAMMA / scene.actuation.control_rate
    m = np.array(mat.renew(t, y, z, held, c)).ravel()
    r = np.array(system.ode(t, y, z, held)).ravel()
    return {"controller step": ns_per_call(control, [y, z, u0]), "held-effort RHS": ns_per_call(ode, [y, t, z, held]),
            "solve with the factors": ns_per_call(mat.solve, [r, m, c]),
            "Jacobian and factorisation": ns_per_call(mat.renew, [t, y, z, held, c])}


def work_precision(scene, repeat: int) -> None:
    T = scene.path.duration
    period = 1.0 / scene.actuation.control_rate
    runs = {f"default: {scene.integrator.method} at {scene.integrator.step:g} s": dict(integrator=None, step=None)}
    for step in (period, period / 2):
        for hold in ((1, 2, 5, 20, 100, 1000) if step == period else (1, 5)):
            runs[f"ros2 at {step:g} s, Jacobian held {hold} step{'s' if hold > 1 else ''}"] = dict(
                integrator=Ros2(jit=True, hold=hold), step=step)
    runs[f"ros2 at {period:g} s, gamma 1 - 1/sqrt(2), held 1 step"] = dict(
        integrator=Ros2(jit=True, hold=1, gamma=2 - GAMMA), step=period)
    k0 = next(iter(runs))
    k5 = f"ros2 at {period:g} s, Jacobian held 5 steps"
    ref = rrr4.simulate(scene, "rk4", step=1e-6)
    walls, sims, failed = {k: [] for k in runs}, {}, {}
    for k, kw in runs.items():  # warm-up: build and compile (cached on disk)
        try:
            rrr4.simulate(scene, kw["integrator"], step=kw["step"])
        except SimulationError as e:
            failed[k] = str(e).split(";")[0]
    for _ in range(repeat):
        for k, kw in runs.items():
            if k not in failed:
                sims[k] = rrr4.simulate(scene, kw["integrator"], step=kw["step"])
                walls[k].append(sims[k].stats["wall_time"])
    ns = floor(scene)
    floor_rtf = period / ((ns["controller step"] + ns["held-effort RHS"]) * 1e-9)
    print(f"\nwork-precision on {scene.name} ({T:g} s; error: max platform-position distance to RK4 at 1e-6 s; "
          f"medians of {repeat}; RTF = simulated s / stepping wall s)")
    print("| path | error [m] | stepping [s] | RTF | RTF / floor | Jacobians per step | <= 1 um |")
    print("|---|---|---|---|---|---|---|")
    for k in runs:
        if k in failed:
            print(f"| {k} | {failed[k]} | - | - | - | - | no |")
            continue
        sim, w = sims[k], float(np.median(walls[k]))
        e = float(np.max(np.linalg.norm(sim.pose[:, :2] - ref.pose[:, :2], axis=1)))
        print(f"| {k} | {e:.2e} | {w:.4f} | {T / w:.1f} | {T / w / floor_rtf:.2f} | "
              f"{sim.stats.get('jacobians_per_step', float('nan')):.3f} | {'yes' if e <= TARGET else 'no'} |")
    print(f"floor per control period ({period:g} s): controller step {ns['controller step']:.0f} ns + held-effort "
          f"RHS {ns['held-effort RHS']:.0f} ns = RTF {floor_rtf:.0f}; a solve with the factors "
          f"{ns['solve with the factors']:.0f} ns, a Jacobian and its factorisation "
          f"{ns['Jacobian and factorisation']:.0f} ns (compiled chains of 2000, medians of 21)")
    print("per control period, what the calls above account for against the measured stepping:")
    newton = sims[k0].stats["newton_iterations_per_step"]  # one RHS at the start and one per Newton update
    for k, rhs, solves in ((k0, 1 + newton, newton), (k5, 2, 2)):
        sim = sims[k]
        steps = period / sim.stats["step"]
        parts = ns["controller step"] + steps * (rhs * ns["held-effort RHS"] + solves * ns["solve with the factors"]
                                                  + sim.stats["jacobians_per_step"] * ns["Jacobian and factorisation"])
        measured = float(np.median(walls[k])) / (T / period) * 1e9
        print(f"  {k}: {rhs:.2f} RHS, {solves:.2f} solves, {sim.stats['jacobians_per_step']:.3f} Jacobians per step: "
              f"{parts:.0f} ns accounted of {measured:.0f} ns measured ({parts / measured:.0%})")


def impacts(repeat: int) -> None:
    """ROS2 where journals fly: 0.08 s of problems/no_preload_circle.yaml (journals centred, no
    preload), error against RK4 at 1e-6 s and contact losses, against Bathe at 1e-4 s."""
    scene = rrr4.load_scene(ROOT / "problems" / "no_preload_circle.yaml")
    t_end = 0.08
    ref = rrr4.simulate(scene, "rk4", step=1e-6, t_end=t_end)
    runs = {"bathe at 1e-4 s": ("bathe", 1e-4), "ros2 at 1e-4 s": (Ros2(jit=True), 1e-4),
            "ros2 at 1e-4 s, refine 4": (Ros2(jit=True, refine=4), 1e-4), "ros2 at 2.5e-5 s": (Ros2(jit=True), 2.5e-5)}
    print(f"\nimpacts: {scene.name}, {t_end:g} s; error against RK4 at 1e-6 s "
          f"({sum(ref.contact_loss_events.values())} contact losses)")
    print("| run | error [m] | contact losses | stepping [s] |")
    print("|---|---|---|---|")
    for k, (method, step) in runs.items():
        rrr4.simulate(scene, method, step=step, t_end=t_end)  # warm-up: build and compile
        sims = [rrr4.simulate(scene, method, step=step, t_end=t_end) for _ in range(repeat)]
        e = float(np.max(np.linalg.norm(sims[-1].pose[:, :2] - ref.pose[:, :2], axis=1)))
        print(f"| {k} | {e:.2e} | {sum(sims[-1].contact_loss_events.values())} | "
              f"{np.median([s.stats['wall_time'] for s in sims]):.4f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "problems" / "paper_circle.yaml"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--work-precision", action="store_true",
                    help="the default's candidates, the floor, and ROS2 on impacts")
    args = ap.parse_args(argv)
    os.environ.pop("RRR4_JIT", None)
    scene = rrr4.load_scene(args.scene)
    T = scene.path.duration
    runs = {"default": {}, "virtual machine (jit=False)": {"jit": False}}
    for kw in runs.values():
        rrr4.simulate(scene, **kw)  # warm-up: build, compile (cached on disk)
    walls = {k: [] for k in runs}
    for _ in range(args.repeat):
        for k, kw in runs.items():
            sim = rrr4.simulate(scene, **kw)
            walls[k].append(sim.stats["wall_time"])
            walls[k + " jit"] = sim.stats["jit"]
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}; scene {scene.name}, {T:g} s, "
          f"{scene.integrator.method} at {scene.integrator.step:g} s; medians of {args.repeat}")
    med = {k: float(np.median(walls[k])) for k in runs}
    for k in runs:
        print(f"  {k:28s} (jit {walls[k + ' jit']}): stepping {med[k]:.3f} s, real-time factor {T / med[k]:.2f}")
    print(f"  default / virtual machine speed: {med['virtual machine (jit=False)'] / med['default']:.1f}x")
    if args.work_precision:
        work_precision(scene, args.repeat)
        impacts(args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
