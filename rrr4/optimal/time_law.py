"""Time-optimal path following with the null-space efforts as decision variables.

On N + 1 grid points s_k = k / N of the scene's path the unknowns are b_k = s_dot^2,
c_k = s_dot (relaxed: c_k^2 <= b_k, tight at the optimum) and the null-space efforts alpha_k.
The segment acceleration a_k = (b_{k+1} - b_k) / (2 ds) is constant on each segment (so is
s_ddot in time), and point k uses a_k (the last point a_{N-1}). With the affine family of
:mod:`rrr4.optimal.family`, at every point

- each actuator's limit |tau_i| <= L_i,
- the preload layer's contact condition at every passive revolute joint (the QP's rule,
  :mod:`rrr4.preload.qp`): sigma d_j . r_j >= f_min, d_j the direction of the joint's
  null-space reaction, sigma the one sign for all joints,
- optional bounds: s_dot <= max_speed, the task point's speed and acceleration,

are linear in (a, b, alpha) (the acceleration bound is a convex quadratic). The duration
sum 2 ds / (c_k + c_{k+1}) and the effort integral sum (tau^T W tau) 2 ds / (c_k + c_{k+1})
(W the preload weights) are convex, so the program is convex (Verscheure et al., IEEE TAC
54(10), 2009) and IPOPT, on CasADi's sparse (banded) derivatives, finds its global optimum
(solver 'convex'). The relaxation c <= sqrt(b) keeps every function smooth where the path is
at rest. The time objective is solved by default by reachability analysis (solver
'reachability', :mod:`rrr4.optimal.reachability`, TOPP-RA): the same constraints on both
sides of every point with an alpha per side (the law reports the alpha of the segment after
each point), so its duration is the convex program's to about 1e-5.

Objectives: 'time'; 'effort' at a given duration; 'time+effort' (time plus effort_weight
times the effort integral). ``contact=False`` drops the contact rows, ``null_space=False``
fixes alpha = 0 (the minimum-norm efforts), so a user sees what each costs. Where the
layer would pick one sign for all joints, both are solved and the faster kept; both are
reported. Before the convex program solves, the path is checked at rest (a = b = 0): if no
null-space effort within the limits meets the contact condition somewhere, or the limits
cannot hold the path at rest, :class:`~rrr4.errors.InfeasibleError` names where and which
constraint (the reachability analysis runs the check where it finds no law).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np
from scipy import sparse

from ..checks import argument, unknown_value
from ..dynamics.family import EffortFamily
from ..errors import InfeasibleError, SceneError
from ..files import write_atomic
from ..mechanism.workspace import near_singular, path_kinematics
from ..preload.qp import qp_preload_function
from ..problem import Problem
from ..scene import time_table_text
from ..scene.vocabulary import OBJECTIVES
from ..trajectory import PathSamples
from .family import PathFamily, path_family
from .reachability import X_CAP, point_rows, project_out, recover_alpha, time_optimal_speeds

__all__ = ["OptimalTimeLaw", "optimal_time_law", "binding_counts", "binding_labels", "optimum_summary", "OBJECTIVES",
           "MAX_POINTS", "contact_directions", "SOLVERS", "time_law_functions"]

MAX_POINTS = 100_000
SOLVERS = ("reachability", "convex")   # of the time law: TOPP-RA, the convex program (IPOPT)
# a constraint whose relative slack is below this is reported as binding
BINDING_TOL = 1e-5
IPOPT_OPTIONS = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-10,
                 "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 500, "ipopt.mu_strategy": "adaptive"}


def sparse_to_casadi(A) -> ca.DM:
    """A scipy sparse matrix as a CasADi DM with the same sparsity (explicit zeros kept)."""
    A = sparse.csc_matrix(A)
    A.sum_duplicates()
    return ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), A.data)


def contact_directions(r_n: np.ndarray) -> np.ndarray:
    """(N, nj, 2) unit direction d_j of each joint's reaction along the first null-space
    direction (r_n (N, nj, 2, m)): the direction of the preload QP's contact condition."""
    d = r_n[..., 0]
    return d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-300)


