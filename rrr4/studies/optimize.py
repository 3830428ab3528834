"""``rrr4 optimize``: the design card's loop. Solve the optimal time law along the scene's
path (:func:`rrr4.optimal.optimal_time_law`: with the contact condition where the scene
preloads, and with the actuator limits only, so the cost of keeping contact is a ratio of
two durations), then replay it: the scene, following the optimal law
(:meth:`rrr4.scene.Scene.with_time_table`), goes through the study (:func:`run_study`) with
its own controller (sampled, the generated C where the study would use it) and its clearance
dynamics, in the study's arms (``with_preload``: the controller's pointwise preload, whose
QP meets the same contact rule the optimum kept; ``without_preload``: the same time law with
the minimum-norm efforts; ``with_preload_compensated`` where the scene has clearance joints).

If the preloaded replay loses contact although the ideal model kept f_min everywhere (the
controller's dynamics, the clearance), the law is solved again with f_min raised by the
factors of :data:`HEADROOM_FACTORS` and replayed (preloaded arm only) until no contact is
lost; the smallest such f_min is reported (or that none of them was enough).

With a target (``--to``) the loop is the point-to-point one on any mechanism with a task body
or point (:func:`rrr4.optimal.optimal_motion`): the optimal motion with the contact condition
where the scene preloads and with the actuator limits only, replayed along a spline through its
nodes, retimed by the optimal time law along it (:func:`retimed_scene`). A replay of a sampled
controller ends with the run's whole control periods (:func:`rrr4.simulation.run_end`).
"""

from __future__ import annotations

import time
from dataclasses import replace

from ..checks import unknown_value
from ..errors import InfeasibleError, SceneError, SolverError
from ..optimal import optimal_motion, optimal_time_law
from ..optimal.limits import limit_curves
from ..optimal.point_to_point import checked_pose
from ..problem import Problem
from ..results.metrics import scalar_metrics
from ..results.optimal import Optimization
from ..scene.vocabulary import OBJECTIVES
from ..simulation import run_end, simulate
from .study import arm_scene, run_study, study_controller

__all__ = ["optimize", "motion_scene", "retimed_scene", "check_arguments", "at_duration", "HEADROOM_FACTORS",
           "DEFAULT_POINTS", "DEFAULT_NODES"]

HEADROOM_FACTORS = (1.25, 1.5, 2.0, 3.0, 5.0, 10.0)
DEFAULT_POINTS, DEFAULT_NODES = 1000, 40  # grid intervals of a time law, intervals of a point-to-point motion


def optimize(scene, objective: str = "time", *, points: int | None = None, duration: float | None = None,
             effort_weight: float | None = None, target=None, nodes: int | None = None, replay: bool = True,
             progress: bool = False, log=None) -> Optimization:
    """The optimal time law of `scene`'s path and its replay (see the module docstring).

    scene: a Scene, a Problem or a scene file's path; objective: 'time', 'effort' (at
    `duration` [s]) or 'time+effort' (effort_weight, default 1); points: grid intervals
    (default 1000); target: a task pose [m, m, rad] to reach rest to rest from the path's start
    with the path free (:func:`rrr4.optimal.optimal_motion`, `nodes` intervals, default 40)
    instead of following the path; replay: run the study on the law; log: callable taking one
    line per stage. An argument that would do nothing in the mode chosen (a duration with the
    time objective, nodes without a target, points with one, an effort weight without
    'time+effort') is refused in one line (:func:`check_arguments`)."""
    say = log or (lambda _msg: None)
    points, nodes, effort_weight = check_arguments(objective, points, duration, effort_weight, target, nodes)
    problem = Problem.from_scene(scene)
    contact = problem.has_preload
    t0 = time.perf_counter()
    if target is not None:
        return _point_to_point(problem, objective, target, nodes, duration, effort_weight, contact, replay, progress,
                               log, say, t0)
    what = "with the contact condition" if contact else "with the actuator limits"
    say(f"optimal time law ({objective}) {what}, {points} grid intervals")
    law = at_duration(lambda: optimal_time_law(problem, objective, points=points, contact=contact,
                                               duration=duration, effort_weight=effort_weight),
                      lambda: optimal_time_law(problem, points=points, contact=contact).duration, duration)
    free = None
    if contact:
        say("the same with the actuator limits only")
        free = optimal_time_law(problem, objective, points=points, contact=False, duration=duration,
                                effort_weight=effort_weight)
    say("limit curves of the phase plane")
    curves = limit_curves(problem, min(points, 200), sign=law.sign or 1)
    stats = {"optimization_wall_time_s": time.perf_counter() - t0}
    study = headroom = None
    if replay:
        follow = problem.scene.with_time_table(law.table)
        say(f"replay: the study of the scene following the optimal law ({law.duration:.4g} s)")
        study = run_study(follow, progress=progress, log=log)
        arm = study.arms.get("with_preload")
        if contact and arm is not None and sum(arm.simulation.contact_loss_events.values()) > 0:
            headroom = _headroom(problem, law, sum(arm.simulation.contact_loss_events.values()), objective, points,
                                 duration, effort_weight, say)
    return Optimization(problem, law, free, curves, study, headroom, stats)


