"""`rrr4.simulate`: the front door of contact-dynamics simulation.

The problem decides the equations (``Problem.equations``); this module feeds them with
references, picks the integrator and rolls it inside compiled CasADi, its outputs written at
their rate as it runs (:mod:`.outputs`).

Torque mode: the efforts are the problem's controller's (:mod:`rrr4.control`: feed-forward,
preload, compensation, PD), run continuously inside the right-hand side or sampled at
``actuation.control_rate`` with a zero-order hold (then the right-hand side only takes the
held efforts). An n-RRR runs its closed-form controller step (in CasADi, or its generated C
in the loop); any other graph with a task body tabulates the controller's references on the
path samples and runs the same feedback law on them, interpolated (cubic Hermite), or its
generated table step in the loop (:func:`rrr4.control.controller_step`), which holds the
same references and interpolation. A
``preload`` override (anything with ``t`` (N,) [s] and ``tau`` (N, n), e.g. a
PreloadSolution) replaces the controller's feed-forward.

Prescribed mode: theta_ref(t), theta_d_ref, theta_dd_ref from the path's IK (closed form for
an n-RRR, inside the graph; Newton and interpolation for other graphs). In the 'free' mode
the actuators carry no effort. A graph without a task body moves by its drivers
(prescribed joint coordinates, constraint rows in time).
"""

from __future__ import annotations

import functools
import inspect
import math
import os
import time
import warnings
from dataclasses import replace

import casadi as ca
import numpy as np
from scipy.interpolate import CubicHermiteSpline

from ..checks import argument, describe, unknown_value
from ..control import CONTROLLERS, interpolants, prescribed_references, reference_function, step_inputs, tabulated
from ..dynamics.builder import with_profiles
from ..errors import SceneError, SimulationError
from ..files import c_compiler
from ..functions import graph_size, mapped
from ..integrators import BACKGROUND, METHODS, FrameInputs, Integrator
from ..problem import Problem
from ..scene import MAX_SAMPLES, IntegratorSettings, Scene
from .initial import initial_state
from .outputs import Outputs
from .result import Simulation
from .system import REFERENCES, Loop, in_tree, loop_of, measured, system_of

__all__ = ["simulate", "OVERRIDES", "default_jit", "frame_times", "controller_efforts", "run_end", "run_references"]

MAX_STEPS = 1e10  # integrator steps one simulate call may take


_NO_COMPILER_WARNED = False


def default_jit() -> bool | str:
    """How simulate steps by default: where a C compiler exists, 'background' (a frame whose
    library is in the on-disk cache steps in it; otherwise a process of its own compiles it
    while CasADi's virtual machine steps, and the run moves to the library, bit for bit the
    same states, at its next block once it is ready, or the next run does: a first run never
    waits for the compiler); RRR4_JIT=1 compiles first and then steps (True), RRR4_JIT=0 never
    compiles (False). Without a compiler it warns once and steps in the virtual machine."""
    global _NO_COMPILER_WARNED
    forced = os.environ.get("RRR4_JIT", "").strip()
    if forced == "0":
        return False
    if c_compiler() is None:
        if not _NO_COMPILER_WARNED:
            warnings.warn("no C compiler found (set CC or install gcc): simulate steps in CasADi's virtual "
                          "machine, several times slower", RuntimeWarning, stacklevel=3)
            _NO_COMPILER_WARNED = True
        return False
    return True if forced == "1" else BACKGROUND


def _stepping(stepping, t_grid) -> dict | None:
    """The run's stepping record with the time [s] its move to compiled C happened at, if it did."""
    if not stepping:
        return None
    k = stepping.get("compiled_from_frame")
    return {**stepping, "compiled_from_s": float(t_grid(np.array([k]))[0]) if k else None}


def _integrator(settings: IntegratorSettings, integrator, jit: bool) -> Integrator:
    """The integrator instance of a run: `integrator` itself, or the named method (default
    the scene's) configured by the scene's integrator `settings`."""
    if isinstance(integrator, Integrator):  # an instance (fixed-step or adaptive)
        return integrator
    name = settings.method if integrator is None else integrator
    if name not in METHODS:
        raise unknown_value("integrator.method" if integrator is None else "integrator", "integrator", name, METHODS)
    return METHODS[name].from_settings(settings, jit=jit)


def frame_times(t_end: float, n: int, k) -> np.ndarray:
    """``np.linspace(0, t_end, n + 1)[k]`` bit for bit, for the indices k, without the rest
    (a long run's frame ends are made a block at a time)."""
    k = np.asarray(k)
    return np.where(k == n, t_end, k * (t_end / n))