@dataclass(frozen=True)
class OptimalTimeLaw:
    """An optimal time law along the scene's path, on N + 1 grid points.

    t, s, s_dot, s_ddot (N+1,) [s, -, 1/s, 1/s^2] (s_ddot: the acceleration of the segment
    that starts at the point; the last point repeats the last segment's); pose, pose_d, pose_dd
    (N+1, 3) of the task; alpha (N+1, m) null-space efforts; efforts (N+1, n) [N m or N];
    reactions (N+1, nj, 2) [N]; axial (N+1, nj) [N]: sigma d_j . r_j, the contact
    condition's left side (>= f_min where it holds); binding (N+1,): the constraint with the
    smallest slack where it binds ('' where none does); duration [s]; statistics: solver, status,
    iterations (IPOPT), build and solve times, the duration with each sign."""
    objective: str
    t: np.ndarray
    s: np.ndarray
    s_dot: np.ndarray
    s_ddot: np.ndarray
    pose: np.ndarray
    pose_d: np.ndarray
    pose_dd: np.ndarray
    alpha: np.ndarray
    efforts: np.ndarray
    reactions: np.ndarray
    axial: np.ndarray
    binding: tuple[str, ...]
    duration: float
    contact: bool
    null_space: bool
    sign: int
    f_min: float
    torque_limit: tuple[float, ...]
    actuator_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    statistics: dict = field(default_factory=dict)

    @property
    def table(self) -> np.ndarray:
        """(N+1, 3) rows (t, s, s_dot) of the time table a scene carries
        (:meth:`rrr4.scene.Scene.with_time_table`)."""
        return np.column_stack([self.t, self.s, self.s_dot])

    def save_table(self, path) -> Path:
        """Write the time table (CSV: t, s, s_dot, s_ddot; :mod:`rrr4.scene.time_table`) to
        `path`, atomically; a scene refers to it with ``path.time_law: table`` and
        ``path.time_table: FILE``."""
        return write_atomic(path, time_table_text(self.t, self.s, self.s_dot, self.s_ddot))

    def binding_counts(self) -> dict[str, int]:
        """How many grid points each constraint binds at."""
        return binding_counts(self.binding)

    def summary(self) -> dict:
        """The law's numbers as plain JSON types."""
        return {**optimum_summary(self), "points": len(self.s), "null_space": self.null_space}


def binding_labels(taus, limits, actuators, axials=None, f_min=None, joints=(), more=()) -> tuple[str, ...]:
    """Per point (or node) the constraints whose relative slack is below BINDING_TOL, tightest
    first, joined by ', ' ('' where none binds): each actuator's limit at the larger |effort|
    of `taus` (its values on either side of a point), each passive joint's contact condition at
    the smaller of `axials` (None: no contact condition), then `more`, pairs (slack (N, k),
    k names). The one place an optimal law's or motion's binding constraints are named."""
    slack = [1.0 - np.maximum.reduce([np.abs(t) for t in taus]) / np.asarray(limits, float)]
    names = [f"actuator {n}" for n in actuators]
    if axials is not None:
        slack.append(np.minimum.reduce(list(axials)) / f_min - 1.0)
        names += [f"contact {j}" for j in joints]
    for s, n in more:
        slack.append(s)
        names += list(n)
    S = np.concatenate(slack, axis=1)
    order = np.argsort(S, axis=1, kind="stable")
    count = (S < BINDING_TOL).sum(axis=1)
    return tuple(", ".join(names[i] for i in row[:n]) for row, n in zip(order.tolist(), count.tolist(), strict=True))


def binding_counts(binding) -> dict[str, int]:
    """How many points (or nodes) each constraint binds at, from the per-point lists
    ('name, name', '' where none binds) of an optimal law or motion."""
    out: dict[str, int] = {}
    for names in binding:
        for b in names.split(", ") if names else ():
            out[b] = out.get(b, 0) + 1
    return dict(sorted(out.items()))


def optimum_summary(opt) -> dict:
    """What an optimal law and an optimal motion report alike, as plain JSON types."""
    return {"objective": opt.objective, "duration_s": opt.duration, "contact_condition": opt.contact,
            "sign": opt.sign, "f_min_N": opt.f_min,
            "peak_effort_ratio": float(np.max(np.abs(opt.efforts) / np.asarray(opt.torque_limit))),
            "min_contact_margin_N": float(opt.axial.min() - opt.f_min) if opt.axial.size else None,
            "binding": binding_counts(opt.binding), "statistics": _plain(opt.statistics)}


def _plain(d):
    if isinstance(d, dict):
        return {str(k): _plain(v) for k, v in d.items()}
    if isinstance(d, (np.floating, np.integer)):
        return d.item()
    return d


def _grid(points) -> int:
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or not 2 <= points <= MAX_POINTS:
        raise SceneError(f"points: {points!r} is not allowed (an integer from 2 to {MAX_POINTS})")
    return int(points)