def check_arguments(objective, points, duration, effort_weight, target, nodes) -> tuple[int, int, float]:
    """(points, nodes, effort_weight) with their defaults, or SceneError in one line naming the
    argument (and its option) that would be ignored in this mode (their ranges are checked where
    they are used)."""
    if objective not in OBJECTIVES:
        raise unknown_value("objective (--objective)", "objective", objective, OBJECTIVES)
    ignored = [(duration is not None and objective == "time", "duration (--duration)",
                "the time objective minimises the duration; give --objective effort or time+effort"),
               (nodes is not None and target is None, "nodes (--nodes)",
                "the intervals of a point-to-point motion; the path's time law has --points"),
               (points is not None and target is not None, "points (--points)",
                "the grid of a time law along the path; a point-to-point motion has --nodes"),
               (effort_weight is not None and objective != "time+effort", "effort_weight",
                "the weight of the effort in objective 'time+effort'")]
    for bad, key, why in ignored:
        if bad:
            raise SceneError(f"{key}: not used with objective {objective!r}{'' if target is None else ' and a target'}"
                             f" ({why})")
    return (DEFAULT_POINTS if points is None else points, DEFAULT_NODES if nodes is None else nodes,
            1.0 if effort_weight is None else effort_weight)


def at_duration(solve, fastest, duration):
    """solve() at a given `duration` [s] (None: the time objective, solve() as it is), whose
    failure is named for what it is: a duration shorter than the fastest law's (fastest() [s],
    the same problem with the time objective) has no law (SceneError naming the duration, before
    solving); at a longer one (a slower motion, which the limits allow where the path holds at
    rest), a solver that stops is a SolverError, not an infeasible problem."""
    if duration is None:
        return solve()
    t_min = fastest()
    if duration < t_min * (1 - 1e-6):
        raise SceneError(f"duration (--duration): {duration:g} s is not allowed (shorter than the fastest motion, "
                         f"{t_min:.6g} s with the time objective: no motion of that duration keeps the limits)")
    try:
        return solve()
    except (InfeasibleError, SolverError) as e:
        if "the solver stopped with" not in str(e):  # a refusal with its reason (a margin, a limit at rest) stands
            raise
        raise SolverError(f"{e}; {duration:g} s is no faster than the fastest motion ({t_min:.6g} s), so the solver "
                          "most likely failed rather than the problem being infeasible: try a duration nearer the "
                          "fastest, or fewer grid intervals") from None