def _interpolated(t_s: np.ndarray, th, th_d, th_dd, ff):
    """t -> {th, thd, thdd, ff, ffd} at the times t: references tabulated at the times t_s,
    interpolated cubic Hermite in theta (with theta_d) and theta_d (with theta_dd), cubic
    splines in theta_dd and the feed-forward (ffd: its rate); error ~ h^4, far below 1e-9 at
    1 kHz. With two samples (a run of one frame, t_s its ends) the samples themselves."""
    if len(t_s) > 2:  # the table step's interpolation (rrr4.control.interpolants)
        p = interpolants(t_s, th, th_d, th_dd, ff)
        return lambda t: {"th": p["th"](t), "thd": p["thd"](t), "thdd": p["thdd"](t), "ff": p["ff"](t),
                          "ffd": p["ff"](t, 1)}
    hermite = CubicHermiteSpline(t_s, th, th_d, axis=0), CubicHermiteSpline(t_s, th_d, th_dd, axis=0)
    return lambda t: {"th": hermite[0](t), "thd": hermite[1](t), "thdd": th_dd[np.searchsorted(t_s, t)],
                      "ff": ff[np.searchsorted(t_s, t)], "ffd": np.zeros((len(t), ff.shape[1]))}


def _whole(periods: float) -> bool:
    return abs(round(periods) - periods) <= 1e-6 * max(1.0, periods)


def run_end(scene: Scene) -> tuple[float, str]:
    """(t_end [s], note) of a run of `scene` by default: the path duration, rounded up to whole
    control periods when a sampled controller runs it (torque mode with
    ``actuation.control_rate``) and the duration is not whole (e.g. an optimal time law
    taken as the path's time table): the run ends with the law, the path resting at its end
    pose for the fraction of the last period. note: one line saying so ('' when not rounded)."""
    duration, c = scene.path.duration, scene.actuation.control_rate
    if scene.actuation.mode != "torque" or not c or _whole(duration * c):
        return duration, ""
    n = math.ceil(duration * c)
    t_end = n / c
    return t_end, (f"the path ends at {duration:.9g} s, {duration * c:.6g} control periods at {c:g} Hz: the run "
                   f"takes {n} whole periods to {t_end:.9g} s (the last {1e3 * (t_end - duration):.3g} ms at rest at "
                   "the path's end)")


def _frames(ctrl: Problem, t_end: float, rate: float, held: bool) -> tuple[int, int]:
    """(number of frames, frames per output): frames are the output intervals, or the
    control periods of a sampled controller (then every m-th frame is an output)."""
    if not held:
        return max(int(round(t_end * rate)), 1), 1
    c = ctrl.scene.actuation.control_rate
    n = int(round(t_end * c))
    if n < 1 or not _whole(t_end * c):
        whole = max(math.ceil(t_end * c), 1)
        raise SceneError(f"t_end: {t_end:.9g} s is not allowed with actuation.control_rate {c:g} Hz (the run must be "
                         f"a whole number of control periods, e.g. {whole / c:.9g} s = {whole} periods; without "
                         "t_end a run ends with the path, rounded up to whole periods)")
    m = max(int(round(c / rate)), 1)
    while n % m:
        m -= 1
    return n, m


