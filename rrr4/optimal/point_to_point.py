"""Point-to-point motions: the fastest, or the least-effort, rest-to-rest motion of the task
body between two poses with the path free (DESIGN.md §10, "between two poses").

Transcription: direct multiple shooting on N intervals of equal length h = T / N. The
states are the task pose and its rate (pose, pose_d); the controls are the task
acceleration pose_dd, constant on each interval (so each interval is integrated exactly:
pose_{k+1} = pose_k + h pose_d,k + h^2/2 pose_dd,k, pose_d,{k+1} = pose_d,k + h pose_dd,k),
and the null-space efforts alpha at every node. The efforts follow from the ideal inverse
dynamics:

- n-RRR scenes: tau = tau_p(pose, pose_d, pose_dd) + tau_n(pose) alpha and the passive-joint
  reactions likewise, from the closed-form SX inverse dynamics
  (:func:`rrr4.dynamics.inverse.inverse_dynamics_function`). Where J is regular, this is
  the same problem as efforts as controls: the efforts fix the task acceleration through
  J^T tau = the platform's wrench, and the null-space part alpha is what the task does not
  see, so (pose_dd, alpha) <-> tau is one-to-one.
- graph scenes with a task body (e.g. problems/xyt_table.yaml): the body coordinates q,
  their rates qd and accelerations qdd, the joint multipliers lambda and the efforts u are
  unknowns at every node, tied by the model's constraints (the task rows = pose, Phi_q qd,
  Phi_q qdd = gamma) and M qdd + Phi_q^T lambda = Q_g + S^T u: efforts as controls.

At every node, with the acceleration of the interval before it and of the one after it (one
alpha for both, as in :mod:`rrr4.optimal.time_law`):

- each actuator's limit |tau_i| <= L_i;
- the preload layer's contact condition at every passive revolute joint (n-RRR scenes):
  sigma d_j . r_j >= f_min, d_j the direction of the joint's null-space reaction, sigma the
  one sign for all joints; both signs are solved and the better kept (like part 1);
- the distance from singularity (n-RRR scenes, pose only): each chain's transmission
  sigma_i sin(link angle) >= ``path.min_transmission`` (sigma_i its sign at the start: no
  working-mode flip, the serial singularities), the IK defined (|cos argument| <= 1: the
  workspace), and sqrt(tr(G) tr(G^-1)) <= ``path.max_condition_number`` with G = J^T J,
  an upper bound of the 2-norm condition number of J (at most 3 times it), smooth where
  the condition number's singular values are not (parallel singularities).

The margins hold at the nodes and at INNER_POINTS instants between each two; the returned motion
(constant accelerations between the nodes) is then checked along its whole length (see
MIN_SAMPLES_PER_INTERVAL): where it fails (a thin singular set between two points, e.g. a pure
turn through a parallel singularity) it is solved again with MAX_INNER_POINTS between each two
nodes, and refused (InfeasibleError naming the instant and the value) if it still fails. The
summary reports the extremes along the motion beside those at the nodes.

Graph scenes keep the efforts' limits; their start and target are checked against the
singularity margins, and the condition number along the motion (sampled the same way) is
reported, not constrained.

Objectives: 'time' (T free), or 'effort' at a given duration: the integral of tau^T W tau dt
(W the preload weights), each interval the mean of its two ends. IPOPT on CasADi's Opti,
warm-started from the straight line between the poses with its optimal time law
(:func:`rrr4.optimal.optimal_time_law` on a 'line' path).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from ..checks import argument, describe, unknown_value
from ..dynamics.family import EffortFamily
from ..errors import InfeasibleError, KinematicsError, SceneError, SolverError
from ..mechanism.workspace import condition_number
from ..preload.qp import qp_preload_function
from ..problem import Problem
from ..trajectory import path_geometry_function
from .time_law import binding_counts, binding_labels, contact_directions, optimal_time_law, optimum_summary

__all__ = ["checked_pose", "OptimalMotion", "optimal_motion", "MOTION_OBJECTIVES"]

MOTION_OBJECTIVES = ("time", "effort")
MAX_NODES = 2000
# the margins are held at INNER_POINTS instants between each two nodes (MAX_INNER_POINTS where the
# check at the path's sample rate, at least MIN_SAMPLES_PER_INTERVAL instants per interval, fails)
INNER_POINTS, MAX_INNER_POINTS, MIN_SAMPLES_PER_INTERVAL, MAX_ALONG_SAMPLES = 1, 16, 32, 100_000
MARGIN_TOL = 1e-6  # relative tolerance of that check
IPOPT_OPTIONS = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-9,
                 "ipopt.constr_viol_tol": 1e-9, "ipopt.max_iter": 1000, "ipopt.mu_strategy": "adaptive"}
# per objective: for 'time' a limited-memory Hessian (the exact one through the mapped closed-form
# dynamics made the reference solve about 1.5x slower: fewer iterations, each far dearer); for
# 'effort' the exact one (the quadratic objective needs it: 18 iterations against 100+)
HESSIAN = {"time": "limited-memory", "effort": "exact"}


@dataclass(frozen=True)
class OptimalMotion:
    """An optimal rest-to-rest motion of the task on N + 1 nodes.

    t (N+1,) [s]; pose, pose_d, pose_dd (N+1, 3) [m, m, rad and rates] (pose_dd: the
    acceleration of the interval that starts at the node, the last node repeats the last
    interval's); efforts (N+1, n) [N m or N] at those accelerations; alpha (N+1, m) null-space
    efforts; reactions (N+1, nj, 2) [N] of the passive revolute joints; axial (N+1, nj) [N]:
    sigma d_j . r_j, the contact condition's left side, the smaller of the node's two sides
    (empty without the contact condition); condition (N+1,): the 2-norm condition number of
    J; transmission (N+1, n): |sin| of each chain's link angle (n-RRR; None for a graph);
    binding (N+1,): the constraints whose relative slack is below BINDING_TOL, tightest first
    ('' where none binds); duration [s]; statistics: solver, status, iterations, build, solve
    and warm-start times, the objective with each sign, the warm start's duration."""
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
            "margins_checked_at": along.get("samples")}


