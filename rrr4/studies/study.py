"""The reference study of a scene: does a preload keep every clearance joint in contact,
and what does it buy in accuracy?

Pipeline (DESIGN sections 1.4 and 7): scene -> inverse dynamics of the ideal mechanism
along the path -> the preload with the scene's ``actuation.preload.method`` (its
feasibility report) -> the clearance simulation (:func:`rrr4.simulate`) of the scene's
controller (:mod:`rrr4.control`) in up to three arms:

- ``with_preload``: the controller with its preload, no compensation;
- ``with_preload_compensated``: the same with ``actuation.compensation: clearance``
  (references closed around the predicted journal seats, friction moments fed forward);
- ``without_preload``: the same controller without preload (``method: none``: the
  minimum-norm torques tau_p, alpha = 0).

The preloaded arms exist only when the controller preloads (actuation redundancy,
``actuation.preload.min_force`` > 0 and a method other than none): a fully actuated 3-RRR
has no null space, and f_min = 0 makes the minimum-norm torques optimal. The compensated
arm needs clearance joints. Where the scene's controller is sampled (``actuation.control_rate``),
the preloaded arms run its generated C in the loop (when a C compiler exists): the closed-form
step of an n-RRR, or the table step of a graph (:func:`rrr4.control.controller_step`); the
other arm runs the controller in CasADi.

A scene without a task body (a driven mechanism such as Flores's slider-crank) has no
preload question; its study compares the mechanism with its clearance joints against its
ideal twin (every joint ideal), driven alike:

- ``with_clearance``: the scene as given;
- ``ideal``: the same scene with every joint ideal, the reference;
- ``refinement``: ``with_clearance`` again at half the step, to show which results have
  converged in the step (kept in ``Study.refinement``, not drawn as an arm).

The result (:class:`rrr4.results.study.Study`, its arms and the arm names) belongs to the
results layer, which writes, draws and tabulates it.

The simulations write every integrator step (output rate = 1/step), so the contact state
of every step is in the result and loss events can be located in time; with a sampled
controller they write every control period (the frames the controller holds its efforts
over), so losses are located to a period and counted by the integrator itself.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import replace

import numpy as np

from ..checks import argument, unknown_value
from ..codegen import start_generated_controller
from ..codegen.build import compile_time
from ..errors import Rrr4Error, SceneError
from ..files import c_compiler
from ..integrators import METHODS
from ..preload import solve_preload
from ..preload.solve import PreloadWarning
from ..problem import Problem
from ..results.metrics import check_skip
from ..results.study import Study, StudyArm
from ..results.summary import preload_lines
from ..scene import MAX_SAMPLES, Scene
from ..simulation import run_end, simulate
from ..simulation.foresight import foresight_lines
from ..trajectory import sample_path

__all__ = ["run_study", "arm_scene", "study_controller", "MAX_HALVINGS"]

MAX_HALVINGS = 6  # run_study(converge=...): at most 1/64 of the first step


def arm_scene(problem: Problem, arm: str) -> Scene:
    """The scene an arm of the study of `problem` simulates (see the module docstring)."""
    scene = problem.scene
    a = scene.actuation
    if arm == "with_preload":
        return replace(scene, actuation=replace(a, compensation="none"))
    if arm == "with_preload_compensated":
        return replace(scene, actuation=replace(a, compensation="clearance"))
    if arm == "without_preload":
        return replace(scene, actuation=replace(a, compensation="none", preload=replace(a.preload, method="none")))
    if arm == "ideal":
        return scene.with_ideal_joints()
    return scene


def study_controller(problem: Problem) -> str:
    """'generated' where the problem's controller is sampled (a torque-mode scene with
    ``actuation.control_rate``) and a C compiler exists, else 'python'. The generated step is
    the closed form of an n-RRR, or the table step of any other scene
    (:func:`rrr4.control.controller_step`)."""
    scene = problem.scene
    ok = scene.actuation.control_rate is not None and c_compiler() is not None
    return "generated" if ok and scene.actuation.mode == "torque" else "python"


def _min_norm_torques(problem: Problem, t_path: np.ndarray) -> np.ndarray:
    """tau_p (N, n) [N m] of the ideal inverse dynamics at the path samples (zeros without a task)."""
    s = sample_path(problem.path)
    if problem.model.task is None:
        return np.zeros((len(t_path), problem.model.n_actuators))
    return problem.effort_family(s.pose, s.pose_d, s.pose_dd).tau_p


def run_study(scene: Scene | Problem, *, t_end: float | None = None, step: float | None = None,
              integrator: str | None = None, output_rate: float | None = None, skip: float = 0.0,
              converge: float | None = None, progress: bool = False, log=None) -> Study:
    """Run the study of `scene`.

    t_end [s]: simulated time (default the path duration, rounded up to whole control
    periods with a sampled controller: :func:`rrr4.simulation.run_end`, said in the log);
    step [s]: integrator step (default the scene's); integrator: method name (default the
    scene's); output_rate [Hz]: outputs kept per second (default every step, so that losses
    are located to a step; at most 1/step); skip [s]: the start-up window the metrics discard
    (0 <= skip < t_end, see :mod:`rrr4.results.metrics`); converge [s]: a wall-time budget per
    arm within which an arm whose verdict fails (:mod:`rrr4.simulation.verdict`) is rerun at
    half its step until it passes (:func:`_converged`; None: every arm runs once at `step`);
    progress: show the simulations' progress bars; log: callable taking one line of text per
    stage, and one per warning of :func:`rrr4.simulation.foresight.foresight_lines` (a contact
    law outside its range, a step that cannot resolve the stiffest contact vibration) before
    any arm runs. What is given is recorded in ``Study.overrides``; the warnings in
    ``Study.foresight``.
    """
    say = log or (lambda _msg: None)
    problem = Problem.from_scene(scene)
    scene = problem.scene
    given = {"t_end_s": t_end, "integrator": integrator, "step_s": step, "output_rate_Hz": output_rate,
             "skip_s": skip or None, "converge_budget_s": converge}
    if t_end is None:
        t_end, note = run_end(scene)
        if note:
            say(note)
    else:
        t_end = argument("t_end", t_end)
    h = scene.integrator.step if step is None else argument("step", step)
    if integrator is not None and integrator not in METHODS:
        raise unknown_value("integrator", "integrator", integrator, METHODS)
    if output_rate is not None and argument("output_rate", output_rate) > 1.0 / h * (1 + 1e-9):
        raise SceneError(f"output_rate: {output_rate:g} Hz is not allowed at step {h:g} s (at most one output per "
                         f"step: <= {1.0 / h:g} Hz)")
    skip = check_skip(skip, t_end)
    if converge is not None:
        argument("converge", converge)
    rate = 1.0 / h if output_rate is None else float(output_rate)
    if t_end * rate > MAX_SAMPLES:  # refuse before the preload is computed
        raise SceneError(f"t_end: {t_end:g} s is not allowed at step {h:g} s (the study keeps every step: at most "
                         f"{MAX_SAMPLES:g} steps)" if output_rate is None else
                         f"t_end: {t_end:g} s is not allowed at output rate {rate:g} Hz (at most {MAX_SAMPLES:g} "
                         "outputs)")
    if problem.model.task is not None:  # before all else: the preloaded arms' controllers compile while
        _start_controllers(problem)  # the preload is solved and the arm without them steps
    t_path = sample_path(scene.path).t
    if problem.model.task is not None:
        say(f"inverse dynamics of the ideal mechanism at {len(t_path)} path samples")
    tau_min_norm = _min_norm_torques(problem, t_path)

    preload, preload_warning = None, ""
    if problem.has_preload:
        pre = scene.actuation.preload
        say(f"preload: method {pre.method}, f_min = {pre.min_force:g} N")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", PreloadWarning)
            preload = solve_preload(problem, pre.method, branch="auto")  # exact: the controller's one branch
        preload_warning = "\n".join(str(w.message) for w in caught if issubclass(w.category, PreloadWarning))
        if not preload.all_feasible:  # loud: where, which actuator, by how much, and what the simulation does
            for line in preload_lines(preload, problem):
                say(line)
    foresight = tuple(foresight_lines(problem, h, integrator, preload))  # before any arm runs
    for line in foresight:
        say(line)

    def run_arm(name, sc, step, controller):
        say(f"simulate {name.replace('_', ' ')}: {t_end:g} s, step {step:g} s"
            + (", generated controller in the loop" if controller == "generated" else ""))
        wall, compiling = time.perf_counter(), compile_time()
        sim = simulate(sc, integrator, t_end=t_end, step=step, output_rate=1.0 / step if output_rate is None
                       else rate, progress=progress, controller=controller)
        compiling = compile_time() - compiling
        return StudyArm(name, sim, time.perf_counter() - wall - compiling, compiling)

    def arm(name, sc, step=h, controller="python"):
        first = run_arm(name, sc, step, controller)
        return first if converge is None else _converged(first, lambda k: run_arm(name, sc, k, controller), converge,
                                                         t_end, output_rate, say)

    arms, refinement = {}, None
    if problem.model.task is None:
        arms["with_clearance"] = arm("with_clearance", scene)
        arms["ideal"] = arm("ideal", scene.with_ideal_joints())
        if scene.clearance_joints:
            fine = arms["with_clearance"].simulation.stats["step"] / 2
            refinement = run_arm("with_clearance (half step)", scene, fine, "python")
    else:
        names = _preloaded_arms(problem)
        last = arm("without_preload", arm_scene(problem, "without_preload"))
        for name in names:
            arms[name] = arm(name, arm_scene(problem, name), controller=study_controller(Problem.from_scene(
                arm_scene(problem, name))))
        arms["without_preload"] = last
    return Study(scene=scene, t_path=t_path, tau_min_norm=tau_min_norm, preload=preload,
                 preload_warning=preload_warning, arms=arms, t_end=t_end, step=h, refinement=refinement, skip=skip,
                 overrides={k: v for k, v in given.items() if v is not None}, foresight=foresight)


def _preloaded_arms(problem: Problem) -> tuple[str, ...]:
    """The preloaded arms of the study of a problem with a task (see the module docstring)."""
    if not problem.has_preload:
        return ()
    return ("with_preload", "with_preload_compensated") if problem.scene.clearance_joints else ("with_preload",)


def _start_controllers(problem: Problem) -> None:
    """Start compiling the generated controllers of the preloaded arms in the background (see
    :func:`rrr4.codegen.start_generated_controller`), where they run one."""
    for name in _preloaded_arms(problem):
        arm_problem = Problem.from_scene(arm_scene(problem, name))
        if study_controller(arm_problem) == "generated":
            start_generated_controller(arm_problem)


def _converged(first: StudyArm, rerun, budget: float, t_end: float, output_rate, say) -> StudyArm:
    """`first`, or the arm rerun (`rerun(step)`) at half its step, again and again, until its
    verdict passes: at most :data:`MAX_HALVINGS` times, while the next run (predicted to cost
    twice the last) fits in `budget` [s] of wall time and the outputs of every step in
    MAX_SAMPLES. A rerun that fails (e.g. blows up) is recorded and the step halved again. The
    arm returned (the last that ran) carries the history (``StudyArm.convergence``): the steps
    tried, their residuals (None where the run failed), what they cost together (wall and
    compile time [s]) and whether the arm returned passed."""
    arm, step, cost = first, first.simulation.stats["step"], first.wall_time
    steps, residuals, spent, compiling = [step], [first.simulation.verdict.residual], first.wall_time, \
        first.compile_time
    while not arm.simulation.verdict.converged and len(steps) <= MAX_HALVINGS:
        text = arm.simulation.verdict.text() if residuals[-1] is not None else "failed"
        step /= 2
        cost *= 2
        if spent + cost > budget or (output_rate is None and t_end / step > MAX_SAMPLES):
            break
        say(f"{first.name.replace('_', ' ')}: {text} at step {step * 2:g} s; again at {step:g} s")
        wall = time.perf_counter()
        steps.append(step)
        try:
            arm = rerun(step)
        except Rrr4Error as e:
            say(f"{first.name.replace('_', ' ')} at step {step:g} s: {str(e).splitlines()[0]}")
            residuals.append(None)
            spent += time.perf_counter() - wall
            continue
        residuals.append(arm.simulation.verdict.residual)
        spent, compiling, cost = spent + arm.wall_time, compiling + arm.compile_time, arm.wall_time
    history = {"steps_s": steps, "energy_audit_residuals": residuals, "wall_time_s": spent,
               "compile_time_s": compiling, "budget_s": budget, "converged": arm.simulation.verdict.converged}
    return replace(arm, convergence=history)
