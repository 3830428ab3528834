"""`solve_preload`: the front door of the preload layer.

Samples the scene's path, evaluates the inverse dynamics (:mod:`rrr4.dynamics.inverse`)
at every sample with ``Function.map``, picks the null-space torques with the chosen
method and checks every sample again in numpy: ||r_j|| >= f_min at all passive joints,
|tau_i| <= L_i, a regular pose. Whatever fails is listed with time, joint and reason, a
:class:`PreloadWarning` is issued (or :class:`PreloadInfeasibleError` raised with
``strict=True``): never a silent wrong answer.

Which method for simulation: ``nlp`` (smooth, the contact force turns slowly in every
bearing) or ``qp`` (fixed force direction sign per joint, pointwise). ``exact`` is the
cheapest global optimum at each instant, but where two branches of the feasible set
cost the same (e.g. at rest, alpha = +-a) it may jump between them, which reverses the
contact forces; use it as the pointwise bound on effort, and for generated controllers
only where its alpha stays on one branch.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from ..checks import argument, unknown_value
from ..errors import Rrr4Error, SceneError
from ..mechanism.workspace import near_singular, path_kinematics
from ..problem import Problem
from ..scene import MAX_SAMPLES, Scene
from ..scene.vocabulary import PRELOAD_METHODS as PRELOAD_METHOD_NAMES
from ..scene.vocabulary import registry
from ..trajectory import sample_path
from .exact import exact_preload_function
from .nlp import solve_trajectory_nlp
from .qp import FEASIBILITY_TOL as QP_FEASIBILITY_TOL
from .qp import QP_OPTIONS, qp_preloads
from .signs import choose_signs
from .solution import Infeasibility, PreloadSolution, effort_excess

__all__ = ["solve_preload", "PreloadWarning", "PreloadInfeasibleError", "FEASIBILITY_TOL"]

# relative tolerance of the final check (f_min and torque limits); the QP marks its own result with the same
FEASIBILITY_TOL = QP_FEASIBILITY_TOL
# relative f_min increase for the NLP on a grid coarser than the samples
COARSE_GRID_MARGIN = 0.02


@dataclass(frozen=True)
class _Options:
    """What a method takes besides the problem, the effort family and the samples."""
    solver: str
    signs: object
    branch: int | str
    nlp_rate: float | None
    f_min: float
    limits: np.ndarray


def _exact(problem: Problem, fam, samples, o: _Options):
    """The closed form at every sample, on `branch` (0: the global optimum; 'auto': the branch
    feasible at more samples)."""
    raw, branch = fam.raw, o.branch
    if branch == "auto":
        branch, alpha, feas = choose_signs(problem, raw, o.solver, exact=True)
        branch = int(branch)
    else:
        f = exact_preload_function(problem, branch=branch).map(len(samples.t))
        alpha, _, feas, _ = (np.array(v) for v in f(*raw))
    return alpha.T, feas.ravel() > 0.5, {"solver": "closed form", "branch": branch}


def _qp(problem: Problem, fam, samples, o: _Options):
    """The conic QP at every sample with fixed axial-force signs (default: the uniform sign
    feasible at more samples)."""
    if o.signs is None:
        used, alpha, feas = choose_signs(problem, fam.raw, o.solver)
    else:
        used = o.signs
        alpha, _, feas, _ = qp_preloads(problem, o.solver, o.signs, fam.raw)
    return alpha.T, feas.ravel() > 0.5, {"solver": o.solver, "signs": used}


def _nlp(problem: Problem, fam, samples, o: _Options):
    """The horizon NLP from the QP's law, on the samples or a coarser grid (alpha interpolated between its points)."""
    scene, pre = problem.scene, problem.scene.actuation.preload
    N, m = len(samples.t), problem.model.redundancy
    used, alpha0, _ = choose_signs(problem, fam.raw, o.solver)
    grid = np.arange(N)
    if o.nlp_rate is not None:
        step = max(1, int(round((N - 1) / max(scene.path.duration * o.nlp_rate, 1))))
        grid = np.unique(np.r_[np.arange(0, N, step), N - 1])
    a0 = np.nan_to_num(alpha0.T[grid])
    # on a coarser grid, aim a little above f_min so the interpolated samples keep it
    f_grid = o.f_min * (1.0 + COARSE_GRID_MARGIN) if len(grid) < N else o.f_min
    a_grid, nstats = solve_trajectory_nlp(
        samples.t[grid], fam.tau_p[grid], fam.tau_n[grid], fam.r_p[grid], fam.r_n[grid], f_min=f_grid,
        weights=pre.weights, limits=o.limits, smoothness_weight=pre.smoothness_weight,
        max_turn_rate=pre.max_turn_rate, alpha0=a0)
    alpha = np.column_stack([np.interp(samples.t, samples.t[grid], a_grid[:, k]) for k in range(m)])
    return alpha, np.full(N, bool(nstats["success"])), {**nstats, "initial_guess": f"qp ({o.solver}, sign {used:+g})"}


