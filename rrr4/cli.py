"""`rrr4` command line. Bad input prints one message and exits 2; never a traceback."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from . import __version__
from .checks import argument, unknown_value
from .errors import Rrr4Error, SceneError
from .files import check_writable, request_stop
from .scene.vocabulary import IDENTIFICATION_DEFAULT, IDENTIFICATION_METHODS, OBJECTIVES


def _check(args) -> int:
    """Exit 0: the scene is valid and its preload holds along the path; 1: valid, but the
    preload cannot hold (printed where and by how much); 2: invalid (one line)."""
    from .mechanism import load_scene
    from .problem import build
    from .results.summary import scene_check
    problem = build(load_scene(args.scene))
    text, preload = scene_check(problem)
    print(text)
    if preload is not None and not preload.all_feasible:
        mode = ("; it was evaluated on the assembly branch taken at t = 0, and others close there (listed above): if "
                "another is the one meant, name it in mechanism.assembly") if problem.branch_hint else ""
        _say(f"rrr4 check: the scene is valid, but its preload cannot hold along the path (see above){mode}")
        return 1
    return 0


def _codegen(args) -> int:
    from .codegen import codegen
    from .mechanism import load_scene
    branch = args.branch if args.branch == "auto" else int(args.branch)
    check_writable(args.out)
    for f in codegen(load_scene(args.scene), args.out, branch=branch):
        print(f)
    print(f"build the example with: cd {args.out} && gcc -O2 -Wall *.c -lm -o example && ./example")
    return 0


def _run(args) -> int:
    from pathlib import Path

    from tqdm import tqdm

    from .integrators import METHODS
    from .mechanism import load_scene
    from .results import check_target, write_results
    from .results.metrics import check_skip
    from .results.summary import verdict_line
    from .studies.study import run_study
    if args.t_end is not None:
        argument("--t-end", args.t_end)
    for key in ("step", "output_rate"):
        if getattr(args, key) is not None:
            argument(f"--{key.replace('_', '-')}", getattr(args, key))
    if args.integrator is not None and args.integrator not in METHODS:
        raise unknown_value("--integrator", "integrator", args.integrator, METHODS)
    if args.skip is not None:
        argument("--skip", args.skip, allow_zero=True)
    if args.converge is not None:
        argument("--converge", args.converge)
    scene = load_scene(args.scene)
    t_end = scene.path.duration if args.t_end is None else args.t_end
    step = scene.integrator.step if args.step is None else args.step
    if args.output_rate is not None and args.output_rate > (1 + 1e-9) / step:
        raise SceneError(f"--output-rate: {args.output_rate:g} Hz is not allowed at step {step:g} s (at most one "
                         f"output per step: <= {1 / step:g} Hz)")
    skip = check_skip(args.skip or 0.0, t_end, "--skip")
    out = Path(args.out) if args.out else Path("results") / scene.name
    check_writable(out)
    check_target(out)
    study = run_study(scene, t_end=args.t_end, integrator=args.integrator, step=args.step,
                      output_rate=args.output_rate, skip=skip, converge=args.converge, progress=True,
                      log=lambda m: tqdm.write(f"rrr4 run: {m}"))
    summary, files = write_results(study, out, progress=True)
    print(f"wrote {len(files)} files to {out}/: {', '.join(files)}")
    print((out / "report.md").read_text())
    if (line := verdict_line(summary)) is not None:  # the one line that says which numbers not to trust
        _say(f"rrr4 run: {line}")
    return 0


def _optimize(args) -> int:
    from pathlib import Path

    from tqdm import tqdm

    from .files import check_target
    from .mechanism import load_scene
    from .results.optimal import MARKER, write_optimization
    from .studies.optimize import optimize
    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results") / f"{scene.name}_optimal"
    check_writable(out)
    check_target(out, MARKER)
    opt = optimize(scene, args.objective, points=args.points, duration=args.duration, target=args.to,
                   nodes=args.nodes, replay=not args.no_replay, progress=True,
                   log=lambda m: tqdm.write(f"rrr4 optimize: {m}"))
    summary, files = write_optimization(opt, out, animate=not args.no_replay, progress=True)
    print(f"wrote {len(files)} files to {out}/")
    law = summary["law"]
    grid = f"{law['points']} points" if "points" in law else f"{law['nodes']} nodes"
    st = law["statistics"]
    steps = f"{st['iterations']} iterations, " if "iterations" in st else ""
    print(f"optimal duration: {law['duration_s']:.6g} s ({law['objective']}, "
          f"{'with the contact condition' if law['contact_condition'] else 'actuator limits'}, "
          f"{grid}, {st['solver']}, {steps}{st['solve_time_s']:.3g} s solve)")
    if "max_condition_number_at_nodes" in law:
        contact = law.get("min_contact_margin_along_N")
        print(f"along the whole motion ({law['margins_checked_at']} instants): largest condition number of J "
              f"{law['max_condition_number']:.4g} ({law['max_condition_number_at_nodes']:.4g} at the nodes), peak "
              f"effort {law['peak_effort_ratio_along']:.6g} x its limit"
              + ("" if contact is None else f", smallest contact margin {contact:.3g} N"))
    if "replay_time_law" in summary["statistics"]:
        r = summary["statistics"]["replay_time_law"]
        print(f"replayed: the motion's path {r['what']}, {r['duration_s']:.6g} s")
    if summary.get("contact_cost_ratio"):
        print(f"with the actuator limits only: {summary['optimal_duration_limits_only_s']:.6g} s; keeping contact "
              f"costs x{summary['contact_cost_ratio']:.3f} in cycle time")
    for arm, m in (summary.get("replay") or {}).items():
        print(f"replay {arm}: contact losses {sum(m['contact_loss_events'].values())}, platform error RMS "
              f"{m['platform_error_rms_m'] * 1e6:.3g} um, torque RMS {m['torque_rms_Nm']:.3g}"
              + ("" if m.get("converged", True) else ", NOT CONVERGED (energy audit residual "
                 f"{m['energy_audit_residual']:.3g} > {m['energy_audit_tolerance']:g}): not to be trusted"))
    if summary.get("headroom"):
        h = summary["headroom"]
        print(f"f_min headroom: {h['tried']}; smallest f_min without losses: {h['smallest_f_min_without_losses_N']}")
    return 0


def _animate(args) -> int:
    from .results.animation import render
    if args.out:
        check_writable(args.out, kind="file")
    print(render(args.result_dir, args.out, frames=args.frames, fps=args.fps, magnification=args.magnification,
                 progress=True))
    return 0


def _bench(args) -> int:
    from .mechanism import load_scene
    from .studies.bench import work_precision, write_work_precision
    if args.t_end is not None and not (args.t_end > 0):
        raise SceneError(f"--t-end: {args.t_end!r} is not allowed (must be > 0 s)")
    scene = load_scene(args.scene)
    out = check_writable(args.out or "results/work_precision")
    t_end = scene.path.duration if args.t_end is None else args.t_end
    rows = work_precision(scene, t_end=t_end, progress=True)
    for f in write_work_precision(rows, scene, out, t_end):
        print(f)
    return 0


def _robustness(args) -> int:
    from pathlib import Path

    from tqdm import tqdm

    from .mechanism import load_scene
    from .studies.robustness import write_robustness
    if args.t_end is not None:
        argument("--t-end", args.t_end)
    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results") / f"{scene.name}_robustness"
    check_writable(out)
    for f in write_robustness(scene, out, t_end=args.t_end, log=lambda m: tqdm.write(f"rrr4 robustness: {m}"),
                              identified=args.identified):
        print(f)
    return 0


def _wear(args) -> int:
    from pathlib import Path

    from tqdm import tqdm

    from .mechanism import load_scene
    from .results import check_target
    from .results.wear import write_wear
    from .studies.wear import wear_study
    argument("--cycles", args.cycles)
    if args.max_change is not None:
        argument("--max-change", args.max_change)
    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results") / scene.name
    check_writable(out)
    check_target(out)
    given = {} if args.max_change is None else {"max_change": args.max_change}
    study = wear_study(scene, args.cycles, check=not args.no_check, progress=True,
                       log=lambda m: tqdm.write(f"rrr4 wear: {m}"), **given)
    summary, names = write_wear(study, out)
    for name, arm in summary["arms"].items():
        print(f"{name}: worn volume {arm['worn_volume_m3']:.3g} m^3 after {summary['cycles']:g} cycles "
              f"({arm['simulated_cycles']} simulated, {arm['wall_time_s']:.1f} s)")
    for n in names:
        print(out / n)
    return 0


def _key_values(option: str, text: str | None, what: str) -> dict:
    """'a,b=1:2' -> {'a': None, 'b': [1.0, 2.0]} (what: the value's form, for the message)."""
    from .errors import SceneError
    out: dict = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        key, _, value = item.partition("=")
        if not value:
            out[key.strip()] = None
            continue
        try:
            parts = [float(v) for v in value.split(":")]
        except ValueError:
            parts = []
        if len(parts) != (1 if what == "STD" else 2):
            raise SceneError(f"{option}: {item!r} is not allowed (KEY or KEY={what}, comma-separated)")
        out[key.strip()] = parts if len(parts) == 2 else parts[0]
    return out


def _windows(text: str | None) -> int:
    """--windows N as an int (1 without it); the range is checked by identify."""
    if text is None:
        return 1
    try:
        return int(text)
    except ValueError:
        from .errors import SceneError
        raise SceneError(f"--windows: {text!r} is not allowed (a whole number of windows >= 1, e.g. 10)") from None


def _identify(args) -> int:
    from pathlib import Path

    from .identify import identify, read_measurements
    from .mechanism import load_scene
    from .results.identification import MARKER, write_identification
    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results") / f"{scene.name}_identified"
    check_writable(out)
    from .files import check_target
    check_target(out, MARKER)
    if args.method == "seated":  # a scene the method cannot model: one line before the measurements are read
        from .identify.seated import check_seated
        from .problem import Problem
        check_seated(Problem.from_scene(scene))
    parameters = _key_values("--parameters", args.parameters, "LOWER:UPPER") or None
    noise = _key_values("--noise", args.noise, "STD")
    if any(v is None for v in noise.values()):
        from .errors import SceneError
        raise SceneError(f"--noise: {args.noise!r} is not allowed (COLUMN=STD, comma-separated, e.g. x_m=1e-6)")
    window = None
    if args.window:
        try:
            window = [float(v) for v in args.window.split(":")]
        except ValueError:
            window = []
        if len(window) != 2 or not window[0] < window[1]:
            from .errors import SceneError
            raise SceneError(f"--window: {args.window!r} is not allowed (T0:T1 in s with T0 < T1, e.g. 0.2:0.8)")
    measured = read_measurements(args.measurements, scene, arm=args.arm)
    if window is not None:
        measured = measured.window(*window)
    ident = identify(scene, measured, parameters=parameters, method=args.method, noise=noise or None,
                     windows=_windows(args.windows))
    files = write_identification(ident, out)
    print(ident.table())
    print(f"wrote {', '.join(files)} to {out}/")
    return 0


def _compare(args) -> int:
    """Exit 0 when every number of the two results agrees within --rtol, 1 when some differ."""
    from .results.compare import RUN_SPECIFIC, compare_results
    argument("--rtol", args.rtol, allow_zero=True)
    n, diffs = compare_results(args.first, args.second, rtol=args.rtol)
    print(f"{n} values of summary.json compared (not {', '.join(RUN_SPECIFIC)}); "
          f"{len(diffs)} differ beyond rtol {args.rtol:g}")
    for key, a, b in diffs:
        print(f"  {key}: {a} | {b}" + ("  (the verdict changed)" if key.endswith(".converged") else ""))
    return 1 if diffs else 0


def _map(args) -> int:
    from pathlib import Path

    from .mechanism import load_scene
    from .studies.maps import write_map
    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results") / f"{scene.name}_map"
    check_writable(out)
    for f in write_map(scene, out, grid=args.grid):
        print(f)
    return 0


def _sweep(args) -> int:
    from tqdm import tqdm

    from .studies.sweeps import sweep
    r = sweep(args.spec, out=args.out, scheduler=args.scheduler, workers=args.workers, progress=True,
              log=lambda m: tqdm.write(f"rrr4 sweep: {m}"))
    print(f"{r['cases']} cases: {r['skipped']} skipped (already done), {r['cases'] - r['skipped']} run, "
          f"{r['failed']} failed; rows in {r['csv']}; figures: {', '.join(f.name for f in r['figures'])}")
    how = " (masses and geometry as inputs, references tabulated per case)" if r["options"] else ""
    print(f"stepping: {'compiled C' if r['compiled'] else 'CasADi virtual machine'}{how}; "
          f"{r['compilations']} C libraries compiled, the rest from the shared cache")
    run = r["cases"] - r["skipped"]
    if run:
        what = {"plant": "the equations and compiled stepping", "controller": "the controller step",
                "preload": "the preload's sign choice and the mechanism"}
        print("reused in their worker: " + "; ".join(f"{what[k]} by {n} of {run} cases"
                                                     for k, n in r["reused"].items()))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rrr4",
        description="Planar redundantly actuated parallel mechanisms (any planar body/joint graph; the 4-RRR is "
                    "the reference scene) with revolute joint clearance: kinematics, preload, contact dynamics and "
                    "C code generation.")
    p.add_argument("--version", action="version", version=f"rrr4 {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    c = sub.add_parser("check", help="validate a scene, print what it would simulate and evaluate its preload along "
                                      "the path (exit 1 when the preload cannot hold, 2 when the scene is invalid)")
    c.add_argument("scene", help="scene YAML file, e.g. problems/paper_circle.yaml")
    c.set_defaults(func=_check)
    g = sub.add_parser("codegen", help="write self-contained C of the scene's controller step (a graph's: its "
                                        "references tabulated along the path; a 4-RRR's also IK, Jacobian, "
                                        "preload, QP), a header, an example main.c and a Makefile")
    g.add_argument("scene", help="scene YAML file with a task body and actuators, e.g. problems/paper_circle.yaml "
                                 "or problems/redundant_five_bar.yaml")
    g.add_argument("--out", required=True, help="directory to write the C files into (created if needed)")
    g.add_argument("--branch", choices=["auto", "1", "-1", "0"], default="auto",
                   help="exact-preload branch of a 4-RRR's exact_preload and preload functions: alpha >= 0 (1), "
                        "<= 0 (-1), global optimum per step (0), or the one rrr4 solve_preload picks on the "
                        "scene's path (auto, default)")
    g.set_defaults(func=_codegen)
    r = sub.add_parser("run", help="run the study of a scene: inverse dynamics, preload, clearance simulation "
                                    "with preload, with preload and compensation, and without preload (a driven "
                                    "scene: with clearance and with ideal joints); writes figures, CSV, "
                                    "summary.json, report.md")
    r.add_argument("scene", help="scene YAML file, e.g. problems/paper_circle.yaml")
    r.add_argument("--out", help="result directory (default results/<scene name>/); replaced atomically")
    r.add_argument("--t-end", type=float, default=None, help="simulated time [s] (default: the path duration)")
    r.add_argument("--integrator", metavar="METHOD", help="integration method instead of the scene's "
                                                          "integrator.method (one of rrr4.integrators.METHODS)")
    r.add_argument("--step", type=float, help="integrator step [s] instead of the scene's integrator.step")
    r.add_argument("--output-rate", type=float, metavar="HZ",
                   help="outputs kept per second [Hz] (default: every step; at most 1/step)")
    r.add_argument("--converge", type=float, nargs="?", const=120.0, metavar="BUDGET",
                   help="rerun an arm that has not converged (its energy audit) at half its step until it has, "
                        "within BUDGET seconds of wall time per arm (default 120); summary.json's "
                        "step_refinement says what was tried and what it cost")
    r.add_argument("--skip", type=float, metavar="S",
                   help="start-up window [s] the metrics over the output samples discard (0 <= S < t_end; "
                        "summary.json's metrics_window says which metrics it applies to)")
    r.set_defaults(func=_run)
    op = sub.add_parser("optimize", help="the optimal time law along the scene's path (every actuator within its "
                                         "limit, every passive joint loaded, as the preload layer requires), the "
                                         "same with the actuator limits only, and its replay with the clearance "
                                         "dynamics and the scene's controller; writes figures, time_law.csv, "
                                         "optimization.json and replay/")
    op.add_argument("scene", help="scene YAML file with a task body, e.g. problems/paper_circle.yaml")
    op.add_argument("--objective", choices=OBJECTIVES, default="time",
                    help="time (default), effort (at --duration) or time+effort")
    op.add_argument("--duration", type=float, default=None, help="duration [s] for --objective effort or "
                                                                   "time+effort (refused with time)")
    op.add_argument("--points", type=int, default=None, help="grid intervals along the path (default 1000; "
                                                             "refused with --to)")
    op.add_argument("--to", nargs="+", type=float, metavar="V",
                    help="a point-to-point motion instead: rest to rest from the path's start to the task pose "
                         "X [m], Y [m], PHI [rad] (a task point: X Y), the path free")
    op.add_argument("--nodes", type=int, default=None, help="intervals of a --to motion (default 40; refused "
                                                            "without --to)")
    op.add_argument("--no-replay", action="store_true", help="solve only; do not replay the law")
    op.add_argument("--out", help="directory (default results/<scene name>_optimal/); replaced atomically")
    op.set_defaults(func=_optimize)
    an = sub.add_parser("animate", help="remake the animation (motion.gif) of a saved result without simulating")
    an.add_argument("result_dir", help="a result directory of rrr4 run, e.g. results/paper_circle")
    an.add_argument("--out", help="file to write: .gif, or .mp4 when ffmpeg is installed (default "
                                  "RESULT_DIR/motion.gif)")
    an.add_argument("--fps", type=float, default=None, help="frames per second (default 10)")
    an.add_argument("--frames", type=int, default=None, help="number of frames (default 60; fewer when the "
                                                              "result has fewer samples)")
    an.add_argument("--magnification", type=float, default=None,
                    help="factor the clearance circles and eccentricities are drawn magnified by (default: the "
                         "largest circle 4 %% of the drawing)")
    an.set_defaults(func=_animate)
    rb = sub.add_parser("robustness", help="the preloaded controller, with and without clearance compensation, "
                                           "keeping the nominal model while the mechanism differs (clearance, "
                                           "stiffness, friction, a link length); writes robustness.json/.png")
    rb.add_argument("scene", help="scene YAML file of an n-RRR scene, e.g. problems/paper_circle.yaml")
    rb.add_argument("--out", help="directory (default results/<scene name>_robustness/); the two files are "
                                  "replaced atomically")
    rb.add_argument("--t-end", type=float, default=None, help="simulated time [s] (default: the path duration)")
    rb.add_argument("--identified", action="store_true",
                    help="also identify each perturbed mechanism from its uncompensated run (rrr4 identify) and run "
                         "the compensated controller with the identified and with the true model")
    rb.set_defaults(func=_robustness)
    wr = sub.add_parser("wear", help="Archard wear of the clearance joints over many cycles by cycle jumping "
                                     "(the scene's effects.wear); writes wear profiles (polar), their history "
                                     "over the cycles, history.csv, profiles.csv, summary.json and report.md")
    wr.add_argument("scene", help="scene YAML file asking for wear, e.g. problems/paper_circle_wear.yaml")
    wr.add_argument("--cycles", type=float, required=True, help="number of cycles N (a whole number; one cycle is "
                                                                 "the path, or one revolution of a driven scene)")
    wr.add_argument("--max-change", type=float, default=None, metavar="F",
                    help="the deepest change of a wear profile per jump, in radial clearances (0 < F <= 1); "
                         "default: 0.02 (rrr4.studies.wear.DEFAULT_MAX_CHANGE), and the study again with the "
                         "smaller F the jump-error check names where it finds the error above 2 %% of the deepest "
                         "depth")
    wr.add_argument("--no-check", action="store_true",
                    help="skip the jump-error check (the first arm again with half the jumps)")
    wr.add_argument("--out", help="directory (default results/<scene name>/); replaced atomically")
    wr.set_defaults(func=_wear)
    idn = sub.add_parser("identify", help="identify clearances, friction, contact stiffness or link lengths of a "
                                          "scene from measured task poses, actuator angles and efforts (a CSV with "
                                          "the column names of a study's timeseries.csv); writes identified.yaml, "
                                          "identification.json and figures")
    idn.add_argument("scene", help="the nominal scene YAML, e.g. problems/paper_circle.yaml")
    idn.add_argument("measurements", help="CSV file: t_s and any of x_m, y_m, theta_rad, theta_<A>_rad, "
                                          "tau_<A>_Nm (optionally behind an arm prefix such as with_preload_)")
    idn.add_argument("--parameters", help="comma-separated scene keys, each optionally KEY=LOWER:UPPER (default "
                                          "joints.radial_clearance,effects.friction.coefficient,"
                                          "effects.contact.stiffness)")
    idn.add_argument("--method", choices=IDENTIFICATION_METHODS, default=IDENTIFICATION_DEFAULT,
                     help="staged (default: seated first where a preload seats the journals, then dynamic over the "
                          "whole record from its estimates), seated (quasi-static, journals seated under preload) or "
                          "dynamic (shooting through the simulation with its forward sensitivities; refuses a run "
                          "whose journals rattle)")
    idn.add_argument("--arm", help="the arm prefix of a timeseries.csv with several arms, e.g. with_preload")
    idn.add_argument("--noise", help="noise levels COLUMN=STD, comma-separated (default: estimated from the "
                                     "residuals)")
    idn.add_argument("--window", help="fit only the rows with T0 <= t <= T1 [s], as T0:T1")
    idn.add_argument("--windows", metavar="N", help="methods dynamic and staged: multiple shooting over N windows "
                                                    "whose start states are extra unknowns (default 1: single "
                                                    "shooting from t = 0)")
    idn.add_argument("--out", help="directory (default results/<scene name>_identified/); replaced atomically")
    idn.set_defaults(func=_identify)
    sw = sub.add_parser("sweep", help="run the study over a grid of scene values or a tolerance Monte Carlo, on "
                                      "Dask; writes results.csv (one row per case and arm), skips finished cases")
    sw.add_argument("spec", help="sweep spec YAML, e.g. problems/sweeps/clearance_vs_preload.yaml")
    sw.add_argument("--out", help="directory (default results/sweeps/<spec name>/)")
    sw.add_argument("--scheduler", help="address of a running Dask scheduler, tcp://HOST:PORT (e.g. "
                                        "tcp://127.0.0.1:8786; tls:// is not supported: no certificate options); "
                                        "default: a local cluster on this machine")
    sw.add_argument("--workers", type=int, help="worker processes of the local cluster (default: the cores)")
    sw.set_defaults(func=_sweep)
    mp = sub.add_parser("map", help="workspace maps of a scene with a task body (n-RRR or graph): Jacobian "
                                    "condition number, smallest transmission (n-RRR), and the preload torque that "
                                    "holds f_min at rest and under the path's peak acceleration; writes map.png, "
                                    "map.npz, map.json")
    mp.add_argument("scene", help="scene YAML file, e.g. problems/paper_circle.yaml")
    mp.add_argument("--out", help="directory (default results/<scene name>_map/)")
    mp.add_argument("--grid", type=int, default=101, help="points per axis (default 101)")
    mp.set_defaults(func=_map)
    cp = sub.add_parser("compare", help="compare two results of rrr4 run (their summary.json, without wall and "
                                         "compile times): exit 0 when they agree within --rtol, 1 when not")
    cp.add_argument("first", help="a result directory, e.g. results/paper_circle (the committed result)")
    cp.add_argument("second", help="another, e.g. runs/paper_circle (your run)")
    cp.add_argument("--rtol", type=float, default=1e-2,
                    help="relative tolerance (default 0.01: rattling without preload is chaotic, so its counts and "
                         "peaks move with the last bits of the arithmetic)")
    cp.set_defaults(func=_compare)
    b = sub.add_parser("bench", help="what accuracy costs in time")
    bsub = b.add_subparsers(dest="bench", metavar="BENCH", required=True)
    a = bsub.add_parser("accuracy", help="work-precision diagram (error vs CPU time per integrator) and CSV")
    a.add_argument("scene", help="scene YAML file, e.g. problems/paper_circle.yaml")
    a.add_argument("--out", help="output directory (default: results/work_precision/)")
    a.add_argument("--t-end", type=float, default=None,
                   help="simulated time [s] from the path's start (default: the path duration)")
    a.set_defaults(func=_bench)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    interrupted = []

    def on_signal(signum, frame):
        interrupted.append(signum)
        request_stop()  # should the interrupt be lost inside a CasADi solver, nothing is written and loops stop
        raise KeyboardInterrupt

    # SIGTERM unwinds like Ctrl-C, so temporary files are removed; the handlers are restored after
    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        with _compiling(f"rrr4 {args.command}"):
            status = args.func(args)
        return _interrupted(interrupted) if interrupted else status
    except Rrr4Error as e:
        if interrupted:  # e.g. a solver stopped by the interrupt reported that it had not converged
            return _interrupted(interrupted)
        _say(f"rrr4: error: {type(e).__name__}: {e}")
        return 2
    except KeyboardInterrupt:
        return _interrupted(interrupted)
    except Exception:
        if interrupted:  # a signal that landed inside a CasADi call comes back as its error (a RuntimeError of
            return _interrupted(interrupted)  # a mapped call such as map1001_qp_preload, a SystemError, ...)
        raise
    except BrokenPipeError:  # e.g. `rrr4 check SCENE | head`: the reader left, nothing to report
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        request_stop(False)


class _compiling:
    """While it is open, 'compiling ...' is said on stderr whenever the C compiler runs, and what
    the compile policy decided when it compiles nothing."""

    def __init__(self, who: str):
        self.who = who

    def __enter__(self):
        from .codegen.build import compile_notice, decision_notice
        self.previous = compile_notice(lambda stem: _say(f"{self.who}: compiling {stem} (C compiler; the result is "
                                                         "cached, later runs skip this) ..."))
        self.previous_say = decision_notice(lambda text: _say(f"{self.who}: {text}"))
        return self

    def __exit__(self, *exc):
        from .codegen.build import compile_notice, decision_notice
        compile_notice(self.previous)
        decision_notice(self.previous_say)
        return False


def _say(line: str) -> None:
    """One line on stderr, above any progress bar still drawn."""
    from tqdm import tqdm
    tqdm.write(line, file=sys.stderr)


def _interrupted(signals: list) -> int:
    term = signal.SIGTERM in signals
    _say(f"rrr4: {'terminated' if term else 'interrupted'}; earlier results are left as they were")
    return 143 if term else 130


if __name__ == "__main__":
    sys.exit(main())