def simulate(scene: Scene | Problem, integrator=None, t_end: float | None = None, *, step: float | None = None,
             output_rate: float | None = None, controller: str | None = None, preload=None, model=None,
             v_min: float | None = None, baumgarte: float | None = None, jit=None, progress: bool = False,
             references: str | None = None, inputs: str | None = None, wear=None, start=None,
             **unknown) -> Simulation:
    """Simulate `scene` from the path's start pose; journals centred, or seated under
    their initial load when the scene says ``initial.journals: seated``.

    In torque mode the actuators get what the scene's controller (:mod:`rrr4.control`)
    commands: inverse-dynamics feed-forward, the preload of ``actuation.preload`` and the
    clearance compensation of ``actuation.compensation``, with PD feedback on the measured
    actuator coordinates; continuously, or sampled at ``actuation.control_rate`` with a
    zero-order hold.

    Parameters
    ----------
    scene : Scene, Problem or a scene file's path
    integrator : None (the scene's ``integrator.method``), a name from
        :data:`rrr4.integrators.METHODS`, or an integrator instance.
    t_end : [s], default the path duration, rounded up to whole control periods with a
        sampled controller (:func:`run_end`).
    step : [s], default the scene's; rounded so a whole number of steps fits one output
        interval or control period.
    output_rate : [Hz], default ``path.sample_rate``; with a sampled controller at most its rate.
    controller : 'python' (default: the controller step in CasADi) or 'generated' (the C that
        :func:`rrr4.codegen` writes, compiled and called through ``casadi.external``; a graph's
        table step too; needs a control rate).
    preload : an object with t (N,) [s] and tau (N, n), e.g. a PreloadSolution: the
        feed-forward efforts instead of the controller's own.
    model : a Scene (or Problem) of the same mechanism: the controller's model of the
        simulated one (default the scene itself; e.g. nominal parameters against a mechanism
        built with tolerances).
    v_min : [m/s], the approach-velocity floor of the contact laws; baumgarte : [rad/s].
    jit : True (compile the stepping, then step in C), False (CasADi's virtual machine),
        'background' (the library if cached, else the virtual machine while a process of its
        own compiles it, moving to it once ready); default :func:`default_jit`: 'background'
        where a C compiler exists, RRR4_JIT=1 or 0 forcing either way. ``stats['stepping']``
        records how the run stepped.
    progress : show a progress bar.
    references : 'exact' (default; an n-RRR controller runs its closed form inside every
        right-hand side, or at every control instant when sampled) or 'sampled' (its
        references, feed-forward included, evaluated once per path sample and interpolated,
        cubic Hermite: only the feedback law is compiled; what a graph scene with a task
        always does).
    inputs : which of the scene's numbers the compiled stepping takes as inputs rather than
        constants (:func:`rrr4.dynamics.builder.build_equations`; the controller's gains,
        limits and preload numbers always are): 'contact' (default) or 'geometry' (with
        references='sampled', scenes that differ in masses and geometry then share one
        compiled library).
    wear : the wear profiles to start from at the joints that wear (joint -> surface -> node
        depths [m], as :attr:`Simulation.wear` gives them; see :mod:`rrr4.contact.wear`):
        contact then uses the worn clearance, and the run's wear is what it adds.
    start : a Simulation of a scene of the same structure: the run starts where that one
        ended (its last output's motion and each journal's contact memory; each body's angle
        shifted by the whole turns that bring it nearest the scene's own start, so a driver
        that turned once starts again at its initial value), instead of the scene's initial
        state: the next cycle of a periodic motion.

    Any other keyword is refused in one line naming the nearest of :data:`OVERRIDES`.
    """
    if unknown:
        bad = sorted(unknown)[0]
        raise unknown_value(bad, "override", bad, OVERRIDES)
    problem = Problem.from_scene(scene)
    scene = problem.scene
    t_end = run_end(scene)[0] if t_end is None else argument("t_end", t_end)
    rate = scene.path.sample_rate if output_rate is None else argument("output_rate", output_rate)
    h_req = scene.integrator.step if step is None else argument("step", step)
    if t_end * rate > MAX_SAMPLES or t_end / h_req > MAX_STEPS:
        raise SceneError(f"t_end: {t_end:g} s is not allowed at output rate {rate:g} Hz and step {h_req:g} s "
                         f"(at most {MAX_SAMPLES:g} output frames and {MAX_STEPS:g} steps)")
    controller, mode = _checked_options(preload, controller, references)
    kw = {k: v for k, v in (("v_min", v_min), ("baumgarte", baumgarte), ("inputs", inputs)) if v is not None}
    eqs = problem.equations(**kw)
    if wear:  # worn profiles: other input numbers, the same compiled code
        eqs = with_profiles(eqs, wear)
    method = _integrator(scene.integrator, integrator,
                         default_jit() if jit is None else BACKGROUND if jit == BACKGROUND else bool(jit))
    ctrl = _controller_model(problem, model)
    loop = loop_of(ctrl, eqs, controller, mode, preload)
    held = loop.kind == "held"

    n_frames, every = _frames(ctrl, t_end, rate, held)
    dt = t_end / n_frames
    spf = max(int(round(dt / h_req)), 1)
    h = dt / spf
    if n_frames > MAX_SAMPLES or n_frames * spf > MAX_STEPS:
        raise SceneError(f"actuation.control_rate: {ctrl.scene.actuation.control_rate:g} Hz is not allowed over "
                         f"{t_end:g} s (at most {MAX_SAMPLES:g} control periods and {MAX_STEPS:g} steps)")
    t_grid = functools.partial(frame_times, t_end, n_frames)  # frame ends, by index
    t_out = t_grid(np.arange(0, n_frames + 1, every))
    refs, refs_at = run_references(problem, ctrl, eqs, loop, preload, t_end, n_frames, t_grid)
    u = _frame_inputs(problem, loop, refs_at, n_frames, t_grid)

    def tabulated_at(t):  # the tabulated controller's (theta, theta_d, tau_ff) at the times t
        return tuple(refs_at(t)[key] for key in ("th", "thd", "ff")) if refs_at is not None else None

    def efforts(t, q, qd):  # what the controller commands at the states (q, qd) at the times t
        return controller_efforts(ctrl, loop, problem.model, t, q, qd, tabulated_at(t))

    tree = in_tree(problem, eqs)
    system = system_of(problem, eqs, loop, refs, tree, inputs or "contact")
    x0 = system.started(initial_state(problem, eqs, efforts, tree, loop.settings, start), u[:1][0])
    outputs = Outputs(problem, eqs, system, tree, t_out, x0, efforts, _prescribed(problem, eqs, refs, refs_at))
    wall = time.perf_counter()
    run = method.run(system, x0, u, h, spf, progress=bool(progress), every=every, sink=outputs)
    outputs.flush()
    wall = time.perf_counter() - wall - u.seconds - outputs.seconds  # the stepping alone
    if outputs.bad is not None:
        raise SimulationError(f"integrator.step: {h:g} s lets the state blow up (non-finite by t = "
                              f"{t_out[outputs.bad]:.6g} s) with {method.name}; use a smaller step")
    failure = run.stats.get("failure")
    if failure is not None:  # the state stayed at the last accepted step: name the joint there
        raise SimulationError(_failure_message(failure, method.name, eqs, outputs))
    stats = {"method": method.name, "step": h, "steps": spf * n_frames, "frames": len(t_out) - 1, "wall_time": wall,
             "input_time": u.seconds, "output_time": outputs.seconds, "jit": method.jit, "v_min": eqs.v_min,
             "graph": {f.name(): graph_size(f) for f in (eqs.acceleration, system.ode)},
             **_loop_stats(ctrl, eqs, loop, controller, preload, tree)}
    stats.update(run.stats)
    stats["stepping"] = _stepping(run.stats.get("stepping"), t_grid)
    return outputs.simulation(stats)