@dataclass(frozen=True)
class _Method:
    redundancy: int | None  # the largest degree of redundancy it handles (None: any)
    along: object           # (problem, family, samples, options) -> (alpha (N, m), ok (N,), statistics)


# one entry per method of the scene's vocabulary (a method without an entry fails the house-rule test)
PRELOAD_METHODS = registry(PRELOAD_METHOD_NAMES, {"exact": _Method(1, _exact), "qp": _Method(None, _qp),
                                                  "nlp": _Method(None, _nlp)})


class PreloadWarning(UserWarning):
    """Some path samples could not be preloaded; see PreloadSolution.report()."""


class PreloadInfeasibleError(Rrr4Error, RuntimeError):
    """solve_preload(..., strict=True) found samples that cannot be preloaded."""


def solve_preload(scene: Scene | Problem, method: str | None = None, *, qp_solver: str | None = None, signs=None,
                  branch: int | str = 0, sample_rate: float | None = None, nlp_rate: float | None = None,
                  strict: bool = False) -> PreloadSolution:
    """Preload torques along the scene's path.

    method: 'exact', 'qp' or 'nlp' (default ``actuation.preload.method``). qp_solver:
    conic plugin for 'qp' (default the scene's; qrqp, osqp, daqp, qpoases). signs: fixed
    axial-force sign for 'qp' (+1, -1 or one per passive joint; default: the uniform sign
    feasible at more samples). branch for 'exact': 0 = global optimum at every sample
    (may jump between the +-alpha branches), +1 / -1 = alpha >= 0 / <= 0, 'auto' = the
    branch feasible at more samples, ties -> less effort. sample_rate [Hz]: path samples (default the scene's).
    nlp_rate [Hz]: grid of the horizon NLP (default: every sample); alpha is interpolated
    linearly between its points and every sample is checked.
    strict: raise PreloadInfeasibleError instead of warning when a sample is infeasible.
    scene: a Scene or its built :class:`~rrr4.problem.Problem`.
    """
    problem = Problem.from_scene(scene)
    scene = problem.scene
    pre = scene.actuation.preload
    method = pre.method if method is None else method
    if method not in PRELOAD_METHODS:
        raise unknown_value("method", "value", method, PRELOAD_METHODS)
    solver = pre.qp_solver if qp_solver is None else qp_solver
    if solver not in QP_OPTIONS:
        raise unknown_value("qp_solver", "value", solver, QP_OPTIONS)
    if sample_rate is not None:
        sample_rate = argument("sample_rate", sample_rate)
        if scene.path.duration * sample_rate > MAX_SAMPLES:
            raise SceneError(f"sample_rate: {sample_rate:g} Hz is not allowed (at most {MAX_SAMPLES:g} samples over "
                             f"{scene.path.duration:g} s)")
    if nlp_rate is not None:
        nlp_rate = argument("nlp_rate", nlp_rate)
    model = problem.model
    m = model.redundancy
    if m < 1:
        raise SceneError(f"mechanism: redundancy {m} is not allowed for a preload (needs more actuators than "
                         f"the task's {model.task_dof} degrees of freedom)")
    most = PRELOAD_METHODS[method].redundancy
    if most is not None and m > most:
        raise SceneError(f"method: {method!r} handles redundancy <= {most}, the scene has {m} (choose one of: "
                         f"{', '.join(k for k, v in PRELOAD_METHODS.items() if (v.redundancy or m) >= m)})")
    samples = sample_path(scene.path, sample_rate)
    N = len(samples.t)
    f_min, limits = pre.min_force, np.asarray(problem.torque_limit, float)
    t_start = time.perf_counter()
    fam = problem.effort_family(samples.pose, samples.pose_d, samples.pose_dd)
    tau_p, tau_n, r_p, r_n = fam.tau_p, fam.tau_n, fam.r_p, fam.r_n
    alpha, method_ok, stats = PRELOAD_METHODS[method].along(
        problem, fam, samples, _Options(solver, signs, branch, nlp_rate, f_min, limits))
    stats = {"method": method, "points": N, **stats}
    stats["wall_time"] = time.perf_counter() - t_start
    stats["time_per_point"] = stats["wall_time"] / N

    alpha = np.asarray(alpha, float).reshape(N, m)
    solver_failed = ~np.all(np.isfinite(alpha), axis=1)
    alpha[solver_failed] = 0.0
    tau = tau_p + np.einsum("knm,km->kn", tau_n, alpha)
    reactions = r_p + np.einsum("kjcm,km->kjc", r_n, alpha)
    norms = np.linalg.norm(reactions, axis=2)
    margin = norms.min(axis=1) - f_min
    singular = near_singular(scene.path, path_kinematics(problem.mechanism, samples))
    finite = np.all(np.isfinite(tau), axis=1) & np.all(np.isfinite(norms), axis=1)
    # non-finite samples (unreachable or singular pose) are flagged below and zeroed
    tau[~finite], reactions[~finite] = 0.0, 0.0
    norms = np.linalg.norm(reactions, axis=2)
    margin = np.where(finite, margin, -f_min)
    force_ok = norms >= f_min * (1 - FEASIBILITY_TOL)
    torque_ok = np.abs(tau) <= limits * (1 + FEASIBILITY_TOL)
    feasible = (method_ok & ~solver_failed & finite & (singular == "") & force_ok.all(axis=1) & torque_ok.all(axis=1))

    names = model.preload_joints
    units = problem.effort_units
    issues: list[Infeasibility] = []
    for k in np.flatnonzero(~feasible):
        tk = float(samples.t[k])
        if singular[k]:
            issues.append(Infeasibility(tk, "pose", singular[k]))
        if not finite[k] or solver_failed[k]:
            issues.append(Infeasibility(tk, "pose", "inverse dynamics or solver returned non-finite values"))
        for j in np.flatnonzero(~force_ok[k]):
            issues.append(Infeasibility(tk, names[j], f"|r| = {norms[k, j]:.4g} N < f_min = {f_min:g} N "
                                                      f"(no preload within the torque limits reaches it)",
                                        f_min - norms[k, j]))
        for i in np.flatnonzero(~torque_ok[k]):
            issues.append(Infeasibility(tk, f"actuator {model.actuator_names[i]}",
                                        f"|tau| = {abs(tau[k, i]):.4g} {units[i]} > limit {limits[i]:g} {units[i]}",
                                        abs(tau[k, i]) - limits[i]))
        if not issues or issues[-1].t != tk:
            reason = ("the fixed-sign axial force constraints cannot all hold within the torque limits"
                      if method == "qp" else f"solver did not converge ({stats.get('return_status')})")
            issues.append(Infeasibility(tk, "all", reason))

    sol = PreloadSolution(
        method=method, t=samples.t, pose=samples.pose, pose_d=samples.pose_d, pose_dd=samples.pose_dd,
        tau=tau, alpha=alpha[:, 0] if m == 1 else alpha, reactions=reactions, feasible=feasible, margin=margin,
        tau_particular=tau_p, null_space=tau_n[:, :, 0] if m == 1 else tau_n, f_min=f_min,
        torque_limit=tuple(limits.tolist()), joint_names=names, infeasible=tuple(issues), statistics=stats,
        effort_excess=effort_excess(samples.t, tau, limits, ~torque_ok, model.actuator_names, units))
    if issues:
        if strict:
            raise PreloadInfeasibleError(sol.report())
        warnings.warn(sol.report(), PreloadWarning, stacklevel=2)
    return sol