def _point_to_point(problem, objective, target, nodes, duration, effort_weight, contact, replay, progress, log, say,
                    t0):
    """Part 2 of the loop: the optimal motion to `target`, with and without the contact
    condition, replayed along a clamped spline through its nodes retimed by its optimal time law
    (:func:`retimed_scene`)."""
    what = "with the contact condition" if contact else "with the actuator limits"
    point = problem.model.task_dof == 2
    target = checked_pose("target (--to)", target, point)[:2 if point else 3]
    say(f"optimal motion ({objective}) to {target.tolist()} {what}, {nodes} intervals")
    motion = at_duration(lambda: optimal_motion(problem, target, objective, duration=duration, nodes=nodes,
                                                contact=contact, effort_weight=effort_weight),
                         lambda: optimal_motion(problem, target, nodes=nodes, contact=contact).duration, duration)
    free = None
    if contact:
        say("the same with the actuator limits only")
        free = optimal_motion(problem, target, objective, duration=duration, nodes=nodes, contact=False,
                              effort_weight=effort_weight)
    stats = {"optimization_wall_time_s": time.perf_counter() - t0}
    study = None
    if replay:
        follow, stats["replay_time_law"] = retimed_scene(problem, motion, contact, effort_weight)
        say(f"replay: the study of the scene following the optimal motion's path, "
            f"{stats['replay_time_law']['what']} ({follow.path.duration:.4g} s)")
        study = run_study(follow, progress=progress, log=log)
    return Optimization(problem, motion, free, None, study, None, stats)


def retimed_scene(problem, motion, contact: bool, effort_weight: float = 1.0, points: int = DEFAULT_POINTS):
    """(scene, note): the scene following the motion's path (:func:`motion_scene`) with the
    optimal time law along it, same objective and constraints (at the motion's duration for
    'effort'), so the replayed reference keeps the limits and the contact condition at every
    sample of the path (the spline's accelerations between the nodes are not the motion's
    constant ones: followed at the motion's own timing its efforts would exceed the limits
    somewhere); where that law fails, the motion's own timing. note: what was replayed, with its
    duration against the motion's."""
    follow = motion_scene(problem.scene, motion)
    duration = motion.duration if motion.objective == "effort" else None
    try:
        law = optimal_time_law(follow, motion.objective, points=points, contact=contact, duration=duration,
                               effort_weight=effort_weight)
    except (InfeasibleError, SolverError) as e:
        return follow, {"what": "at the motion's own timing", "duration_s": motion.duration, "retime_failed": str(e)}
    return follow.with_time_table(law.table), {
        "what": f"retimed by its optimal time law ({motion.objective})", "duration_s": law.duration,
        "duration_ratio_to_motion": law.duration / motion.duration}


def motion_scene(scene, motion):
    """`scene` with its path replaced by the motion: a clamped cubic spline through the nodes'
    poses (uniform knots, so the linear time law puts node k at its time t_k), at rest at both
    ends. Between nodes the spline is smoother than the motion's constant accelerations; it
    converges to the motion with the nodes."""
    path = replace(scene.path, type="waypoints", points=tuple(tuple(float(v) for v in p) for p in motion.pose),
                   duration=float(motion.duration), time_law="linear", time_table=())
    return replace(scene, path=path)


def _headroom(problem, law, losses, objective, points, duration, effort_weight, say) -> dict:
    """Raise f_min until the preloaded replay loses no contact (see the module docstring)."""
    tried = [{"f_min_N": law.f_min, "duration_s": law.duration, "contact_loss_events": int(losses)}]
    found = None
    for factor in HEADROOM_FACTORS:
        f_min = law.f_min * factor
        say(f"replay lost contact {losses} times: trying f_min = {f_min:g} N")
        sc = problem.scene
        sc = replace(sc, actuation=replace(sc.actuation, preload=replace(sc.actuation.preload, min_force=f_min)))
        try:
            raised = optimal_time_law(sc, objective, points=points, duration=duration, effort_weight=effort_weight)
        except InfeasibleError as e:  # an f_min no preload reaches ends the search, and is reported
            tried.append({"f_min_N": f_min, "infeasible": str(e)})
            break
        follow = Problem.from_scene(arm_scene(Problem.from_scene(sc.with_time_table(raised.table)), "with_preload"))
        sim = simulate(follow, t_end=run_end(follow.scene)[0],
                       output_rate=1.0 / follow.scene.integrator.step, controller=study_controller(follow))
        losses = scalar_metrics(sim)["contact_loss_events"]
        tried.append({"f_min_N": f_min, "duration_s": raised.duration, "contact_loss_events": int(losses)})
        if losses == 0:
            found = f_min
            break
    return {"tried": tried, "smallest_f_min_without_losses_N": found}