def checked_pose(key: str, v) -> np.ndarray:
    """`v` as a task pose [x, y, theta] (3 finite numbers), or a one-line SceneError naming `key`."""
    try:
        x = np.asarray(v, float).ravel()
    except (TypeError, ValueError):
        x = None
    if x is None or x.size != 3 or not np.all(np.isfinite(x)):
        raise SceneError(f"{key}: {describe(v)} is not allowed (a task pose [x, y, theta] of 3 finite numbers "
                         "[m, m, rad])")
    return x


def _where(key: str, pose) -> str:
    return f"{key} pose {np.round(pose, 6).tolist()}"


def optimal_motion(scene, target, objective: str = "time", *, duration: float | None = None, nodes: int = 40,
                   start=None, contact: bool = True, null_space: bool = True, sign: int | None = None,
                   f_min: float | None = None, warm_start: bool = True) -> OptimalMotion:
    """The optimal rest-to-rest motion from `start` to `target` (see the module docstring).

    scene: a Scene, a Problem or a scene file's path. target, start: task poses (3,)
    [m, m, rad] (start: the scene's path at s = 0). objective: 'time', or 'effort' (needs
    `duration` [s]). nodes: intervals N. contact: keep the contact condition (an n-RRR with
    actuation redundancy and f_min > 0). null_space: alpha free (else 0, the minimum-norm
    efforts). sign: +1 / -1 of the contact condition (default: both, the better kept).
    f_min [N]: default ``actuation.preload.min_force``. warm_start: from the straight line's
    optimal time law (else a quintic rest-to-rest line). Raises KinematicsError for a pose
    out of reach, InfeasibleError where no motion exists (a pose beyond the singularity
    margins, the contact condition or the limits at rest), SceneError for bad arguments.
    """
    problem = Problem.from_scene(scene)
    if objective not in MOTION_OBJECTIVES:
        raise unknown_value("objective", "value", objective, MOTION_OBJECTIVES)
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or not 2 <= nodes <= MAX_NODES:
        raise SceneError(f"nodes: {nodes!r} is not allowed (an integer from 2 to {MAX_NODES})")
    if problem.model.task is None or problem.model.task_dof != 3:
        raise SceneError("mechanism.task: a point-to-point motion needs a task body with 3 degrees of freedom "
                         f"(this scene has {'none' if problem.model.task is None else 'a task point'})")
    if objective == "effort":
        if duration is None:
            raise SceneError("duration: missing (objective 'effort' minimises the effort at a given duration [s])")
        duration = argument("duration", duration)
    elif duration is not None:
        raise SceneError("duration: not allowed with objective 'time' (the duration is what it minimises)")
    m = problem.model.redundancy
    f_min = problem.scene.actuation.preload.min_force if f_min is None else argument("f_min", f_min)
    if contact and (m < 1 or f_min <= 0):
        raise SceneError(f"contact: True is not allowed for this scene (the contact condition needs actuation "
                         f"redundancy and f_min > 0; redundancy {m}, f_min {f_min:g} N): pass contact=False")
    if contact and not problem.closed_form:
        raise SceneError("contact: True is not allowed for a graph scene in a point-to-point motion (the contact "
                         "condition is formulated on the n-RRR's closed form): pass contact=False")
    if not null_space and not problem.closed_form and m:
        raise SceneError("null_space: False is not allowed for a redundant graph scene in a point-to-point motion")
    if sign is not None and sign not in (1, -1):
        raise SceneError(f"sign: {sign!r} is not allowed (+1 or -1)")
    target = checked_pose("target", target)
    start = (np.array(path_geometry_function(problem.path)(0.0)[0]).ravel() if start is None
             else checked_pose("start", start))
    if np.allclose(start, target, rtol=0.0, atol=1e-12):
        raise SceneError(f"target: {np.round(target, 6).tolist()} is not allowed (the same pose as the start)")
    formulation = _NRRR(problem, start, null_space) if problem.closed_form else _Graph(problem)
    for key, pose in (("start", start), ("target", target)):
        formulation.check_pose(key, pose)
    signs = (sign,) if sign is not None else ((1, -1) if contact else (1,))
    inner = INNER_POINTS
    while True:
        best = _best(problem, formulation, start, target, objective, duration, nodes, contact, null_space, signs,
                     f_min, warm_start, inner)
        along = formulation.along(best, problem.path.sample_rate)
        along["inner_points"] = inner
        best.statistics["along"] = along
        if not along["violation"]:
            return best
        if inner >= MAX_INNER_POINTS:
            raise InfeasibleError(f"optimal motion: {along['violation']} between the nodes, with the margins held "
                                  f"at the {nodes + 1} nodes and {inner} points between each two (no motion found "
                                  "that keeps them everywhere; try other --nodes or another target)")
        inner = MAX_INNER_POINTS


