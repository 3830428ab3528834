"""Performance on the reference scene: what 1 um of platform accuracy costs in time.

The reference scene (problems/paper_circle.yaml): all 8 clearance joints, Lankarani-Nikravesh
contact, Ambrosio friction, the scene's QP preload, journals seated at t = 0, the full 1 s
circle, the controller sampled at 10 kHz. Everything runs in one process on one core (BLAS
threads limited to 1); times are medians of --repeat runs after a warm-up that builds and
compiles (the libraries are cached on disk); the real-time factor (RTF) is simulated s per
wall s of the stepping (stats['wall_time']); 'total' is the whole simulate call, with the
output processing. Error: max platform-position distance to RK4 at 1e-6 s of the same
physics and controller. Sections:

1. paths: the default call ``rrr4.simulate(scene)``; the same in reference-point coordinates
   (``integrator.coordinates: reference-point``); the same with the controller evaluated
   continuously inside every right-hand side (the exact-reference path: no control rate,
   references='exact'); compiled RK4 at 2.5e-5 s (its cheapest step within 1 um); Bathe with
   full Newton at the default's step (a new Jacobian and factorisation per iteration);
2. ns per right-hand side (RHS) of the held (default) and the exact-reference ODE, the
   implicit methods' Newton figures per step, and the right-hand sides each path evaluates per
   control period (their ratio bounds what the default can gain on RK4);
3. peak memory (max RSS of a child process) of a 1 s and a 60 s run (60 revolutions);
4. cost against the number of clearance joints: the 4-RRR with 0, 4 and 8 and the
   slider-crank, each at its scene's own settings;
5. (--ladders) the integrators' ladders of ``rrr4 bench accuracy``: the cheapest setting of
   each method within 1 um, against scipy;
6. error control: Bathe with a tolerance against fixed steps, on the reference scene, on
   the scene without preload (journals flying and hitting their bearings), and on the
   slider-crank's first impacts.

    .venv/bin/python benchmarks/bench_performance.py [--repeat 5] [--sections 12346] [--ladders]
"""

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import rrr4  # noqa: E402
from rrr4.codegen.build import machine  # noqa: E402
from rrr4.studies.bench import work_precision  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "problems" / "paper_circle.yaml"
TARGET = 1e-6   # m, max platform-position error
LADDERS = {     # method -> ('step' | 'rtol', settings cheapest first)
    "rk4": ("step", [1e-4, 8e-5, 6.25e-5, 5e-5, 4e-5, 2.5e-5, 1e-5]),
    "bathe": ("step", [1e-3, 5e-4, 2.5e-4, 2e-4, 1e-4, 5e-5, 2.5e-5]),
    "cvodes": ("rtol", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8]),
    "rk45": ("rtol", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]),
    "radau": ("rtol", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]),
}
SCIPY = ("rk45", "radau")
MEMORY = """
import resource, sys, time
import rrr4
from dataclasses import replace
scene = rrr4.load_scene(sys.argv[1])
T = float(sys.argv[2])
scene = replace(scene, path=replace(scene.path, duration=T, revolutions=round(T)))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
sim = rrr4.simulate(scene)
print(before, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, len(sim.t), sim.stats["steps"],
      time.perf_counter() - t0)
"""


def timed(runs: dict, repeat: int) -> dict:
    """{name: (median stepping wall, median total wall, last Simulation)}, runs interleaved."""
    for kw in runs.values():
        rrr4.simulate(**kw)  # warm-up: build and compile
    walls = {k: [] for k in runs}
    sims = {}
    for _ in range(repeat):
        for k, kw in runs.items():
            t0 = time.perf_counter()
            sims[k] = rrr4.simulate(**kw)
            walls[k].append((sims[k].stats["wall_time"], time.perf_counter() - t0))
    return {k: (*np.median(np.array(w), axis=0), sims[k]) for k, w in walls.items()}


def error(sim, ref) -> float:
    return float(np.max(np.linalg.norm(sim.pose[:, :2] - ref.pose[:, :2], axis=1)))