# the keyword-only options of simulate, from its signature (one source)
OVERRIDES = tuple(k for k, v in inspect.signature(simulate).parameters.items() if v.kind is v.KEYWORD_ONLY)


def _checked_options(preload, controller, references) -> tuple[str, str]:
    """(controller, references) with their defaults, after a one-line check of each and of `preload`."""
    if preload is not None and not (hasattr(preload, "t") and hasattr(preload, "tau")):
        raise SceneError(f"preload: {describe(preload)} is not allowed (a PreloadSolution from rrr4.solve_preload, "
                         "or an object with t (N,) [s] and tau (N, n))")
    controller = controller or "python"
    if controller not in CONTROLLERS:
        raise unknown_value("controller", "value", controller, CONTROLLERS)
    mode = references or "exact"
    if mode not in REFERENCES:
        raise unknown_value("references", "value", mode, REFERENCES)
    return controller, mode


def _controller_model(problem: Problem, model) -> Problem:
    """The controller's model of the simulated mechanism (`model`, default the problem's own
    scene) on the one commanded path; one line when it is not a scene of the same actuators."""
    scene = problem.scene
    model_scene = model or scene
    if isinstance(model_scene, Problem):
        model_scene = model_scene.scene
    if not isinstance(model_scene, Scene) or (Problem.from_scene(model_scene).model.actuator_names !=
                                              problem.model.actuator_names):
        raise SceneError(f"model: {describe(model_scene)} is not allowed (a Scene of the same mechanism, with the "
                         "same actuators: the controller's model of the simulated one)")
    return problem if model_scene is scene else Problem.from_scene(replace(model_scene, path=scene.path))


def _loop_stats(ctrl: Problem, eqs, loop: Loop, controller: str, preload, tree: bool) -> dict:
    """What a run's statistics say of its controller and coordinates."""
    torque = eqs.mode == "torque"
    a = ctrl.scene.actuation
    return {"controller": (controller if loop.control is not None else "none"),
            "coordinates": "tree" if tree else "reference-point",
            "control_rate": a.control_rate if loop.kind == "held" else None, "references": loop.kind,
            "preload": ("given" if preload is not None else
                        a.preload.method if ctrl.has_preload and torque else "none"),
            "compensation": a.compensation if torque else "none",
            "seat_model": a.seat_model if torque and ctrl.compensates else "none"}