def optimal_time_law(scene, objective: str = "time", *, points: int = 1000, contact: bool = True,
                     null_space: bool = True, sign: int | None = None, duration: float | None = None,
                     effort_weight: float = 1.0, max_speed: float | None = None,
                     max_task_speed: float | None = None, max_task_acceleration: float | None = None,
                     end_speeds=(0.0, 0.0), f_min: float | None = None, solver: str | None = None) -> OptimalTimeLaw:
    """The optimal time law along the scene's path (see the module docstring).

    scene: a Scene, a Problem or a scene file's path. objective: 'time', 'effort' (needs
    `duration` [s]) or 'time+effort' (the duration [s] plus effort_weight times the effort
    integral ∫ tau^T W tau dt [(N m)^2 s]). points: grid intervals N. contact: keep the contact condition (needs a
    redundant mechanism with a preload's f_min > 0). null_space: alpha free (else 0).
    sign: +1 / -1 for the contact condition (default: both, the better kept). max_speed
    [1/s] on s_dot; max_task_speed [m/s], max_task_acceleration [m/s^2] of the task point.
    end_speeds: s_dot [1/s] at s = 0 and s = 1 (rest to rest by default). f_min [N]: default
    the scene's ``actuation.preload.min_force``. solver: 'reachability' (TOPP-RA,
    :mod:`rrr4.optimal.reachability`: the time objective with at most one free null-space
    effort and no task acceleration bound) or 'convex' (IPOPT on the convex program: every
    objective); default the first where it applies. Raises InfeasibleError where no law exists.
    """
    problem = Problem.from_scene(scene)
    if objective not in OBJECTIVES:
        raise unknown_value("objective", "value", objective, OBJECTIVES)
    N = _grid(points)
    if problem.model.task is None:
        raise SceneError("path.type: 'none' is not allowed for a time law (the scene has no task body: its drivers "
                         "set the motion)")
    if objective == "effort":
        if duration is None:
            raise SceneError("duration: missing (objective 'effort' minimises the effort at a given duration [s])")
        duration = argument("duration", duration)
    effort_weight = argument("effort_weight", effort_weight, allow_zero=True)
    bounds = {k: None if v is None else argument(k, v) for k, v in
              (("max_speed", max_speed), ("max_task_speed", max_task_speed),
               ("max_task_acceleration", max_task_acceleration))}
    try:
        ends = tuple(argument("end_speeds", v, allow_zero=True) for v in end_speeds)
    except TypeError:
        ends = ()
    if len(ends) != 2:
        raise SceneError(f"end_speeds: {end_speeds!r} is not allowed (two s_dot values >= 0 [1/s], at s = 0 and 1)")
    model = problem.model
    m = model.redundancy
    f_min = problem.scene.actuation.preload.min_force if f_min is None else argument("f_min", f_min)
    if contact and (m < 1 or f_min <= 0):
        raise SceneError(f"contact: True is not allowed for this scene (the contact condition needs actuation "
                         f"redundancy and f_min > 0; redundancy {m}, f_min {f_min:g} N): pass contact=False")
    if sign is not None and sign not in (1, -1):
        raise SceneError(f"sign: {sign!r} is not allowed (+1 or -1)")
    solver = _solver(solver, objective, m if null_space else 0, bounds["max_task_acceleration"])
    fam = path_family(problem, np.linspace(0.0, 1.0, N + 1))
    _check_path(problem, fam)
    signs = (sign,) if sign is not None else ((1, -1) if contact else (1,))
    setup = _Setup(problem, fam, objective, contact, null_space, duration, effort_weight, bounds, ends, f_min)
    results, failures = {}, {}
    for sg in signs:
        if solver == "reachability":   # the check at rest only names the constraint where no law exists
            try:
                results[sg] = setup.solve_reachability(sg)
            except InfeasibleError as e:
                failures[sg] = setup.at_rest(sg) or str(e)
            continue
        where = setup.at_rest(sg)
        if where:
            failures[sg] = where
            continue
        results[sg] = setup.solve_reachability(sg) if solver == "reachability" else setup.solve(sg)
    if not results:
        raise InfeasibleError("; ".join(failures[sg] for sg in signs))
    by_sign = {sg: (r.duration if r.statistics["success"] else None) for sg, r in results.items()}
    by_sign.update({sg: None for sg in failures})
    ok = [r for r in results.values() if r.statistics["success"]]
    if not ok:
        r = next(iter(results.values()))
        raise InfeasibleError(f"optimal time law: the solver stopped with {r.statistics['return_status']} "
                              f"(largest violation {r.statistics['max_violation']:.3g} at s = "
                              f"{r.statistics['worst_s']:.4g}, {r.statistics['worst_constraint']})")
    best = min(ok, key=lambda r: r.statistics["objective_value"])
    best.statistics.update(duration_by_sign={f"{k:+d}": v for k, v in by_sign.items()},
                           at_rest_infeasible={f"{k:+d}": v for k, v in failures.items()})
    return best