def paths(scene, repeat: int) -> dict:
    T = scene.path.duration
    cont = replace(scene, actuation=replace(scene.actuation, control_rate=None))
    step = scene.integrator.step
    full = replace(scene, integrator=replace(scene.integrator, newton="full"))
    flat = replace(scene, integrator=replace(scene.integrator, coordinates="reference-point"))
    runs = {
        f"default: {scene.integrator.method} at {step:g} s (simplified Newton, tree coordinates)": dict(scene=scene),
        "the same in reference-point coordinates": dict(scene=flat),
        "exact references: controller in every RHS, same method and step": dict(scene=cont, references="exact"),
        "compiled RK4 at 2.5e-5 s": dict(scene=scene, integrator="rk4", step=2.5e-5),
        f"bathe at {step:g} s, full Newton": dict(scene=full, integrator="bathe"),
    }
    refs = {id(scene): rrr4.simulate(scene, "rk4", step=1e-6), id(cont): rrr4.simulate(cont, "rk4", step=1e-6)}
    out = timed(runs, repeat)
    base = out["compiled RK4 at 2.5e-5 s"][0]
    print(f"\n1. paths ({T:g} s; medians of {repeat}; RTF = simulated / stepping wall)")
    print("| path | error [m] | stepping [s] | RTF | total [s] | RTF / RK4 2.5e-5 |")
    print("|---|---|---|---|---|---|")
    for k, (w, tot, sim) in out.items():
        ref = refs[id(runs[k]["scene"])] if runs[k]["scene"] not in (full, flat) else refs[id(scene)]
        print(f"| {k} | {error(sim, ref):.1e} | {w:.3f} | {T / w:.2f} | {tot:.3f} | {base / w:.2f} |")
    return out


def rhs_and_newton(scene, out: dict) -> None:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_rhs import chain, inputs

    from rrr4.integrators.compiled import compiled
    from rrr4.simulation import problem_system
    cont = replace(scene, actuation=replace(scene.actuation, control_rate=None))
    odes = {"held efforts (default)": problem_system(rrr4.build(scene)).ode,
            "exact references": problem_system(rrr4.build(cont), "exact").ode}
    K, reps = 2000, 21
    fs = {k: compiled(chain(f, K)) for k, f in odes.items()}
    ins = {k: inputs(f, PAPER) for k, f in odes.items()}
    times = {k: [] for k in fs}
    for _ in range(reps):
        for k, f in fs.items():
            t0 = time.perf_counter()
            f(*ins[k])
            times[k].append((time.perf_counter() - t0) / K * 1e9)
    print(f"\n2. right-hand side (compiled chain of {K}, medians of {reps}) and Newton per step")
    print("| ODE | SX instructions | ns per RHS |")
    print("|---|---|---|")
    for k, f in odes.items():
        print(f"| {k} | {f.n_instructions()} | {np.median(times[k]):.0f} |")
    # right-hand sides per control period: RK4 four per step; an implicit step one at its start
    # and one per Newton update (a residual is a right-hand side at the iterate)
    period = 1.0 / scene.actuation.control_rate
    print("| run | Newton iterations / step | Jacobians = factorisations / step | stages not converged | "
          "RHS per control period |")
    print("|---|---|---|---|---|")
    rhs = {}
    for k, (_, _, sim) in out.items():
        st = sim.stats
        per_step = 1 + st["newton_iterations_per_step"] if "newton_iterations_per_step" in st else 4
        rhs[k] = per_step * period / st["step"]
        newton = (f"{st['newton_iterations_per_step']:.2f} | {st['jacobians_per_step']:.3f} | {st['newton_failures']}"
                  if "newton_iterations_per_step" in st else "- | - | -")
        print(f"| {k} | {newton} | {rhs[k]:.1f} |")
    default, rk4 = next(iter(rhs)), "compiled RK4 at 2.5e-5 s"
    print(f"right-hand sides alone (no solves, Jacobians or controller) bound the default's ratio to RK4 at "
          f"{rhs[rk4] / rhs[default]:.1f}x")