def _best(problem, formulation, start, target, objective, duration, nodes, contact, null_space, signs, f_min,
          warm_start, inner) -> OptimalMotion:
    """The better of the signs' motions (raises InfeasibleError when none is found)."""
    failures, results = {}, {}
    for sg in signs:
        where = formulation.at_rest(start, target, sg, f_min) if contact else ""
        if where:
            failures[sg] = where
            continue
        results[sg] = _solve(problem, formulation, start, target, objective, duration, nodes, contact, null_space,
                             sg, f_min, warm_start, inner)
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


def along_motion(motion: OptimalMotion, rate: float, least: int = MIN_SAMPLES_PER_INTERVAL):
    """t (K,), pose (K, 3): the motion between its nodes as transcribed (constant acceleration on
    each interval), sampled at `rate` [Hz] (at most MAX_ALONG_SAMPLES in all) and at least
    `least` instants per interval, the nodes included."""
    N = len(motion.t) - 1
    h = motion.duration / N
    k = max(least, min(int(np.ceil(h * rate)), MAX_ALONG_SAMPLES // N))
    u = np.arange(k) / k * h
    pose = (motion.pose[:-1, None, :] + u[None, :, None] * motion.pose_d[:-1, None, :]
            + 0.5 * u[None, :, None]**2 * motion.pose_dd[:-1, None, :]).reshape(-1, 3)
    t = (motion.t[:-1, None] + u[None, :]).ravel()
    return np.r_[t, motion.t[-1]], np.vstack([pose, motion.pose[-1]])


def _margin_report(t, cond, cmax, sin_tr=None, tmin=None) -> dict:
    """The extremes of the margins at the samples t and the first violation ('' if none)."""
    out = {"samples": int(t.size), "max_condition_number": float(np.max(cond)),
           "t_max_condition_s": float(t[int(np.argmax(cond))]), "violation": ""}
    if sin_tr is not None:
        low = np.min(sin_tr, axis=1)
        out.update(min_transmission=float(np.min(low)), t_min_transmission_s=float(t[int(np.argmin(low))]))
        if out["min_transmission"] < tmin * (1 - MARGIN_TOL):
            out["violation"] = (f"a transmission |sin| of {out['min_transmission']:.3g} at t = "
                                f"{out['t_min_transmission_s']:.4g} s (allowed >= path.min_transmission = {tmin:g})")
    if not out["max_condition_number"] <= cmax * (1 + MARGIN_TOL):
        out["violation"] = (f"a condition number of J of {out['max_condition_number']:.4g} at t = "
                            f"{out['t_max_condition_s']:.4g} s (allowed <= path.max_condition_number = {cmax:g})")
    return out


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
        self.path = problem.path
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

    def at_rest(self, start, target, sign: int, f_min: float) -> str:
        """'' if some alpha within the limits holds each end at rest with the contact
        condition (the preload layer's QP), else one sentence naming the end and the joint."""
        poses = np.vstack([start, target])
        fam = self.problem.effort_family(poses, np.zeros((2, 3)), np.zeros((2, 3)))
        f = qp_preload_function(self.problem, "qrqp", float(sign), f_min=f_min)
        alpha, _, feas, _ = (np.array(v) for v in f.map(2)(*fam.raw))
        for k, key in enumerate(("start", "target")):
            if feas.ravel()[k] < 0.5:
                a = alpha.T.reshape(2, -1)[k]
                tau = fam.tau_p[k] + fam.tau_n[k] @ a
                r = fam.r_p[k] + np.einsum("jcm,m->jc", fam.r_n[k], a)
                d = contact_directions(fam.r_n[k][None])[0]
                ax = sign * np.einsum("jc,jc->j", d, r)
                j = int(np.argmin(ax))
                names = self.problem.model.preload_joints
                return (f"{_where(key, poses[k])}: no null-space effort within the limits holds it at rest with "
                        f"the contact condition at joint {names[j]} (f_min {f_min:g} N, sign {sign:+d}; best "
                        f"{ax[j]:.4g} N, peak effort {np.max(np.abs(tau)):.4g}).")
        return ""

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

    def along(self, motion, rate) -> dict:
        """The margins' extremes along the motion (:func:`along_motion`) and the first violation."""
        t, pose = along_motion(motion, rate)
        K = len(t)
        J = np.array(self.mech.jacobian_function.map(K)(pose.T)[0]).T.reshape(K, 3, self.n).transpose(0, 2, 1)
        sin_tr = np.array(self.geometry.map(K)(pose.T)[0]).T
        return _margin_report(t, condition_number(J), self.path.max_condition_number, self.sigma * sin_tr,
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


# ---------------------------------------------------------------------------------- graph


class _Graph:
    """Any graph with a task body: body coordinates, multipliers and efforts as unknowns."""

    def __init__(self, problem: Problem):
        self.problem, self.mech, self.model = problem, problem.mechanism, problem.model
        self.n, self.m_all = self.model.n_actuators, self.model.redundancy
        self.nq, self.rows = self.model.nq, self.mech.nq - 3
        mech, nq = self.mech, self.nq
        q, qd, qdd = (ca.SX.sym(s, nq) for s in ("q", "qd", "qdd"))
        pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
        lam, u = ca.SX.sym("lambda", self.rows), ca.SX.sym("u", self.n)
        A, gamma, _, S = mech.constraint_jacobian_function(q, qd)
        closure = mech.closure_function(q, ca.vertcat(pose, ca.SX.zeros(self.rows)))
        self.kinematics = ca.Function("motion_kinematics", [q, qd, pose, pose_d],
                                      [ca.vertcat(closure, A @ qd - ca.vertcat(ca.SX.zeros(self.rows), pose_d))])
        M = ca.DM(self.model.mass_diagonal)
        Qg = ca.DM(self.model.gravity_forces(problem.gravity))
        dyn = ca.vertcat(A @ qdd - gamma - ca.vertcat(ca.SX.zeros(self.rows), pose_dd),
                         M * qdd + A[:self.rows, :].T @ lam - Qg - S.T @ u)
        self.dynamics = ca.Function("motion_dynamics", [q, qd, qdd, pose_dd, lam, u], [dyn])

    def check_pose(self, key: str, pose):
        try:
            q = self.mech.assemble(pose)
        except KinematicsError as e:
            raise KinematicsError(f"{key}: {e}") from None
        cond = float(condition_number(self.mech.path_jacobians(q[None]))[0])
        cmax = self.problem.path.max_condition_number
        if not cond <= cmax:
            raise InfeasibleError(f"{_where(key, pose)} is beyond the singularity margin: condition number of J "
                                  f"{cond:.4g} (allowed <= path.max_condition_number = {cmax:g})")

    def at_rest(self, start, target, sign, f_min) -> str:
        return ""

    def unknowns(self, opti, N):
        N1, nq = N + 1, self.nq
        v = {"q": opti.variable(nq, N1), "qd": opti.variable(nq, N1)}
        for s in (0, 1):
            v[f"qdd{s}"] = opti.variable(nq, N1)
            v[f"lambda{s}"] = opti.variable(self.rows, N1)
            v[f"u{s}"] = opti.variable(self.n, N1)
        return v

    def nodes(self, rows, v, pose, pose_d, sides):
        N1, nq = pose.shape[1], self.nq
        rows.add(self.kinematics.map(N1)(v["q"], v["qd"], pose, pose_d), 0.0, 0.0,
                 [f"position closure row {i}" for i in range(nq)] + [f"velocity closure row {i}" for i in range(nq)])
        for s, acc in enumerate(sides):
            rows.add(self.dynamics.map(N1)(v["q"], v["qd"], v[f"qdd{s}"], acc, v[f"lambda{s}"], v[f"u{s}"]), 0.0, 0.0,
                     [f"acceleration closure row {i}" for i in range(nq)] + [f"equation of motion row {i}"
                                                                             for i in range(nq)])
        return [v["u0"], v["u1"]], [ca.MX(0, N1), ca.MX(0, N1)]

    def between(self, rows, poses):
        """Nothing: a graph's margins are checked at the ends and reported along the motion."""

    def along(self, motion, rate) -> dict:
        """The condition number's extreme along the motion (:func:`along_motion`), reported only."""
        t, pose = along_motion(motion, rate)
        try:
            q = self.problem.path_coordinates(pose, np.zeros_like(pose), np.zeros_like(pose))
            cond = condition_number(self.mech.path_jacobians(q))
        except KinematicsError as e:
            return {"samples": int(t.size), "violation": f"the mechanism does not assemble ({e})"}
        return {**_margin_report(t, cond, np.inf), "reported_only": True}

    def initial(self, opti, v, warm):
        pose, pose_d = warm["pose"], warm["pose_d"]
        q = self.problem.path_coordinates(pose, pose_d, np.zeros_like(pose))
        qd, _, _, _ = self.mech.motion(q, pose_d, np.zeros_like(pose))
        opti.set_initial(v["q"], q.T)
        opti.set_initial(v["qd"], qd.T)

    def values(self, sol, v, pose, pose_d, sides):
        N1 = pose.shape[1]
        q = np.atleast_2d(sol.value(v["q"])).T
        out = []
        for s in (0, 1):
            u = np.atleast_2d(sol.value(v[f"u{s}"])).reshape(self.n, N1).T
            fam = self.problem.effort_family(np.asarray(pose).T, np.asarray(pose_d).T, np.asarray(sides[s]).T, q=q)
            r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, _project(fam, u))
            out.append((u, r, np.zeros((N1, 0))))
        fam = self.problem.effort_family(np.asarray(pose).T, np.asarray(pose_d).T, np.asarray(sides[0]).T, q=q)
        return out, _project(fam, out[0][0]), condition_number(self.mech.path_jacobians(q)), None, None


def _project(fam: EffortFamily, u) -> np.ndarray:
    """alpha (N, m) of efforts u (N, n) in the family (orthonormal null-space directions)."""
    return np.einsum("knm,kn->km", fam.tau_n, u - fam.tau_p)


# ---------------------------------------------------------------------------------- the program


def _warm(problem, start, target, N, contact, null_space, sign, f_min, duration, warm_start):
    """The straight line's optimal time law on N + 1 uniform times (its duration, or the
    given one by time scaling); a quintic line in 1 s where the line has none."""
    t0 = time.perf_counter()
    law, note = None, ""
    if warm_start:
        path = replace(problem.path, type="line", start=tuple(start.tolist()), end=tuple(target.tolist()))
        try:
            law = optimal_time_law(replace(problem.scene, path=path), points=max(2 * N, 50),
                                   contact=contact, null_space=null_space, sign=sign if contact else None,
                                   f_min=f_min if contact else None)
        except (InfeasibleError, KinematicsError) as e:
            note = str(e)
    m_all = problem.model.redundancy
    if law is not None:
        T_line = law.duration
        T = T_line if duration is None else duration
        r = T_line / T
        tk = np.linspace(0.0, T_line, N + 1)
        pose = np.column_stack([np.interp(tk, law.t, law.pose[:, i]) for i in range(3)])
        pose_d = np.column_stack([np.interp(tk, law.t, law.pose_d[:, i]) for i in range(3)]) * r
        alpha = np.column_stack([np.interp(tk, law.t, law.alpha[:, i]) for i in range(m_all)]) if m_all \
            else np.zeros((N + 1, 0))
    else:
        T_line = None
        T = 1.0 if duration is None else duration
        x = np.linspace(0.0, 1.0, N + 1)
        shape, rate = 10 * x**3 - 15 * x**4 + 6 * x**5, (30 * x**2 - 60 * x**3 + 30 * x**4) / T
        pose = start + np.outer(shape, target - start)
        pose_d = np.outer(rate, target - start)
        alpha = np.zeros((N + 1, m_all))
    h = T / N
    acc = np.diff(pose_d, axis=0) / h
    return {"T": T, "pose": pose, "pose_d": pose_d, "pose_dd": acc, "alpha": alpha, "line_duration": T_line,
            "note": note, "time_s": time.perf_counter() - t0}


def _solve(problem, form, start, target, objective, duration, N, contact, null_space, sign, f_min,
           warm_start, inner) -> OptimalMotion:
    warm = _warm(problem, start, target, N, contact, null_space, sign, f_min, duration, warm_start)
    t0 = time.perf_counter()
    opti = ca.Opti()
    X = opti.variable(6, N + 1)
    U = opti.variable(3, N)
    pose, pose_d = X[:3, :], X[3:, :]
    rows = _Rows(opti)
    if objective == "time":
        T = opti.variable()
        opti.subject_to(T >= 1e-6)
        rows.labels.append("duration > 0")
        opti.set_initial(T, warm["T"])
    else:
        T = duration
    h = T / N
    rows.add(pose[:, 1:] - pose[:, :-1] - h * pose_d[:, :-1] - h**2 / 2 * U, 0.0, 0.0,
             ["continuity x", "continuity y", "continuity theta"], "interval")
    rows.add(pose_d[:, 1:] - pose_d[:, :-1] - h * U, 0.0, 0.0,
             ["continuity x_d", "continuity y_d", "continuity theta_d"], "interval")
    rows.add(X[:, [0, N]] - np.column_stack([np.r_[start, np.zeros(3)], np.r_[target, np.zeros(3)]]), 0.0, 0.0,
             ["rest x", "rest y", "rest theta", "rest x_d", "rest y_d", "rest theta_d"], "end")
    # each node with the acceleration of the interval after it, and of the one before it
    sides = (ca.horzcat(U, U[:, -1]), ca.horzcat(U[:, 0], U))
    v = form.unknowns(opti, N)
    taus, axials = form.nodes(rows, v, pose, pose_d, sides)
    form.between(rows, ca.horzcat(*(pose[:, :-1] + (h * u) * pose_d[:, :-1] + (h * u)**2 / 2 * U
                                    for u in np.arange(1, inner + 1) / (inner + 1))))
    L = np.asarray(problem.torque_limit, float)
    for tau in taus:
        rows.add(ca.diag(ca.DM(1 / L)) @ tau, -1.0, 1.0, [f"limit of actuator {a}"
                                                          for a in problem.model.actuator_names])
    if contact:
        for ax in axials:
            rows.add(sign * ax / f_min, 1.0, None, [f"contact condition at joint {j}"
                                                    for j in problem.model.preload_joints])
    W = ca.DM(np.asarray(problem.scene.actuation.preload.weights, float)
              if problem.model.redundancy else np.ones(len(L)))
    right, left = (ca.sum1(ca.diag(W) @ tau**2) for tau in taus)
    effort = ca.sum2(0.5 * (right[:, :-1] + left[:, 1:])) * h
    opti.minimize(T if objective == "time" else effort)
    opti.set_initial(X, np.vstack([warm["pose"].T, warm["pose_d"].T]))
    opti.set_initial(U, warm["pose_dd"].T)
    form.initial(opti, v, warm)
    opti.solver("ipopt", {"ipopt.max_wall_time": 60.0 + 0.1 * N, **IPOPT_OPTIONS,
                          "ipopt.hessian_approximation": HESSIAN[objective]})
    build = time.perf_counter() - t0
    t1 = time.perf_counter()
    try:
        sol = opti.solve()
    except RuntimeError:
        sol = opti.debug
    solve_time = time.perf_counter() - t1
    st = opti.stats()
    Tv = float(sol.value(T)) if objective == "time" else duration
    Xv, Uv = np.array(sol.value(X)), np.atleast_2d(np.array(sol.value(U))).reshape(3, N)
    Pv, Pdv = Xv[:3], Xv[3:]
    sides_v = (np.hstack([Uv, Uv[:, -1:]]), np.hstack([Uv[:, :1], Uv]))
    (right_v, left_v), alpha, cond, sin_tr, bound = form.values(sol, v, Pv, Pdv, sides_v)
    g = np.array(sol.value(opti.g)).ravel()
    lbg, ubg = np.array(sol.value(opti.lbg)).ravel(), np.array(sol.value(opti.ubg)).ravel()
    viol = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    w = int(np.argmax(viol)) if viol.size else 0
    stats = {"solver": "ipopt", "transcription": "multiple shooting", "return_status": st["return_status"],
             "success": bool(st["success"]), "iterations": int(st["iter_count"]), "build_time_s": build,
             "solve_time_s": solve_time, "warm_start_time_s": warm["time_s"], "nodes": N + 1,
             "objective_value": float(sol.value(opti.f)), "sign": sign if contact else 0,
             "line_duration_s": warm["line_duration"], "warm_start_note": warm["note"],
             "max_violation": float(viol.max(initial=0.0)), "worst_constraint": ""}
    if viol.size and viol[w] > 0:
        stats["worst_constraint"] = rows.labels[w] if w < len(rows.labels) else f"constraint row {w}"
    tau, r = right_v[0], right_v[1]
    axial = np.minimum(sign * right_v[2], sign * left_v[2]) if contact else np.zeros((N + 1, 0))
    binding = _binding(problem, (right_v[0], left_v[0]), axial if contact else None, f_min, sin_tr, bound)
    return OptimalMotion(
        objective=objective, t=np.linspace(0.0, Tv, N + 1), pose=Pv.T, pose_d=Pdv.T, pose_dd=sides_v[0].T,
        efforts=tau, alpha=alpha, reactions=r, axial=axial, condition=cond, transmission=sin_tr, binding=binding,
        duration=Tv, start=tuple(start.tolist()), target=tuple(target.tolist()), contact=contact,
        sign=sign if contact else 0, f_min=f_min, torque_limit=tuple(L.tolist()),
        actuator_names=problem.model.actuator_names, joint_names=problem.model.preload_joints, statistics=stats)


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


def _binding(problem, taus, axial, f_min, sin_tr, bound) -> tuple[str, ...]:
    """Per node the constraints whose relative slack is below BINDING_TOL, tightest first."""
    p, more = problem.path, []
    if sin_tr is not None:
        chains = [f"transmission chain {i + 1}" for i in range(sin_tr.shape[1])]
        more.append((sin_tr / p.min_transmission - 1.0, chains))
    if bound is not None:
        more.append(((1.0 - bound / p.max_condition_number)[:, None], ["condition number"]))
    return binding_labels(taus, problem.torque_limit, problem.model.actuator_names,
                          None if axial is None else (axial,), f_min, problem.model.preload_joints, more)