def time_law_functions(scene, points: int = 1000, *, sign: int = 1, contact: bool = True,
                       null_space: bool = True, f_min: float | None = None):
    """What both solvers of the time objective constrain, for cross-checks and benchmarks:
    (family, F, lo, hi, labels), F (N+1, nf, 3 + m) the scaled coefficients of (a, b, alpha...,
    1) of every constrained function at every grid point (the actuators' efforts over their
    limits, then the contact rows over f_min) and lo <= F . (a, b, alpha, 1) <= hi (nf,); the
    arguments as :func:`optimal_time_law`'s."""
    problem = Problem.from_scene(scene)
    fam = path_family(problem, np.linspace(0.0, 1.0, _grid(points) + 1))
    f_min = problem.scene.actuation.preload.min_force if f_min is None else argument("f_min", f_min)
    none = dict.fromkeys(("max_speed", "max_task_speed", "max_task_acceleration"))
    setup = _Setup(problem, fam, "time", contact, null_space, None, 1.0, none, (0.0, 0.0), f_min)
    return (fam, *setup.function_array(sign))


def _solver(solver, objective, m, max_task_acceleration) -> str:
    """The solver asked for, or the default: reachability analysis where it applies."""
    if solver is not None and solver not in SOLVERS:
        raise unknown_value("solver", "value", solver, SOLVERS)
    why = ("the objective is 'time'" if objective != "time" else
           f"at most one free null-space effort (here {m})" if m > 1 else
           "no max_task_acceleration (a quadratic bound)" if max_task_acceleration is not None else "")
    if solver == "reachability" and why:
        raise SceneError(f"solver: 'reachability' is not allowed here (it needs {why}): use 'convex'")
    return solver or ("convex" if why else "reachability")


def _check_path(problem: Problem, fam: PathFamily) -> None:
    """InfeasibleError at the first grid point where the path leaves the workspace, comes
    within the scene's singularity margins, or makes the family non-finite."""
    pk = path_kinematics(problem.mechanism, PathSamples(fam.s, fam.pose, fam.pose_s, fam.pose_ss))
    why = near_singular(problem.path, pk)
    if pk.cos_arg is not None:
        out = np.any(~(np.abs(pk.cos_arg) <= 1.0), axis=1)
        why = np.where(out, "out of reach (the IK of a chain is undefined)", why)
    finite = np.ones(len(fam.s), bool)
    for v in (fam.tau_a, fam.tau_b, fam.tau_g, fam.tau_n, fam.r_a, fam.r_b, fam.r_g, fam.r_n):
        finite &= np.all(np.isfinite(v.reshape(len(fam.s), -1)), axis=1)
    why = np.where(finite | (why != ""), why, "the inverse dynamics are not finite (a singular pose)")
    bad = np.flatnonzero(why != "")
    if bad.size:
        k = int(bad[0])
        raise InfeasibleError(f"path infeasible at s = {fam.s[k]:.4g} (pose {np.round(fam.pose[k], 6).tolist()}): "
                              f"{why[k]}")