def memory() -> None:
    print("\n3. peak memory of the default call (max RSS of a child process)")
    print("| simulated | outputs | steps | RSS before [MB] | peak RSS [MB] | growth [MB] | wall [s] |")
    print("|---|---|---|---|---|---|---|")
    runs = []
    for T in (1.0, 60.0):
        r = subprocess.run([sys.executable, "-c", MEMORY, str(PAPER), str(T)], capture_output=True, text=True,
                           check=True, cwd=ROOT)
        before, peak, n, steps, wall = r.stdout.split()
        runs.append((int(peak), int(n), int(steps)))
        print(f"| {T:g} s | {n} | {steps} | {int(before) / 1024:.0f} | {int(peak) / 1024:.0f} | "
              f"{(int(peak) - int(before)) / 1024:.0f} | {float(wall):.1f} |")
    (p1, n1, s1), (p60, n60, s60) = runs
    print(f"from 1 s to 60 s the peak grows by {(p60 - p1) / 1024:.0f} MB: {(p60 - p1) * 1024 / (n60 - n1):.0f} B per "
          f"extra output, or {(p60 - p1) * 1024 / (s60 - s1):.0f} B per extra step")


def scaling(scene, repeat: int) -> None:
    slider = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    variants = {}
    for clear in ((), ("B1", "B2", "B3", "B4"), ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")):
        data = rrr4.scene.read_yaml(PAPER)
        data["joints"]["clearance"] = list(clear)
        variants[f"4-RRR, {len(clear)} clearance joints"] = dict(scene=rrr4.scene.parse_scene(data))
    variants["slider-crank (Flores), 1 clearance joint"] = dict(scene=slider)
    out = timed(variants, repeat)
    print(f"\n4. cost against clearance joints (each scene's own settings; medians of {repeat})")
    print("| scene | method, step | RHS SX instructions | stepping [s] / simulated s | RTF |")
    print("|---|---|---|---|---|")
    for k, (w, _, sim) in out.items():
        T = sim.t[-1]
        st = sim.stats
        print(f"| {k} | {st['method']}, {st['step']:g} s | {st['graph']['ode']['instructions']} | {w / T:.3f} | "
              f"{T / w:.2f} |")


def ladders(scene) -> None:
    T = scene.path.duration
    rows = work_precision(scene, t_end=T, plan=LADDERS, progress=True)
    print("\n5. ladders (controller continuous, as in rrr4 bench accuracy)")
    for r in rows:
        if r["status"] == "cross-check":
            print(f"reference {r['reference']}: distance to {r['method']} = {r['error_m']:.1e} m")
    best = {}
    for method in LADDERS:
        for r in (r for r in rows if r["method"] == method and r["status"] != "cross-check"):
            ok = r["status"] == "ok" and r["error_m"] <= TARGET
            print(f"  {method:8s} {r['kind']} {r['setting']:8.2e}: {r['status']:8s} error {r['error_m']:8.2e} m, "
                  f"wall {r['cpu_s']:8.3f} s, {r['steps']} steps{'  <= 1 um' if ok else ''}")
            if ok:
                best[method] = r
                break
        else:
            print(f"  {method}: no setting of the ladder reaches {TARGET:g} m")
    scipy = {k: v["cpu_s"] for k, v in best.items() if k in SCIPY}
    base = min(scipy, key=scipy.get) if scipy else None
    print(f"cheapest setting with max platform error <= {TARGET:g} m over {T:g} s:")
    for method, r in best.items():
        ratio = f"{scipy[base] / r['cpu_s']:8.1f}x" if base else "     n/a"
        print(f"  {method:8s} {r['kind']} {r['setting']:8.2e}  error {r['error_m']:8.2e} m  wall {r['cpu_s']:8.3f} s  "
              f"real-time factor {T / r['cpu_s']:7.2f}  {base} / method {ratio}")


def error_control(scene, repeat: int) -> None:
    """Bathe with a tolerance (its step the largest) against fixed steps: on the reference
    scene, whose preload keeps every journal in contact; on the scene without preload, whose
    journals fly and hit their bearings hundreds of times (0.3 s of it); on the slider-crank's
    first impacts (2 ms)."""
    def bathe(sc, step, tolerance=None, newton_tol=1e-7):
        return replace(sc, integrator=replace(sc.integrator, method="bathe", step=step, gamma=2 - np.sqrt(2),
                                              newton_tol=newton_tol, newton="simplified", tolerance=tolerance))

    impacts = rrr4.load_scene(ROOT / "problems" / "no_preload_circle.yaml")
    T = 0.3
    cases = {
        "reference scene, default (fixed 1e-4 s)": (dict(scene=scene), scene.path.duration),
        "reference scene, tolerance 1e-7 m, largest step 1e-4 s": (dict(scene=bathe(scene, 1e-4, 1e-7)),
                                                                   scene.path.duration),
        "no preload, RK4 at 2.5e-5 s": (dict(scene=impacts, integrator="rk4", step=2.5e-5, t_end=T), T),
        "no preload, Bathe fixed 1e-4 s": (dict(scene=bathe(impacts, 1e-4), t_end=T), T),
        "no preload, Bathe fixed 1e-5 s": (dict(scene=bathe(impacts, 1e-5), t_end=T), T),
    }
    for step, tol in ((1e-4, 1e-8), (1e-4, 1e-10), (1e-5, 1e-8), (1e-5, 1e-10)):
        cases[f"no preload, tolerance {tol:g} m, largest step {step:g} s"] = (
            dict(scene=bathe(impacts, step, tol), t_end=T), T)
    slider = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    Ts = 2e-3  # the slider-crank's first impacts
    cases["slider-crank, its default RK4 at 1e-6 s"] = (dict(scene=slider, t_end=Ts), Ts)
    for tol in (1e-9, 1e-10):
        cases[f"slider-crank, tolerance {tol:g} m, largest step 1e-05 s"] = (
            dict(scene=bathe(slider, 1e-5, tol, newton_tol=1e-8), t_end=Ts), Ts)
    refs = {"reference": rrr4.simulate(scene, "rk4", step=1e-6),
            "no preload": rrr4.simulate(impacts, "rk4", step=2.5e-7, t_end=T),
            "slider-crank": rrr4.simulate(slider, step=2.5e-7, t_end=Ts)}
    out = timed({k: kw for k, (kw, _) in cases.items()}, repeat)
    print(f"\n6. error control (medians of {repeat}; error against RK4 at 1e-6 s (reference scene) and 2.5e-7 s "
          "(no preload; slider-crank: its slider's x, refine 16))")
    print("| run | error [m] | steps | rejected | smallest step [s] | stepping [s] | RTF |")
    print("|---|---|---|---|---|---|---|")
    for k, (w, _, sim) in out.items():
        _, dur = cases[k]
        which = next(r for r in refs if k.startswith(r))
        ref = refs[which]
        err = (np.max(np.abs(sim.body("slider")[:, 0] - ref.body("slider")[:, 0])) if which == "slider-crank" else
               error(sim, ref))
        st = sim.stats
        print(f"| {k} | {err:.1e} | {st['steps']} | {st.get('rejected_steps', '-')} | "
              f"{st.get('smallest_step', st['step']):.3g} | {w:.3f} | {dur / w:.2f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--sections", default="12346", help="which of sections 1-6 to run (default 12346)")
    ap.add_argument("--ladders", action="store_true", help="also run section 5, the ladders (minutes)")
    args = ap.parse_args(argv)
    run = set(args.sections) | ({"5"} if args.ladders else set())
    os.environ.pop("RRR4_JIT", None)
    scene = rrr4.load_scene(PAPER)
    print(f"machine: {machine()}, one core used; load average {os.getloadavg()[0]:.2f}; casadi {ca.__version__}")
    if run & {"1", "2"}:
        out = paths(scene, args.repeat)
        if "2" in run:
            rhs_and_newton(scene, out)
    if "3" in run:
        memory()
    if "4" in run:
        scaling(scene, args.repeat)
    if "5" in run:
        ladders(scene)
    if "6" in run:
        error_control(scene, args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
