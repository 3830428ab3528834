"""Point-to-point motions: the fastest, the least-effort or the best time+effort rest-to-rest
motion of the task (a body's pose or a point's position) between two poses with the path free
(DESIGN.md §10, "between two poses").

Transcription: direct multiple shooting on N intervals of equal length h = T / N. The
states are the task coordinates and their rates (pose, pose_d: k = 3 for a task body, 2 for a
task point); the controls are the task acceleration pose_dd, constant on each interval (so
each interval is integrated exactly: pose_{k+1} = pose_k + h pose_d,k + h^2/2 pose_dd,k,
pose_d,{k+1} = pose_d,k + h pose_dd,k). The efforts follow from the ideal inverse dynamics,
the same effort family the time law uses (:meth:`rrr4.problem.Problem.effort_family`: gravity
and every known force element balanced):

- where the n-RRR's closed form is the whole family (``Problem.closed_form_family``):
  tau = tau_p(pose, pose_d, pose_dd) + tau_n(pose) alpha and the passive-joint reactions
  likewise, from the closed-form SX inverse dynamics, alpha unknown at every node. Where J is
  regular this is the same problem as efforts as controls: (pose_dd, alpha) <-> tau is one-to-one.
- any other graph with a task (:mod:`rrr4.optimal.graph_motion`): body coordinates, rates,
  accelerations, joint multipliers and efforts as unknowns at every node, tied by the graph's
  constraints and equations of motion (efforts as controls), the null space and the velocity
  analysis as unknowns where the contact condition and the singularity margin need them.

At every node, with the acceleration of the interval before it and of the one after it:

- each actuator's limit |tau_i| <= L_i;
- the preload layer's contact condition at every passive revolute joint (with actuation
  redundancy and f_min > 0): sigma d_j . r_j >= f_min, d_j the direction of the joint's
  null-space reaction, sigma the one sign for all joints; both signs are solved and the better kept;
- the distance from singularity: sqrt(tr(G) tr(G^-1)) <= ``path.max_condition_number`` with
  G = J^T J, an upper bound of the 2-norm condition number of J (at most sqrt(k) times it),
  smooth where the condition number's singular values are not (parallel singularities); for an
  n-RRR also each chain's transmission sigma_i sin(link angle) >= ``path.min_transmission``
  (sigma_i its sign at the start: no working-mode flip) and the IK defined (the workspace).

The margins hold at the nodes and at INNER_POINTS instants between each two. The returned motion
(constant accelerations between the nodes, the null-space efforts linear in time between them)
is then checked along its whole length with the mechanism's own kinematics and the effort
family (:mod:`rrr4.optimal.motion_check`): where a margin fails between two nodes (a thin
singular set, e.g. a pure turn through a parallel singularity) it is solved again with
MAX_INNER_POINTS between each two nodes; where an effort limit or the contact condition fails
between nodes by at most BACKOFF_MAX, it is solved again from that motion with the limits
lowered and f_min raised by what was missed (at most BACKOFF_ROUNDS times); what still fails,
or fails by more, is refused (InfeasibleError naming the instant and the value). The summary
reports the extremes along the motion beside those at the nodes.

Objectives: 'time' (T free); 'effort' at a given duration: the integral of tau^T W tau dt (W the
preload weights), each interval the mean of its two ends; 'time+effort': T plus effort_weight
times that integral. IPOPT on CasADi's Opti, warm-started from the straight line between the
poses with its optimal time law (:func:`rrr4.optimal.optimal_time_law` on a 'line' path).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from ..checks import argument, describe, unknown_value
from ..errors import InfeasibleError, KinematicsError, SceneError, SolverError
from ..mechanism.workspace import condition_number
from ..preload.qp import qp_preload_function
from ..problem import Problem
from ..scene.vocabulary import OBJECTIVES
from ..trajectory import path_geometry_function
from .graph_motion import GraphMotion
from .motion_check import MIN_SAMPLES_PER_INTERVAL, along_motion, margin_report, plan_report
from .time_law import binding_counts, binding_labels, contact_directions, optimal_time_law, optimum_summary

__all__ = ["checked_pose", "OptimalMotion", "optimal_motion", "MOTION_OBJECTIVES", "MIN_SAMPLES_PER_INTERVAL"]

MOTION_OBJECTIVES = OBJECTIVES
MAX_NODES = 2000
# the margins are held at INNER_POINTS instants between each two nodes (MAX_INNER_POINTS where the
# check along the motion fails); the limits and the contact condition tightened at most BACKOFF_ROUNDS times
# (each round by what was missed and BACKOFF_EXTRA more, relative; only a miss of at most BACKOFF_MAX)
INNER_POINTS, MAX_INNER_POINTS, BACKOFF_ROUNDS, BACKOFF_EXTRA, BACKOFF_MAX = 1, 16, 4, 1e-4, 0.1
IPOPT_OPTIONS = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-9,
                 "ipopt.constr_viol_tol": 1e-9, "ipopt.max_iter": 1000, "ipopt.mu_strategy": "adaptive"}
# per objective: for 'time' a limited-memory Hessian (the exact one through the mapped closed-form
# dynamics made the reference solve about 1.5x slower: fewer iterations, each far dearer); for
# the effort objectives the exact one (the quadratic objective needs it: 18 iterations against 100+)
HESSIAN = {"time": "limited-memory", "effort": "exact", "time+effort": "exact"}


@dataclass(frozen=True)
class OptimalMotion:
    """An optimal rest-to-rest motion of the task on N + 1 nodes.

    t (N+1,) [s]; pose, pose_d, pose_dd (N+1, 3) [m, m, rad and rates] (pose_dd: the
    acceleration of the interval that starts at the node, the last node repeats the last
    interval's; a task point's angle column is the start's and its rates are zero); efforts
    (N+1, n) [N m or N] at those accelerations, efforts_before at the accelerations of the
    interval before each node (the first node: the first interval's); alpha (N+1, m)
    null-space efforts; reactions (N+1, nj, 2) [N] of the passive revolute joints; axial
    (N+1, nj) [N]: sigma d_j . r_j, the contact condition's left side, the smaller of the node's
    two sides (empty without the contact condition); condition (N+1,): the 2-norm condition
    number of J; transmission (N+1, n): |sin| of each chain's link angle (n-RRR closed form;
    None otherwise); binding (N+1,): the constraints whose relative slack is below BINDING_TOL,
    tightest first ('' where none binds); duration [s]; statistics: solver, status, iterations,
    build, solve and warm-start times, the objective with each sign, the warm start's duration,
    'along': the check along the whole motion (:mod:`rrr4.optimal.motion_check`)."""
    objective: str
    t: np.ndarray
    pose: np.ndarray
    pose_d: np.ndarray
    pose_dd: np.ndarray
    efforts: np.ndarray
    alpha: np.ndarray
    reactions: np.ndarray
    axial: np.ndarray
    condition: np.ndarray
    transmission: np.ndarray | None
    binding: tuple[str, ...]
    duration: float
    start: tuple[float, float, float]
    target: tuple[float, float, float]
    contact: bool
    sign: int
    f_min: float
    torque_limit: tuple[float, ...]
    actuator_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    statistics: dict = field(default_factory=dict)
    efforts_before: np.ndarray | None = None

    def binding_counts(self) -> dict[str, int]:
        """How many nodes each constraint binds at."""
        return binding_counts(self.binding)

    def summary(self) -> dict:
        """The motion's numbers as plain JSON types."""
        return {**optimum_summary(self), "nodes": len(self.t), "start": list(self.start), "target": list(self.target),
                **_extremes(self)}


def _extremes(motion: OptimalMotion) -> dict:
    """The margins' extremes along the whole motion (statistics['along'], sampled between the
    nodes) beside those at the nodes."""
    along = motion.statistics.get("along", {})
    nodes_tr = None if motion.transmission is None else float(motion.transmission.min())
    return {"max_condition_number": along.get("max_condition_number", float(motion.condition.max())),
            "min_transmission": along.get("min_transmission", nodes_tr),
            "max_condition_number_at_nodes": float(motion.condition.max()), "min_transmission_at_nodes": nodes_tr,
            "peak_effort_ratio_along": along.get("peak_effort_ratio"),
            "min_contact_margin_along_N": along.get("min_contact_margin_N"),
            "margins_checked_at": along.get("samples")}


def checked_pose(key: str, v, point: bool = False) -> np.ndarray:
    """`v` as a task pose [x, y, theta] (3 finite numbers; for a task point also [x, y], its
    angle then 0 and in any case not used), or a one-line SceneError naming `key`."""
    try:
        x = np.asarray(v, float).ravel()
    except (TypeError, ValueError):
        x = None
    sizes = (2, 3) if point else (3,)
    if x is None or x.size not in sizes or not np.all(np.isfinite(x)):
        what = ("a task point [x, y] (or [x, y, theta], theta not used) of finite numbers [m]" if point
                else "a task pose [x, y, theta] of 3 finite numbers [m, m, rad]")
        raise SceneError(f"{key}: {describe(v)} is not allowed ({what})")
    return np.r_[x, 0.0] if x.size == 2 else x


def _where(key: str, pose) -> str:
    return f"{key} pose {np.round(pose, 6).tolist()}"


@dataclass(frozen=True)
class _Task:
    """What one solve needs: the problem, its formulation, the ends and the settings; the limits'
    scale and f_min as tightened by the check along the motion; the points between nodes."""
    problem: Problem
    form: object
    start: np.ndarray
    target: np.ndarray
    objective: str
    duration: float | None
    nodes: int
    contact: bool
    null_space: bool
    f_min: float
    warm_start: bool
    effort_weight: float
    inner: int = INNER_POINTS
    limit_scale: float = 1.0
    f_min_solved: float | None = None
    previous: OptimalMotion | None = None   # the warm start of a tightened solve


def optimal_motion(scene, target, objective: str = "time", *, duration: float | None = None, nodes: int = 40,
                   start=None, contact: bool = True, null_space: bool = True, sign: int | None = None,
                   f_min: float | None = None, warm_start: bool = True, effort_weight: float = 1.0) -> OptimalMotion:
    """The optimal rest-to-rest motion from `start` to `target` (see the module docstring).

    scene: a Scene, a Problem or a scene file's path (any mechanism with a task body or point).
    target, start: task poses (3,) [m, m, rad] (a task point: (2,) or (3,), the angle not used;
    start: the scene's path at s = 0). objective: 'time', 'effort' (needs `duration` [s]) or
    'time+effort' (the duration [s] plus effort_weight times the effort integral [(N m)^2 s]).
    nodes: intervals N. contact: keep the contact condition (needs actuation redundancy and
    f_min > 0). null_space: alpha free (else 0, the minimum-norm efforts; closed form only).
    sign: +1 / -1 of the contact condition (default: both, the better kept). f_min [N]: default
    ``actuation.preload.min_force``. warm_start: from the straight line's optimal time law
    (else a quintic rest-to-rest line). Raises KinematicsError for a pose out of reach,
    InfeasibleError where no motion exists (a pose beyond the singularity margins, the contact
    condition or the limits at rest, or a motion that cannot keep them between its nodes),
    SceneError for bad arguments.
    """
    problem = Problem.from_scene(scene)
    if objective not in MOTION_OBJECTIVES:
        raise unknown_value("objective", "value", objective, MOTION_OBJECTIVES)
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or not 2 <= nodes <= MAX_NODES:
        raise SceneError(f"nodes: {nodes!r} is not allowed (an integer from 2 to {MAX_NODES})")
    if problem.model.task is None:
        raise SceneError("mechanism.task: a point-to-point motion needs a task body or point (this scene has none: "
                         "its drivers set the motion)")
    if objective == "effort":
        if duration is None:
            raise SceneError("duration: missing (objective 'effort' minimises the effort at a given duration [s])")
        duration = argument("duration", duration)
    elif duration is not None:
        raise SceneError(f"duration: not allowed with objective {objective!r} (the duration is what it minimises)")
    effort_weight = argument("effort_weight", effort_weight, allow_zero=True)
    m = problem.model.redundancy
    f_min = problem.scene.actuation.preload.min_force if f_min is None else argument("f_min", f_min)
    if contact and (m < 1 or f_min <= 0):
        raise SceneError(f"contact: True is not allowed for this scene (the contact condition needs actuation "
                         f"redundancy and f_min > 0; redundancy {m}, f_min {f_min:g} N): pass contact=False")
    if not null_space and not problem.closed_form_family and m:
        raise SceneError("null_space: False is not allowed for this scene in a point-to-point motion (the "
                         "minimum-norm efforts are formulated on the n-RRR's closed form)")
    if sign is not None and sign not in (1, -1):
        raise SceneError(f"sign: {sign!r} is not allowed (+1 or -1)")
    point = problem.model.task_dof == 2
    target = checked_pose("target", target, point)
    start = (np.array(path_geometry_function(problem.path)(0.0)[0]).ravel() if start is None
             else checked_pose("start", start, point))
    if point:
        target = np.r_[target[:2], start[2]]
    if np.allclose(start, target, rtol=0.0, atol=1e-12):
        raise SceneError(f"target: {np.round(target, 6).tolist()} is not allowed (the same pose as the start)")
    form = _NRRR(problem, start, null_space) if problem.closed_form_family else GraphMotion(problem, contact)
    for key, pose in (("start", start), ("target", target)):
        form.check_pose(key, pose)
    signs = (sign,) if sign is not None else ((1, -1) if contact else (1,))
    task = _Task(problem, form, start, target, objective, duration, nodes, contact, null_space, f_min, warm_start,
                 effort_weight)
    return _checked_along(task, signs)


def _checked_along(task: _Task, signs) -> OptimalMotion:
    """The best motion, solved again until it keeps every margin, limit and the contact condition
    along its whole length (see the module docstring)."""
    rounds, missed, first = 0, "", {}
    while True:
        try:
            best = _best(task, signs)
        except (SolverError, InfeasibleError) as e:
            if not rounds:
                raise
            raise InfeasibleError(f"optimal motion: {missed} between the nodes, and solved again with the limits "
                                  f"lowered to {task.limit_scale:.6g} of theirs and f_min raised to "
                                  f"{task.f_min_solved:.6g} N no motion was found ({e})") from None
        if rounds:   # what the first solve found with each sign and its warm start, this sign's updated
            by_sign = {**first["objective_by_sign"], f"{best.sign:+d}": best.statistics["objective_value"]}
            best.statistics.update(objective_by_sign=by_sign, at_rest_infeasible=first["at_rest_infeasible"],
                                   line_duration_s=first["line_duration_s"], warm_start_note="the motion tightened")
        else:
            first = best.statistics
        along = _along(task, best)
        along.update(inner_points=task.inner, limit_scale=task.limit_scale,
                     f_min_solved_N=task.f_min_solved or task.f_min, backoff_rounds=rounds)
        best.statistics["along"] = along
        if not along["violation"]:
            return best
        if along["margin_violation"] and task.inner < MAX_INNER_POINTS:
            task = replace(task, inner=MAX_INNER_POINTS)
        elif not along["margin_violation"] and rounds < BACKOFF_ROUNDS and _small_miss(along, task):
            # solved again from this motion, with its sign, the limits and f_min tightened by what it missed
            rounds, missed = rounds + 1, along["violation"]
            scale = task.limit_scale / max(along["peak_effort_ratio"], 1.0) * (1 - BACKOFF_EXTRA)
            short = max(-along.get("min_contact_margin_N", 0.0), 0.0)
            task = replace(task, limit_scale=scale, previous=best, f_min_solved=(task.f_min_solved or task.f_min)
                           + short + BACKOFF_EXTRA * task.f_min)
            signs = (best.sign,) if best.sign else signs
        else:
            raise InfeasibleError(f"optimal motion: {along['violation']} between the nodes, with the constraints "
                                  f"held at the {task.nodes + 1} nodes, {task.inner} points between each two for the "
                                  f"margins and {rounds} rounds of tightened limits (no motion found that keeps them "
                                  "everywhere; try more --nodes or another target)")


def _small_miss(along: dict, task: _Task) -> bool:
    """True if the limits and the contact condition were missed between the nodes by at most
    BACKOFF_MAX (relative): what tightening them can fix; a larger miss needs more nodes."""
    short = max(-along.get("min_contact_margin_N", 0.0), 0.0) / task.f_min
    return along["peak_effort_ratio"] - 1.0 <= BACKOFF_MAX and short <= BACKOFF_MAX


def _along(task: _Task, motion: OptimalMotion) -> dict:
    """The check along the motion (:mod:`rrr4.optimal.motion_check`): margins, efforts, contact."""
    problem = task.problem
    samples = along_motion(motion, problem.path.sample_rate)
    t, pose, pose_d, pose_dd = samples[:4]
    try:
        q = problem.path_coordinates(pose, pose_d, pose_dd)
    except KinematicsError as e:
        return {"samples": int(t.size), "violation": f"the mechanism does not assemble ({e})",
                "margin_violation": True}
    margins = task.form.margins(t, pose, q)
    plan = plan_report(problem, motion, samples, q)
    return {**plan, **margins, "violation": margins["violation"] or plan["violation"]}


def _best(task: _Task, signs) -> OptimalMotion:
    """The better of the signs' motions (raises InfeasibleError when none is found)."""
    failures, results = {}, {}
    for sg in signs:
        where = _at_rest(task.problem, task.start, task.target, sg, task.f_min) if task.contact else ""
        if where:
            failures[sg] = where
            continue
        results[sg] = _solve(task, sg)
    if not results:
        raise InfeasibleError(" ".join(failures[sg] for sg in signs))
    ok = [r for r in results.values() if r.statistics["success"]]
    if not ok:
        st = next(iter(results.values())).statistics
        error = InfeasibleError if st["return_status"] == "Infeasible_Problem_Detected" else SolverError
        raise error(f"optimal motion: the solver stopped with {st['return_status']} (largest violation "
                    f"{st['max_violation']:.3g}, {st['worst_constraint']})")
    best = min(ok, key=lambda r: r.statistics["objective_value"])
    best.statistics["objective_by_sign"] = {f"{k:+d}": (r.statistics["objective_value"] if r.statistics["success"]
                                                        else None) for k, r in results.items()}
    best.statistics["objective_by_sign"].update({f"{k:+d}": None for k in failures})
    best.statistics["at_rest_infeasible"] = {f"{k:+d}": v for k, v in failures.items()}
    return best


def _at_rest(problem, start, target, sign: int, f_min: float) -> str:
    """'' if some alpha within the limits holds each end at rest with the contact condition
    (the preload layer's QP on the effort family), else one sentence naming the end and the joint."""
    poses = np.vstack([start, target])
    fam = problem.effort_family(poses, np.zeros((2, 3)), np.zeros((2, 3)))
    f = qp_preload_function(problem, "qrqp", float(sign), f_min=f_min)
    alpha, _, feas, _ = (np.array(v) for v in f.map(2)(*fam.raw))
    for k, key in enumerate(("start", "target")):
        if feas.ravel()[k] < 0.5:
            a = alpha.T.reshape(2, -1)[k]
            tau = fam.tau_p[k] + fam.tau_n[k] @ a
            r = fam.r_p[k] + np.einsum("jcm,m->jc", fam.r_n[k], a)
            d = contact_directions(fam.r_n[k][None])[0]
            ax = sign * np.einsum("jc,jc->j", d, r)
            j = int(np.argmin(ax))
            names = problem.model.preload_joints
            return (f"{_where(key, poses[k])}: no null-space effort within the limits holds it at rest with "
                    f"the contact condition at joint {names[j]} (f_min {f_min:g} N, sign {sign:+d}; best "
                    f"{ax[j]:.4g} N, peak effort {np.max(np.abs(tau)):.4g}).")
    return ""


# ---------------------------------------------------------------------------------- n-RRR


def _nrrr_node(problem: Problem) -> ca.Function:
    """SX Function 'motion_node': pose, pose_d (3), the accelerations after and before the
    node pose_dd, pose_dd_before (3), alpha (m) -> for each: tau (n), the reactions'
    components along the joints' null-space directions (nj), the reactions (2, nj). One
    Function for both sides, so their common terms (all that depends on the pose) are shared.
    Built once per problem."""
    return problem.memo(("point_to_point", "node"), lambda: _build_node(problem))


def _build_node(problem: Problem) -> ca.Function:
    pose, pose_d, acc, acc_before = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd", "pose_dd_before"))
    f = problem.inverse_dynamics()
    m = problem.model.redundancy
    alpha = ca.SX.sym("alpha", m)
    out = []
    for a in (acc, acc_before):
        tau_p, tau_n, r_p, r_n = f(pose, pose_d, a)
        nj = r_p.shape[1]
        tau = tau_p + (tau_n @ alpha if m else 0)
        r = r_p + sum((r_n[:, k * nj:(k + 1) * nj] * alpha[k] for k in range(m)), ca.SX.zeros(2, nj))
        if m:
            d = r_n[:, :nj]  # the first null-space direction, as contact_directions
            d = d / ca.repmat(ca.sqrt(ca.sum1(d**2) + 1e-300), 2, 1)
            axial = ca.sum1(d * r).T
        else:
            axial = ca.SX(0, 1)
        out += [tau, axial, r]
    return ca.Function("motion_node", [pose, pose_d, acc, acc_before, alpha], out,
                       ["pose", "pose_d", "pose_dd", "pose_dd_before", "alpha"],
                       ["tau", "axial", "r", "tau_before", "axial_before", "r_before"], {"cse": True})


def _nrrr_geometry(problem: Problem) -> ca.Function:
    """SX Function 'singularity': pose -> transmission sin (n), IK cos argument (n),
    tr(G) tr(G^-1) with G = J^T J (the squared bound of the condition number). Built once per problem."""
    return problem.memo(("point_to_point", "singularity"), lambda: _build_geometry(problem))


def _build_geometry(problem: Problem) -> ca.Function:
    mech = problem.mechanism
    pose = ca.SX.sym("pose", 3)
    J, _, _, sin_tr = mech.jacobian_function(pose)
    _, cos_arg = mech.ik_function(pose, ca.DM(mech.modes))
    G = J.T @ J
    return ca.Function("singularity", [pose], [sin_tr, cos_arg, ca.trace(G) * ca.trace(ca.inv(G))],
                       ["pose"], ["sin_transmission", "cos_arg", "condition_bound2"])


class _NRRR:
    """The closed-form formulation of an n-RRR scene."""

    def __init__(self, problem: Problem, start, null_space: bool):
        self.problem, self.mech = problem, problem.mechanism
        self.node, self.geometry = _nrrr_node(problem), _nrrr_geometry(problem)
        self.n, self.m_all = problem.model.n_actuators, problem.model.redundancy
        self.m = self.m_all if null_space else 0
        self.path, self.k = problem.path, 3
        cos_arg = np.array(self.mech.ik_function(start, self.mech.modes)[1]).ravel()
        # sin of the link angles at the start: their signs may not change (no working-mode flip)
        sin0 = np.array(self.geometry(start)[0]).ravel() if np.all(np.abs(cos_arg) <= 1) else np.ones(self.n)
        self.sigma = np.where(sin0 < 0, -1.0, 1.0)

    def check_pose(self, key: str, pose):
        cos_arg = np.array(self.mech.ik_function(pose, self.mech.modes)[1]).ravel()
        out = np.flatnonzero(~(np.abs(cos_arg) <= 1.0))
        if out.size:
            raise KinematicsError(f"{key}: pose {np.round(pose, 6).tolist()} is out of reach of chain {out[0] + 1} "
                                  f"(IK cos argument {cos_arg[out[0]]:.12g}, allowed [-1, 1])")
        sin_tr, _, bound2 = (np.array(v).ravel() for v in self.geometry(pose))
        p, where = self.path, _where(key, pose)
        weak = self.sigma * sin_tr < p.min_transmission
        if weak.any():
            i = int(np.argmax(weak))
            flip = " (a working-mode flip from the start)" if self.sigma[i] * sin_tr[i] < 0 else ""
            raise InfeasibleError(f"{where} is beyond the singularity margin: chain {i + 1}'s transmission |sin| "
                                  f"{abs(sin_tr[i]):.3g}{flip} (allowed >= path.min_transmission = "
                                  f"{p.min_transmission:g})")
        cond = float(condition_number(np.array(self.mech.jacobian(pose))[None])[0])
        if not np.sqrt(bound2[0]) <= p.max_condition_number:
            raise InfeasibleError(f"{where} is beyond the singularity margin: condition number of J {cond:.4g} "
                                  f"(its bound sqrt(tr(G) tr(G^-1)) {np.sqrt(bound2[0]):.4g}, allowed <= "
                                  f"path.max_condition_number = {p.max_condition_number:g})")

    def unknowns(self, opti, N):
        return {"alpha": opti.variable(self.m, N + 1) if self.m else ca.MX(0, N + 1)}

    def nodes(self, rows, v, pose, pose_d, sides):
        """Efforts and contact components at the nodes for each side's accelerations."""
        N1 = pose.shape[1]
        F = self.node.map(N1)
        alpha = v["alpha"]
        if self.m < self.m_all:
            alpha = ca.MX.zeros(self.m_all, N1)
        out = F(pose, pose_d, *sides, alpha)
        out = (out[:3], out[3:])
        self._margins(rows, pose, "node")
        return [o[0] for o in out], [o[1] for o in out]

    def between(self, rows, poses):
        """The singularity margins at poses (3, K) between the nodes."""
        self._margins(rows, poses, "point between nodes")

    def _margins(self, rows, poses, where):
        sin_tr, cos_arg, bound2 = self.geometry.map(poses.shape[1])(poses)
        p = self.path
        chains = [f"chain {i + 1}" for i in range(self.n)]
        rows.add(ca.diag(ca.DM(self.sigma)) @ sin_tr, p.min_transmission, None, [f"transmission {c}" for c in chains],
                 where)
        rows.add(cos_arg, -1.0, 1.0, [f"workspace (IK) {c}" for c in chains], where)
        rows.add(bound2 / p.max_condition_number**2, None, 1.0, ["condition number"], where)

    def margins(self, t, pose, q) -> dict:
        """The margins' extremes at the samples (t, pose (K, 3)) and the first violation."""
        K = len(t)
        J = np.array(self.mech.jacobian_function.map(K)(pose.T)[0]).T.reshape(K, 3, self.n).transpose(0, 2, 1)
        sin_tr = np.array(self.geometry.map(K)(pose.T)[0]).T
        return margin_report(t, condition_number(J), self.path.max_condition_number, self.sigma * sin_tr,
                             self.path.min_transmission)

    def initial(self, opti, v, warm):
        if self.m:
            opti.set_initial(v["alpha"], warm["alpha"][:, :self.m].T)

    def values(self, sol, v, pose, pose_d, sides):
        """Per side: efforts (N+1, n), reactions (N+1, nj, 2), axial (N+1, nj) (unsigned);
        alpha (N+1, m_all); condition (N+1,); transmission (N+1, n)."""
        N1 = pose.shape[1]
        alpha = np.zeros((self.m_all, N1))
        if self.m:
            alpha[:self.m] = np.atleast_2d(sol.value(v["alpha"]))
        res = [np.array(x) for x in self.node.map(N1)(pose, pose_d, *sides, alpha)]
        out = [(tau.T, r.reshape(2, N1, -1).transpose(1, 2, 0), ax.T) for tau, ax, r in (res[:3], res[3:])]
        J = np.array(self.mech.jacobian_function.map(N1)(pose)[0]).T.reshape(N1, 3, self.n).transpose(0, 2, 1)
        sin_tr, _, bound2 = (np.array(x).T for x in self.geometry.map(N1)(pose))
        return out, alpha.T, condition_number(J), np.abs(sin_tr), np.sqrt(bound2.ravel())


# ---------------------------------------------------------------------------------- the program


def _warm(task: _Task, sign, fractions) -> dict:
    """The straight line's optimal time law on N + 1 uniform times (its duration, or the
    given one by time scaling); a quintic line in 1 s where the line has none. Poses (N+1, 3),
    the accelerations on either side of each node, the poses at `fractions` of each interval."""
    t0 = time.perf_counter()
    problem, N, start, target, contact = task.problem, task.nodes, task.start, task.target, task.contact
    law, note = None, ""
    if task.previous is not None:
        p = task.previous
        return _warm_dict(p.duration, p.pose, p.pose_d, p.alpha, None, "from the previous solve", fractions, t0)
    if task.warm_start:
        path = replace(problem.path, type="line", start=tuple(start.tolist()), end=tuple(target.tolist()))
        try:
            law = optimal_time_law(replace(problem.scene, path=path), points=max(2 * N, 50),
                                   contact=contact, null_space=task.null_space, sign=sign if contact else None,
                                   f_min=task.f_min if contact else None)
        except (InfeasibleError, KinematicsError) as e:
            note = str(e)
    m_all = problem.model.redundancy
    if law is not None:
        T_line = law.duration
        T = T_line if task.duration is None else task.duration
        r = T_line / T
        tk = np.linspace(0.0, T_line, N + 1)
        pose = np.column_stack([np.interp(tk, law.t, law.pose[:, i]) for i in range(3)])
        pose_d = np.column_stack([np.interp(tk, law.t, law.pose_d[:, i]) for i in range(3)]) * r
        alpha = np.column_stack([np.interp(tk, law.t, law.alpha[:, i]) for i in range(m_all)]) if m_all \
            else np.zeros((N + 1, 0))
    else:
        T_line = None
        T = 1.0 if task.duration is None else task.duration
        x = np.linspace(0.0, 1.0, N + 1)
        shape, rate = 10 * x**3 - 15 * x**4 + 6 * x**5, (30 * x**2 - 60 * x**3 + 30 * x**4) / T
        pose = start + np.outer(shape, target - start)
        pose_d = np.outer(rate, target - start)
        alpha = np.zeros((N + 1, m_all))
    return _warm_dict(T, pose, pose_d, alpha, T_line, note, fractions, t0)


def _warm_dict(T, pose, pose_d, alpha, T_line, note, fractions, t0) -> dict:
    h = T / (len(pose) - 1)
    acc = np.diff(pose_d, axis=0) / h
    inner = np.vstack([pose[:-1] + (h * u) * pose_d[:-1] + (h * u)**2 / 2 * acc for u in fractions])
    return {"T": T, "pose": pose, "pose_d": pose_d, "pose_dd": acc, "alpha": alpha, "line_duration": T_line,
            "sides": (np.vstack([acc, acc[-1:]]), np.vstack([acc[:1], acc])), "inner_pose": inner,
            "note": note, "time_s": time.perf_counter() - t0}


def _full(task: _Task, x, rate: bool) -> np.ndarray:
    """(3, N) task coordinates from the program's (k, N): a task point's angle (the start's, its
    rates zero) appended."""
    if x.shape[0] == 3:
        return x
    return np.vstack([x, np.full((1, x.shape[1]), 0.0 if rate else task.start[2])])


def _solve(task: _Task, sign: int) -> OptimalMotion:
    problem, form, N, objective, start, target = task.problem, task.form, task.nodes, task.objective, task.start, \
        task.target
    k = form.k
    fractions = np.arange(1, task.inner + 1) / (task.inner + 1)
    warm = _warm(task, sign, fractions)
    t0 = time.perf_counter()
    opti = ca.Opti()
    X = opti.variable(2 * k, N + 1)
    U = opti.variable(k, N)
    pose, pose_d = X[:k, :], X[k:, :]
    rows = _Rows(opti)
    names = ("x", "y", "theta")[:k]
    if objective != "effort":
        T = opti.variable()
        opti.subject_to(T >= 1e-6)
        rows.labels.append("duration > 0")
        opti.set_initial(T, warm["T"])
    else:
        T = task.duration
    h = T / N
    rows.add(pose[:, 1:] - pose[:, :-1] - h * pose_d[:, :-1] - h**2 / 2 * U, 0.0, 0.0,
             [f"continuity {c}" for c in names], "interval")
    rows.add(pose_d[:, 1:] - pose_d[:, :-1] - h * U, 0.0, 0.0, [f"continuity {c}_d" for c in names], "interval")
    rows.add(X[:, [0, N]] - np.column_stack([np.r_[start[:k], np.zeros(k)], np.r_[target[:k], np.zeros(k)]]),
             0.0, 0.0, [f"rest {c}" for c in names] + [f"rest {c}_d" for c in names], "end")
    # each node with the acceleration of the interval after it, and of the one before it
    sides = (ca.horzcat(U, U[:, -1]), ca.horzcat(U[:, 0], U))
    v = form.unknowns(opti, N)
    taus, axials = form.nodes(rows, v, pose, pose_d, sides)
    form.between(rows, ca.horzcat(*(pose[:, :-1] + (h * u) * pose_d[:, :-1] + (h * u)**2 / 2 * U
                                    for u in fractions)))
    L = np.asarray(problem.torque_limit, float)
    f_min = task.f_min_solved or task.f_min
    for tau in taus:
        rows.add(ca.diag(ca.DM(1 / (L * task.limit_scale))) @ tau, -1.0, 1.0,
                 [f"limit of actuator {a}" for a in problem.model.actuator_names])
    if task.contact:
        for ax in axials:
            rows.add(sign * ax / f_min, 1.0, None, [f"contact condition at joint {j}"
                                                    for j in problem.model.preload_joints])
    W = ca.DM(np.asarray(problem.scene.actuation.preload.weights, float)
              if problem.model.redundancy else np.ones(len(L)))
    right, left = (ca.sum1(ca.diag(W) @ tau**2) for tau in taus)
    effort = ca.sum2(0.5 * (right[:, :-1] + left[:, 1:])) * h
    opti.minimize({"time": T, "effort": effort, "time+effort": T + task.effort_weight * effort}[objective])
    opti.set_initial(X, np.vstack([warm["pose"][:, :k].T, warm["pose_d"][:, :k].T]))
    opti.set_initial(U, warm["pose_dd"][:, :k].T)
    form.initial(opti, v, warm)
    opti.solver("ipopt", {"ipopt.max_cpu_time": 60.0 + 0.1 * N, **IPOPT_OPTIONS,
                          "ipopt.hessian_approximation": HESSIAN[objective]})
    build = time.perf_counter() - t0
    t1 = time.perf_counter()
    try:
        sol = opti.solve()
    except RuntimeError:
        sol = opti.debug
    solve_time = time.perf_counter() - t1
    st = opti.stats()
    Tv = task.duration if objective == "effort" else float(sol.value(T))
    Xv, Uv = np.array(sol.value(X)), np.atleast_2d(np.array(sol.value(U))).reshape(k, N)
    Pv, Pdv = _full(task, Xv[:k], False), _full(task, Xv[k:], True)
    sides_v = tuple(_full(task, a, True) for a in (np.hstack([Uv, Uv[:, -1:]]), np.hstack([Uv[:, :1], Uv])))
    (right_v, left_v), alpha, cond, sin_tr, bound = form.values(sol, v, Pv, Pdv, sides_v)
    g = np.array(sol.value(opti.g)).ravel()
    lbg, ubg = np.array(sol.value(opti.lbg)).ravel(), np.array(sol.value(opti.ubg)).ravel()
    viol = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    w = int(np.argmax(viol)) if viol.size else 0
    stats = {"solver": "ipopt", "transcription": "multiple shooting", "return_status": st["return_status"],
             "success": bool(st["success"]), "iterations": int(st["iter_count"]), "build_time_s": build,
             "solve_time_s": solve_time, "warm_start_time_s": warm["time_s"], "nodes": N + 1,
             "objective_value": float(sol.value(opti.f)), "sign": sign if task.contact else 0,
             "line_duration_s": warm["line_duration"], "warm_start_note": warm["note"],
             "formulation": "closed form" if isinstance(form, _NRRR) else "graph",
             "max_violation": float(viol.max(initial=0.0)), "worst_constraint": ""}
    if viol.size and viol[w] > 0:
        stats["worst_constraint"] = rows.labels[w] if w < len(rows.labels) else f"constraint row {w}"
    tau, r = right_v[0], right_v[1]
    axial = np.minimum(sign * right_v[2], sign * left_v[2]) if task.contact else np.zeros((N + 1, 0))
    binding = _binding(problem, (right_v[0], left_v[0]), axial if task.contact else None, f_min, sin_tr, bound,
                       L * task.limit_scale)
    return OptimalMotion(
        objective=objective, t=np.linspace(0.0, Tv, N + 1), pose=Pv.T, pose_d=Pdv.T, pose_dd=sides_v[0].T,
        efforts=tau, alpha=alpha, reactions=r, axial=axial, condition=cond, transmission=sin_tr, binding=binding,
        duration=Tv, start=tuple(start.tolist()), target=tuple(target.tolist()), contact=task.contact,
        sign=sign if task.contact else 0, f_min=task.f_min, torque_limit=tuple(L.tolist()),
        actuator_names=problem.model.actuator_names, joint_names=problem.model.preload_joints, statistics=stats,
        efforts_before=left_v[0])


class _Rows:
    """Opti's constraints with a label per scalar row, in Opti's order (for the worst violation)."""

    def __init__(self, opti):
        self.opti, self.labels = opti, []

    def add(self, expr, lo, hi, names, where: str = "node"):
        """lo <= expr <= hi (None: unbounded) for expr (k, cols): row r of k at column `where` c."""
        k, cols = expr.shape
        e = ca.vec(expr)
        if lo is not None and lo == hi:
            self.opti.subject_to(e == lo)
        elif hi is None:
            self.opti.subject_to(e >= lo)
        elif lo is None:
            self.opti.subject_to(e <= hi)
        else:
            self.opti.subject_to(self.opti.bounded(lo, e, hi))
        self.labels += [f"{names[r % k]} at {where} {r // k}" for r in range(k * cols)]


def _binding(problem, taus, axial, f_min, sin_tr, bound, limits) -> tuple[str, ...]:
    """Per node the constraints whose relative slack is below BINDING_TOL, tightest first."""
    p, more = problem.path, []
    if sin_tr is not None:
        chains = [f"transmission chain {i + 1}" for i in range(sin_tr.shape[1])]
        more.append((sin_tr / p.min_transmission - 1.0, chains))
    if bound is not None:
        more.append(((1.0 - bound / p.max_condition_number)[:, None], ["condition number"]))
    return binding_labels(taus, limits, problem.model.actuator_names,
                          None if axial is None else (axial,), f_min, problem.model.preload_joints, more)