class _Setup:
    """One time-law program on a path family; solved per contact sign."""

    def __init__(self, problem, fam: PathFamily, objective, contact, null_space, duration, effort_weight,
                 bounds, ends, f_min):
        self.problem, self.fam, self.objective = problem, fam, objective
        self.contact, self.null_space, self.duration = contact, null_space, duration
        self.effort_weight, self.bounds, self.ends, self.f_min = effort_weight, bounds, ends, f_min
        self.limits = np.asarray(problem.torque_limit, float)
        self.weights = np.asarray(problem.scene.actuation.preload.weights, float)
        self.names = problem.model.actuator_names
        self.joints = problem.model.preload_joints
        self.d = contact_directions(fam.r_n) if fam.r_n.shape[-1] else np.zeros(fam.r_g.shape)
        self.m = fam.tau_n.shape[2] if null_space else 0

    # ------------------------------------------------------------------ at rest

    def at_rest(self, sign: int) -> str:
        """'' if the path can be held at rest (a = b = 0) at every grid point with some alpha,
        else one sentence naming the first point and the constraint."""
        fam, L = self.fam, self.limits
        N1 = len(fam.s)
        if self.m == 0:
            alpha = np.zeros((N1, 0))
            feasible = np.ones(N1, bool)
        else:
            alpha, feasible = self._rest_alpha(sign)
        tau = fam.tau_g + np.einsum("knm,km->kn", fam.tau_n[:, :, :self.m], alpha)
        over = np.abs(tau) / L - 1.0
        axial = self._axial(fam.r_g + np.einsum("kjcm,km->kjc", fam.r_n[..., :self.m], alpha), sign)
        short = (self.f_min - axial) / self.f_min if self.contact else np.full((N1, 1), -1.0)
        bad = ~feasible | (over.max(axis=1) > 1e-9) | (short.max(axis=1) > 1e-9)
        if not bad.any():
            return ""
        k = int(np.flatnonzero(bad)[0])
        i = int(np.argmax(over[k]))
        where = f"path infeasible at s = {fam.s[k]:.4g} (pose {np.round(fam.pose[k], 6).tolist()}): "
        if not self.contact:
            return where + f"actuator {self.names[i]} needs |{tau[k, i]:.4g}| > its limit {L[i]:g} to hold it at rest"
        if short[k].max() > 1e-9:
            j = int(np.argmax(short[k]))
            return where + (f"no null-space effort meets the contact condition at joint {self.joints[j]} (f_min "
                            f"{self.f_min:g} N, sign {sign:+d})")
        return where + (f"the contact condition (f_min {self.f_min:g} N at every passive joint, sign {sign:+d}) "
                        f"needs actuator {self.names[i]} at |{tau[k, i]:.4g}| > its limit {L[i]:g} at rest")

    def _rest_alpha(self, sign):
        """alpha (N+1, m) and a feasibility flag per point of the static problem: the preload
        layer's QP (its rule and its tolerance) at a = b = 0."""
        fam = self.fam
        f = qp_preload_function(self.problem, "qrqp", float(sign), f_min=self.f_min if self.contact else -1e30)
        raw = EffortFamily(fam.tau_g, fam.tau_n, fam.r_g, fam.r_n).raw
        alpha, _, feas, _ = (np.array(v) for v in f.map(len(fam.s))(*raw))
        return alpha.T.reshape(len(fam.s), -1), feas.ravel() > 0.5

    def _axial(self, r, sign):
        return sign * np.einsum("kjc,kjc->kj", self.d, r)

    # ------------------------------------------------------------------ the program

    def _rows(self, coefs, scale):
        """Sparse rows (both sides of every point) of affine functions of (a, b, alpha):
        coefs = (c_a, c_b, c_g (N+1,), c_n (N+1, m)) per function; returns (A (2 (N+1) F, nx)
        in scipy CSR with the rows point-major: point k, side, function; g0) for A x + g0."""
        fam, m = self.fam, self.m
        N1 = len(fam.s)
        N, nv, F = N1 - 1, 2 + m, len(coefs)
        k = np.arange(N1)
        rows, cols, vals, g0 = [], [], [], np.zeros((N1, 2, F))
        for side, (lo, hi) in enumerate(((np.minimum(k, N - 1), np.minimum(k, N - 1) + 1),     # the segment after
                                          (np.maximum(k, 1) - 1, np.maximum(k, 1)))):          # the segment before
            for f, ((c_a, c_b, c_g, c_n), sc) in enumerate(zip(coefs, scale, strict=True)):
                r = (k * 2 + side) * F + f
                w = sc * c_a * N / 2.0  # a = (b_hi - b_lo) / (2 ds), ds = 1 / N
                rows += [r, r, r]
                cols += [hi * nv, lo * nv, k * nv]
                vals += [w, -w, sc * c_b]
                for i in range(m):
                    rows.append(r)
                    cols.append(k * nv + 2 + i)
                    vals.append(sc * c_n[:, i])
                g0[:, side, f] = sc * c_g
        A = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(2 * N1 * F, N1 * nv))
        return A, g0.ravel()

    def _functions(self, sign):
        """The constrained functions of (a, b, alpha) at every point: per function its
        coefficients (c_a, c_b, c_g (N+1,), c_n (N+1, m)), scale, label and scaled bounds; the
        efforts' first (one per actuator)."""
        fam, m = self.fam, self.m
        n_act = fam.tau_a.shape[1]
        efforts = [(fam.tau_a[:, i], fam.tau_b[:, i], fam.tau_g[:, i], fam.tau_n[:, i, :m]) for i in range(n_act)]
        coefs, scale, labels = list(efforts), list(1.0 / self.limits), [f"actuator {n}" for n in self.names]
        lo_f, hi_f = [-1.0] * n_act, [1.0] * n_act
        if self.contact:
            for j in range(fam.r_g.shape[1]):
                d = self.d[:, j, :]
                coefs.append(tuple(np.einsum("kc,kc->k", d, v[:, j, :]) for v in (fam.r_a, fam.r_b, fam.r_g))
                             + (np.einsum("kc,kcm->km", d, fam.r_n[:, j, :, :m]),))
                scale.append(sign / self.f_min)
                labels.append(f"contact {self.joints[j]}")
                lo_f.append(1.0)
                hi_f.append(np.inf)
        return efforts, coefs, scale, labels, np.array(lo_f), np.array(hi_f)

    def function_array(self, sign):
        """F (N+1, nf, 3 + m): per point and function the coefficients of (a, b, alpha..., 1),
        scaled so that the bounds lo_f, hi_f (nf,) are -1, 1 (actuators) or 1, inf (contact);
        and the functions' labels."""
        _, coefs, scale, labels, lo_f, hi_f = self._functions(sign)
        F = np.stack([np.column_stack([sc * c_a, sc * c_b, sc * c_n, sc * c_g])
                      for (c_a, c_b, c_g, c_n), sc in zip(coefs, scale, strict=True)], axis=1)
        return F, lo_f, hi_f, labels

    def speed_bounds(self) -> np.ndarray:
        """(N+1,) the largest b = s_dot^2 the speed bounds allow (inf where none)."""
        fam = self.fam
        bmax = np.full(len(fam.s), np.inf)
        if self.bounds["max_speed"] is not None:
            bmax = np.minimum(bmax, self.bounds["max_speed"] ** 2)
        if self.bounds["max_task_speed"] is not None:
            speed2 = np.sum(fam.pose_s[:, :2] ** 2, axis=1)   # the task point's x, y
            bmax = np.minimum(bmax, self.bounds["max_task_speed"] ** 2 / np.maximum(speed2, 1e-300))
        N = len(fam.s) - 1
        for k, v in ((0, self.ends[0]), (N, self.ends[1])):
            if v**2 > bmax[k] * (1 + 1e-12):
                raise SceneError(f"end_speeds: s_dot {v:g} 1/s at s = {k / N:g} is not allowed (above the speed "
                                 f"bounds there: {np.sqrt(bmax[k]):.4g} 1/s)")
        return bmax

    def solve_reachability(self, sign: int) -> OptimalTimeLaw:
        """The time objective by reachability analysis (:mod:`rrr4.optimal.reachability`); the
        law checked on both sides of every point, and solved again without pruning the rows
        should a constraint fail by more than 1e-6 (none has)."""
        N1 = len(self.fam.s)
        t0 = time.perf_counter()
        F, lo_f, hi_f, labels = self.function_array(sign)
        G, h, margin = point_rows(F, lo_f, hi_f, np.array([lab.startswith("contact") for lab in labels]))
        G2, h2 = project_out(G, h)
        X = np.minimum(self.speed_bounds(), X_CAP)
        build = time.perf_counter() - t0
        for prune_rows in (True, False):
            t1 = time.perf_counter()
            b = self._speeds(sign, G2, h2, X, prune_rows)
            a_seg = np.diff(b) * (N1 - 1) / 2.0
            sides = [np.r_[a_seg, a_seg[-1]], np.r_[a_seg[0], a_seg]]    # after and before each point
            alphas = [self._alpha(G, h, margin, a, b) for a in sides]
            solve_time = time.perf_counter() - t1
            worst = max((self._violation(F, lo_f, hi_f, a, b, al) for a, al in zip(sides, alphas, strict=True)),
                        key=lambda w: w[0])
            if worst[0] <= 1e-6:
                break
        ok = worst[0] <= 1e-6
        stats = {"solver": "reachability", "return_status": "Solve_Succeeded" if ok else "Constraint_Violation",
                 "success": ok, "build_time_s": build, "solve_time_s": solve_time, "points": N1, "sign": sign,
                 "pruned": prune_rows, "max_violation": worst[0], "worst_s": float(self.fam.s[worst[1]]),
                 "worst_constraint": labels[worst[2]]}
        law = self._law(sign, b, alphas[0], stats, one_sided=True)
        stats["objective_value"] = law.duration
        return law

    def _speeds(self, sign, G2, h2, X, prune_rows) -> np.ndarray:
        """b (N+1,) of the time-optimal law on the projected rows, or InfeasibleError."""
        fam, v0, v1 = self.fam, *self.ends
        b, where = time_optimal_speeds(G2, h2, 1.0 / (len(fam.s) - 1), X, v0**2, v1**2, prune_rows=prune_rows)
        if b is None:
            at = "s_dot at s = 0 is too fast to reach the end" if where == "start" else \
                f"none passes s = {fam.s[int(where.split()[1])]:.4g}"
            raise InfeasibleError(f"optimal time law: no law from s_dot {v0:g} to {v1:g} 1/s keeps every constraint "
                                  f"(sign {sign:+d}): {at}")
        if b.max() > 0.5 * X_CAP:
            raise SceneError(f"max_speed: None is not allowed for this path (nothing else bounds s_dot: it reaches "
                             f"{np.sqrt(b.max()):.3g} 1/s): give max_speed [1/s]")
        return b

    def _alpha(self, G, h, margin, a, b) -> np.ndarray:
        """alpha (N+1, m) at (a, b): the largest contact margin within the limits, or without
        the contact condition the preload weights' least effort clipped into them."""
        fam, m, N1 = self.fam, self.m, len(self.fam.s)
        preferred = np.zeros((N1, m))
        if m and not margin.any():
            n, tau = fam.tau_n[:, :, 0], fam.efforts(a, b, np.zeros((N1, fam.tau_n.shape[2])))
            W = self.weights
            preferred[:, 0] = -np.einsum("kn,n,kn->k", n, W, tau) / np.maximum(np.einsum("kn,n,kn->k", n, W, n),
                                                                                1e-300)
        return recover_alpha(G[2:], h - G[0] * a - G[1] * b, margin, preferred)

    @staticmethod
    def _violation(F, lo_f, hi_f, a, b, alpha):
        """(largest violation of lo_f <= F . (a, b, alpha, 1) <= hi_f, its point, its function)."""
        values = np.einsum("kfi,ki->kf", F, np.column_stack([a, b, alpha, np.ones(len(a))]))
        viol = np.maximum(lo_f - values, values - hi_f)
        k, f = np.unravel_index(int(np.argmax(viol)), viol.shape)
        return float(max(viol[k, f], 0.0)), int(k), int(f)

    def solve(self, sign: int) -> OptimalTimeLaw:
        fam, N1, m = self.fam, len(self.fam.s), self.m
        N = N1 - 1
        ds = 1.0 / N
        nv = 2 + m
        t0 = time.perf_counter()
        n_act = fam.tau_a.shape[1]
        # linear rows: each point is reached with the acceleration of the segment before it and
        # left with that of the segment after it: the constraints hold on both sides, one alpha
        efforts, coefs, scale, labels, lo_f, hi_f = self._functions(sign)
        A, g0 = self._rows(coefs, scale)
        F = len(coefs)
        lo = np.tile(lo_f, 2 * N1) - g0
        hi = np.tile(hi_f, 2 * N1) - g0
        X = ca.MX.sym("x", nv * N1)  # per point: b, c, alpha (grid-major: a banded KKT system)
        b, c = X[0::nv], X[1::nv]
        G = [ca.mtimes(ca.DM(sparse_to_casadi(A)), X)]
        G.append(c**2 - b)  # the relaxation c <= sqrt(b)
        lo, hi = np.r_[lo, np.full(N1, -np.inf)], np.r_[hi, np.zeros(N1)]
        amax = self.bounds["max_task_acceleration"]
        k2 = 2  # the task point's x, y
        a_seg = (b[1:] - b[:-1]) / (2 * ds)
        if amax is not None:
            ps, pss = ca.DM(fam.pose_s[:, :k2]), ca.DM(fam.pose_ss[:, :k2])
            for a in (ca.vertcat(a_seg, a_seg[-1]), ca.vertcat(a_seg[0], a_seg)):
                G.append(sum((ps[:, i] * a + pss[:, i] * b) ** 2 for i in range(k2)) / amax**2)
                lo, hi = np.r_[lo, np.full(N1, -np.inf)], np.r_[hi, np.ones(N1)]
        dt = 2 * ds / (c[:-1] + c[1:])  # segment durations
        time_total = ca.sum1(dt)
        if self.objective == "time":
            f = time_total
        else:
            # on each segment the mean of its two ends' weighted squared efforts
            T, t_0 = self._rows(efforts, list(np.sqrt(self.weights)))
            tau = ca.mtimes(ca.DM(sparse_to_casadi(T)), X) + t_0          # sqrt(w_i) tau_i, point-major
            sq = ca.reshape(tau**2, 2 * n_act, N1)
            right, left = ca.sum1(sq[:n_act, :]).T, ca.sum1(sq[n_act:, :]).T
            effort = ca.sum1(0.5 * (right[:-1] + left[1:]) * dt)
            if self.objective == "effort":
                f = effort
                G.append(time_total)
                lo, hi = np.r_[lo, self.duration], np.r_[hi, self.duration]
            else:
                f = time_total + self.effort_weight * effort
        G = ca.densify(ca.vertcat(*G))
        # bounds on the unknowns
        bmax = self.speed_bounds()
        lbx = np.zeros((nv, N1))
        ubx = np.vstack([bmax, np.sqrt(bmax), np.full((m, N1), np.inf)])
        lbx[2:] = -np.inf
        v0, v1 = self.ends
        for k, v in ((0, v0), (N, v1)):
            lbx[0, k] = ubx[0, k] = v**2
            lbx[1, k] = ubx[1, k] = v
        # start: a sine speed profile below the speed bounds; alpha 0
        shape = np.sin(np.pi * fam.s) + np.linspace(v0, v1, N1)
        x0 = np.zeros((nv, N1))
        x0[1] = np.minimum(shape, 0.9 * np.sqrt(np.minimum(bmax, 1e300)))
        x0[1, [0, N]] = v0, v1
        x0[0] = x0[1] ** 2
        solver = ca.nlpsol("optimal_time_law", "ipopt", {"x": X, "f": f, "g": G}, IPOPT_OPTIONS)
        build = time.perf_counter() - t0
        t1 = time.perf_counter()
        sol = solver(x0=x0.T.ravel(), lbx=lbx.T.ravel(), ubx=ubx.T.ravel(), lbg=lo, ubg=hi)
        solve_time = time.perf_counter() - t1
        st = solver.stats()
        x = np.array(sol["x"]).reshape(N1, nv).T
        stats = {"solver": "ipopt", "return_status": st["return_status"], "success": bool(st["success"]),
                 "iterations": int(st["iter_count"]), "build_time_s": build, "solve_time_s": solve_time,
                 "points": N1, "objective_value": float(sol["f"]), "sign": sign}
        law = self._law(sign, np.maximum(x[0], 0.0), x[2:].T, stats)
        gv = np.array(sol["g"]).ravel()
        viol = np.maximum(lo - gv, gv - hi)
        w = int(np.argmax(viol))
        n_lin = 2 * N1 * F
        if w < n_lin:
            point, label = w // (2 * F), labels[w % F]
        elif w < n_lin + N1:
            point, label = w - n_lin, "relaxation"
        elif amax is not None and w < n_lin + 3 * N1:
            point, label = (w - n_lin - N1) % N1, "task acceleration"
        else:
            point, label = N, "duration"
        stats.update(max_violation=float(max(viol.max(), 0.0)), worst_s=float(fam.s[point]), worst_constraint=label)
        return law

    def _law(self, sign, b, alpha, stats, one_sided=False) -> OptimalTimeLaw:
        fam = self.fam
        N1 = len(fam.s)
        N = N1 - 1
        ds = 1.0 / N
        sd = np.sqrt(b)
        a_seg = np.diff(b) / (2 * ds)
        a = np.r_[a_seg, a_seg[-1]]
        a_left = a if one_sided else np.r_[a_seg[0], a_seg]   # one_sided: TOPP-RA's scheme
        seg = 2 * ds / np.maximum(sd[:-1] + sd[1:], 1e-300)
        t = np.r_[0.0, np.cumsum(seg)]
        m_all = fam.tau_n.shape[2]
        alpha_full = np.zeros((N1, m_all))
        alpha_full[:, :self.m] = alpha
        tau, tau_left = fam.efforts(a, b, alpha_full), fam.efforts(a_left, b, alpha_full)
        r, r_left = fam.reactions(a, b, alpha_full), fam.reactions(a_left, b, alpha_full)
        axial = self._axial(r, sign) if m_all else np.zeros((N1, 0))
        axial_left = self._axial(r_left, sign) if m_all else np.zeros((N1, 0))
        binding = self._binding((tau, tau_left), (axial, axial_left), b, (a, a_left))
        return OptimalTimeLaw(
            objective=self.objective, t=t, s=fam.s, s_dot=sd, s_ddot=a, pose=fam.pose,
            pose_d=fam.pose_s * sd[:, None], pose_dd=fam.pose_s * a[:, None] + fam.pose_ss * b[:, None],
            alpha=alpha_full, efforts=tau, reactions=r, axial=np.minimum(axial, axial_left), binding=binding,
            duration=float(t[-1]), contact=self.contact, null_space=self.null_space, sign=sign if self.contact else 0,
            f_min=self.f_min, torque_limit=tuple(self.limits.tolist()), actuator_names=self.names,
            joint_names=self.joints, statistics=stats)

    def _binding(self, taus, axials, b, accs) -> tuple[str, ...]:
        """Per point the constraints whose relative slack (on either side of the point) is
        below BINDING_TOL, tightest first, joined by ', ' ('' where none binds)."""
        fam, k2, more = self.fam, 2, []  # the task point's x, y
        if self.bounds["max_speed"] is not None:
            more.append(((1.0 - b / self.bounds["max_speed"] ** 2)[:, None], ["speed"]))
        if self.bounds["max_task_speed"] is not None:
            v = np.sqrt(np.sum(fam.pose_s[:, :k2] ** 2, axis=1) * b)
            more.append(((1.0 - v / self.bounds["max_task_speed"])[:, None], ["task speed"]))
        if self.bounds["max_task_acceleration"] is not None:
            acc = np.maximum(*(np.linalg.norm(fam.pose_s[:, :k2] * a[:, None] + fam.pose_ss[:, :k2] * b[:, None],
                                              axis=1) for a in accs))
            more.append(((1.0 - acc / self.bounds["max_task_acceleration"])[:, None], ["task acceleration"]))
        return binding_labels(taus, self.limits, self.names, axials if self.contact else None, self.f_min,
                              self.joints, more)