def _prescribed(problem: Problem, eqs, refs, refs_at):
    """t -> (theta_ref, theta_d_ref, theta_dd_ref) (m, n each) at the times t (m,) of the
    prescribed mode with a task: the closed-form references Function `refs`, or the
    tabulated ones `refs_at`; None in the other modes."""
    if eqs.mode != "prescribed" or problem.model.task is None:
        return None
    if refs is not None:
        return lambda t: tuple(np.array(v).T for v in refs.map(len(t))(t[None, :])[1:])
    return lambda t: tuple(refs_at(t)[key] for key in ("th", "thd", "thdd"))


def run_references(problem: Problem, ctrl: Problem, eqs, loop: Loop, given, t_end: float, n_frames: int, t_grid):
    """(refs, refs_at) of a run: the prescribed mode's closed-form references Function (or
    None), and t -> the tabulated references at the times t (or None): on the path's sample
    grid (or the frames, if coarser), interpolated to the frames."""
    if loop.kind == "sampled" or (loop.kind == "held" and not loop.pointwise):
        n_s = max(int(round(t_end * problem.path.sample_rate)), 2) + 1
        t_s = t_grid(np.arange(n_frames + 1)) if n_frames + 1 <= n_s else np.linspace(0.0, t_end, n_s)
        if eqs.mode == "torque":
            tab = tabulated(ctrl, t_s, given)
            th, th_d, th_dd, ff = tab.theta_ref, tab.theta_d_ref, tab.theta_dd_ref, tab.tau_ff
        else:
            th, th_d, th_dd = prescribed_references(problem, t_s)
            ff = np.zeros_like(th)
        return None, _interpolated(t_s, th, th_d, th_dd, ff)
    if eqs.mode == "prescribed":
        return reference_function(problem), None
    return None, None


def _frame_inputs(problem: Problem, loop: Loop, refs_at, n_frames: int, t_grid) -> FrameInputs:
    """The frame inputs of a run, made a block of frames at a time while the run steps them:
    [t_a, t_b] and the references of each frame (their layout: ``loop.inputs``)."""
    def rows(a: int, b: int) -> np.ndarray:  # the inputs of frames a..b-1
        t = t_grid(np.arange(a, b + 1))
        step = step_inputs(loop.control, problem.path, t[:-1]) if loop.inputs.step else None
        return loop.inputs.rows(t, refs_at(t) if refs_at is not None else None, step)

    return FrameInputs(n_frames, loop.inputs.width, rows)


def _failure_message(failure: dict, method: str, eqs, outputs: Outputs) -> str:
    """One line for an error-controlled run that could not go on: the time, the last step and
    the clearance joint pressed deepest there (where such failures start: stiff contact)."""
    where, joints = "", eqs.clearance_joints
    if len(joints):
        penetration = outputs.arrays["penetration"][-1]
        j = int(np.argmax(penetration))
        where = (f" at joint {joints[j]} (penetration {penetration[j]:.3g} m)" if penetration[j] > 0 else
                 " with no journal in contact")
    return (f"integrator.tolerance: {method} cannot go on at t = {failure['t']:.9g} s{where}: even its smallest "
            f"step, {failure['step']:.3g} s, did not converge or stay finite (try a smaller integrator.step or a "
            "larger integrator.max_newton)")


def controller_efforts(ctrl: Problem, loop: Loop, model, t: np.ndarray, q: np.ndarray, qd: np.ndarray,
                       refs: tuple | None = None) -> np.ndarray:
    """(N, n) efforts the controller commands at the states (q, qd) (N, nq) at times t (N,):
    what it held over the control period starting there, or what it applied there. refs:
    a tabulated controller's (theta_ref, theta_d_ref, tau_ff) (N, n each) at t, as the loop
    used them (None for a closed-form controller)."""
    N = len(t)
    qs, qds = ca.SX.sym("q", q.shape[1]), ca.SX.sym("qd", q.shape[1])
    meas = ca.Function("measured", [qs, qds], list(measured(model, qs, qds)))
    th, th_d = (np.array(v) for v in meas.map(N)(q.T, qd.T))
    if loop.pointwise:
        ins = step_inputs(loop.control, ctrl.path, t)
    else:
        ins = [v.T for v in refs]
    settings = np.broadcast_to(np.asarray(loop.settings, float)[:, None], (len(loop.settings), N))
    out = mapped(loop.control, **dict(zip(loop.control.name_in(), [*ins, th, th_d, settings], strict=True)))
    return out[loop.control.name_out(0)].T
