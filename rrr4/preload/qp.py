"""Pointwise preload as a QP over the null-space parameters alpha (m = n - 3 of them).

    minimise    (tau_p + N alpha)^T W (tau_p + N alpha)
    subject to  sigma_j d_j . r_j(alpha) >= f_min     for every passive joint j,
                -L <= tau_p + N alpha <= L,

with N = tau_n (n x m) and r_j(alpha) = r_p[:, j] + sum_k alpha_k r_n[:, j + 2n k].
The null-space reactions are axial forces in the following links
(:mod:`rrr4.dynamics.inverse`), so d_j = r_n[:, j] / |r_n[:, j]| is the direction of
following link i2 (for both B_i and C_i), oriented the way the first null-space
direction pushes. The component of r_j along d_j is the link's axial force; requiring it
to keep the fixed sign sigma_j with magnitude >= f_min (which implies ||r_j|| >= f_min)
keeps the contact force in each bearing from reversing, at the price of a smaller
feasible set than the exact method's. sigma_j = +1 for all joints means "preloaded the
way positive alpha pushes" (:func:`rrr4.preload.solve.solve_preload` picks the sign).

Solved with ``casadi.conic``: qrqp (default, supports C code generation), osqp, daqp or
qpoases.
"""

from __future__ import annotations

import contextlib
import functools

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..functions import fix_last_input, solver_output_captured
from ..problem import Problem
from ..scene.vocabulary import QP_SOLVERS, registry
from .exact import constraint_violation

__all__ = ["qp_preload_function", "qp_preloads", "scalar_qp_preload_function", "parametric_scalar_qp_preload",
           "QP_OPTIONS"]

_OPTIONS = {
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False},
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-10, "eps_rel": 1e-10, "polish": True, "max_iter": 10000},
             "error_on_fail": False},
    "daqp": {"error_on_fail": False},
    "qpoases": {"printLevel": "none", "error_on_fail": False},
}
QP_OPTIONS = registry(QP_SOLVERS, _OPTIONS)  # the registry, by the scene's vocabulary
# relative tolerance on the constraints when the result is marked feasible
FEASIBILITY_TOL = 1e-6


@functools.lru_cache(maxsize=16)  # per size
def _qp_parts(n: int, nj: int, m: int) -> tuple[ca.Function, ca.Function]:
    """SX Functions 'qp_data' (inputs, settings -> H, g, A, lba, uba; rows unscaled, upper
    bounds of the joint rows infinite) and 'qp_result' (inputs, settings, alpha -> tau,
    feasible, margin); n actuators, nj joints, m alphas. settings: weights (n), torque
    limits (n) [N m], f_min [N], signs (nj) (+1 / -1 each)."""
    tau_p, tau_n = ca.SX.sym("tau_p", n), ca.SX.sym("tau_n", n, m)
    r_p, r_n = ca.SX.sym("r_p", 2, nj), ca.SX.sym("r_n", 2, nj * m)
    settings = ca.SX.sym("settings", 2 * n + 1 + nj)
    w, lim, f_min, sig = settings[:n], settings[n:2 * n], settings[2 * n], settings[2 * n + 1:]
    W = ca.diag(w)

    # QP data in alpha: H = 2 N^T W N, g = 2 N^T W tau_p; rows: joints (sigma_j d_j . r_j >=
    # f_min, multiplied through by sigma_j so that the sign is a number, not a structure), then actuators
    H = 2 * tau_n.T @ W @ tau_n
    g = 2 * tau_n.T @ W @ tau_p
    rows, bounds = [], []
    for j in range(nj):
        d = r_n[:, j] / ca.fmax(ca.norm_2(r_n[:, j]), 1e-300)
        rows.append(sig[j] * ca.horzcat(*[d.T @ r_n[:, j + nj * k] for k in range(m)]))
        bounds.append(f_min - sig[j] * d.T @ r_p[:, j])
    A = ca.vertcat(*rows, tau_n)
    lba = ca.vertcat(*bounds, -lim - tau_p)
    uba = ca.vertcat(ca.DM.inf(nj), lim - tau_p)
    data = ca.Function("qp_data", [tau_p, tau_n, r_p, r_n, settings], [H, g, A, lba, uba])

    # result: torques, reactions, feasibility (axial sign constraints and limits) and margin
    alpha = ca.SX.sym("alpha", m)
    tau = tau_p + tau_n @ alpha
    r = r_p + sum((alpha[k] * r_n[:, nj * k: nj * (k + 1)] for k in range(1, m)), alpha[0] * r_n[:, :nj])
    # signed axial force sigma_j d_j . r_j [N]
    axial = ca.vertcat(*[sig[j] * ca.dot(r_n[:, j], r[:, j]) / ca.fmax(ca.norm_2(r_n[:, j]), 1e-300)
                         for j in range(nj)])
    margin, viol = constraint_violation(tau, r, f_min, lim)
    axial_viol = ca.mmax((f_min - axial) / ca.fmax(f_min, 1e-12))
    feasible = ca.logic_and(ca.fmax(viol, axial_viol) <= FEASIBILITY_TOL, ca.sum1(alpha == alpha) == m)
    result = ca.Function("qp_result", [tau_p, tau_n, r_p, r_n, settings, alpha],
                         [tau, ca.if_else(feasible, 1.0, 0.0), margin])
    return data, result


@functools.lru_cache(maxsize=64)
def _build(solver: str, f_min: float, weights: tuple[float, ...], limits: tuple[float, ...],
           signs: tuple[float, ...], m: int) -> ca.Function:
    n, nj = len(weights), len(signs)
    data, result = _qp_parts(n, nj, m)
    settings = ca.DM([*weights, *limits, f_min, *signs])
    with solver_output_captured() if solver == "qpoases" else contextlib.nullcontext():  # its banner (see qp_preloads)
        qp = ca.conic("qp_preload_solver", solver, {"h": ca.Sparsity.dense(m, m), "a": ca.Sparsity.dense(nj + n, m)},
                      QP_OPTIONS[solver])
    ins = [ca.MX.sym("tau_p", n), ca.MX.sym("tau_n", n, m), ca.MX.sym("r_p", 2, nj), ca.MX.sym("r_n", 2, nj * m)]
    Hm, gm, Am, lbam, ubam = data(*ins, settings)
    # unit row norms: qrqp otherwise cycles on nearly parallel active rows of different scale
    scale = 1.0 / ca.fmax(ca.sqrt(ca.sum2(Am**2)), 1e-300)
    sol = qp(h=Hm, g=gm, a=Am * scale, lba=lbam * scale, uba=ubam * scale)
    a_opt = sol["x"]
    tau_m, feas_m, margin_m = result(*ins, settings, a_opt)
    return ca.Function("qp_preload", ins, [a_opt, tau_m, feas_m, margin_m],
                       ["tau_p", "tau_n", "r_p", "r_n"], ["alpha", "tau", "feasible", "margin"])


def qp_preload_function(problem: Problem, solver: str = "qrqp", signs=1.0, f_min: float | None = None) -> ca.Function:
    """MX Function 'qp_preload' (a plain ``casadi.conic`` call):
    tau_p (n,) [N m], tau_n (n, n-3), r_p (2, 2n) [N], r_n (2, 2n (n-3)) [N] ->
    alpha (n-3,) [N m], tau (n,) [N m], feasible (1.0 / 0.0), margin [N] = min_j ||r_j|| - f_min.

    solver: one of qrqp, osqp, daqp, qpoases. signs: +1 or -1, scalar or one per passive
    joint B1..Bn, C1..Cn, the fixed sign of each joint's axial force relative to the
    positive null-space preload. feasible means every constraint holds within a relative
    1e-6. Weights, limits and f_min (default ``actuation.preload.min_force``) from the scene.
    """
    if solver not in QP_OPTIONS:
        raise SceneError(f"actuation.preload.qp_solver: unknown value {solver!r} "
                         f"(choose one of: {', '.join(QP_OPTIONS)})")
    model = problem.model
    m, nj = model.redundancy, len(model.preload_joints)
    if m < 1:
        raise SceneError(f"mechanism: a preload is not allowed without actuation redundancy ({model.n_actuators} "
                         f"actuators for a {model.task_dof}-DOF task)")
    s = [float(signs)] * nj if isinstance(signs, (int, float)) else [float(v) for v in signs]
    if len(s) != nj or any(v not in (1.0, -1.0) for v in s):
        raise SceneError(f"signs: {signs!r} is not allowed (+1 or -1, or a list of {nj} of them)")
    p = problem.scene.actuation.preload
    fm = p.min_force if f_min is None else float(f_min)
    return _build(solver, float(fm), tuple(p.weights), problem.torque_limit, tuple(s), m)


def qp_preloads(problem: Problem, solver: str, signs, raw) -> tuple[np.ndarray, ...]:
    """(alpha, tau, feasible, margin) of :func:`qp_preload_function` at every column of the
    effort family `raw` (``EffortFamily.raw``: tau_p (n, N), ...), in one mapped call. qpOASES
    prints its banner whenever a solver memory is made (at the first call of a Function that
    holds it), whatever its printLevel: captured here."""
    f = qp_preload_function(problem, solver, signs).map(raw[0].shape[1])
    with solver_output_captured() if solver == "qpoases" else contextlib.nullcontext():
        return tuple(np.array(v) for v in f(*raw))


_BIG = 1e30  # stands for an infinite bound in the closed-form QP


@functools.lru_cache(maxsize=64)
def _fixed_scalar(f_min: float, weights: tuple[float, ...], limits: tuple[float, ...],
                  signs: tuple[float, ...]) -> ca.Function:
    return fix_last_input(parametric_scalar_qp_preload(len(weights), len(signs)), [*weights, *limits, f_min, *signs])


@functools.lru_cache(maxsize=16)  # per size
def parametric_scalar_qp_preload(n: int, nj: int) -> ca.Function:
    """The law of :func:`scalar_qp_preload_function` with the input ``settings`` last:
    weights (n), torque limits (n) [N m], f_min [N], and the axial-force sign of each of the nj
    joints (+1 or -1)."""
    data, result = _qp_parts(n, nj, 1)
    tau_p, tau_n = ca.SX.sym("tau_p", n), ca.SX.sym("tau_n", n, 1)
    r_p, r_n = ca.SX.sym("r_p", 2, nj), ca.SX.sym("r_n", 2, nj)
    settings = ca.SX.sym("settings", 2 * n + 1 + nj)
    H, g, A, lba, uba = data(tau_p, tau_n, r_p, r_n, settings)

    def box(rows):
        """[lo, hi] of alpha from the rows (a alpha in [lb, ub]); a row with a ~ 0 bounds nothing."""
        lo, hi = -_BIG, _BIG
        for k in rows:
            a = A[k]
            safe = ca.if_else(a >= 0, 1.0, -1.0) * ca.fmax(ca.fabs(a), 1e-300)
            # infinite bounds clamped first: inf / a would make the derivative (inf * da) NaN
            b1, b2 = ca.fmax(lba[k], -_BIG) / safe, ca.fmin(uba[k], _BIG) / safe
            active = ca.fabs(a) > 1e-12
            lo = ca.if_else(active, ca.fmax(lo, ca.if_else(a > 0, b1, b2)), lo)
            hi = ca.if_else(active, ca.fmin(hi, ca.if_else(a > 0, b2, b1)), hi)
        return lo, hi

    lo_f, hi_f = box(range(nj))              # the contact rows
    lo_t, hi_t = box(range(nj, nj + n))      # the actuator limits
    lo, hi = ca.fmax(lo_f, lo_t), ca.fmin(hi_f, hi_t)
    x0 = -g / ca.fmax(H, 1e-300)
    # feasible: the QP's unique optimum; else keep the contact rows and let the limits go
    ok = lo <= hi
    alpha = ca.if_else(ok, ca.fmin(ca.fmax(x0, lo), hi), ca.fmin(ca.fmax(x0, lo_f), hi_f))
    tau, _, margin = result(tau_p, tau_n, r_p, r_n, settings, alpha)
    feasible = ca.if_else(ok, 1.0, 0.0)
    return ca.Function("qp_preload", [tau_p, tau_n, r_p, r_n, settings], [alpha, tau, feasible, margin],
                       ["tau_p", "tau_n", "r_p", "r_n", "settings"], ["alpha", "tau", "feasible", "margin"])


def scalar_qp_preload_function(problem: Problem, signs=1.0) -> ca.Function:
    """The QP of :func:`qp_preload_function` for one degree of redundancy, solved in closed
    form: SX Function 'qp_preload' with the same inputs and outputs, no solver, no iterations.

    With one unknown every constraint row a alpha in [lb, ub] is an interval of alpha, so
    the optimum is the unconstrained minimiser -g/H clipped to the intersection [lo, hi]
    of the intervals (the QP's unique solution, strictly convex). When [lo, hi] is empty
    (feasible = 0) alpha keeps the contact rows and leaves the torque limits to the
    controller's clipping. Code-generable and cheap enough for a controller step.
    """
    model = problem.model
    if model.redundancy != 1:
        raise SceneError(f"actuation.preload.method: the closed-form QP needs one degree of actuation redundancy, "
                         f"the scene has {model.redundancy} (use qp_preload_function)")
    nj = len(model.preload_joints)
    s = [float(signs)] * nj if isinstance(signs, (int, float)) else [float(v) for v in signs]
    if len(s) != nj or any(v not in (1.0, -1.0) for v in s):
        raise SceneError(f"signs: {signs!r} is not allowed (+1 or -1, or a list of {nj} of them)")
    p = problem.scene.actuation.preload
    return _fixed_scalar(float(p.min_force), tuple(p.weights), problem.torque_limit, tuple(s))
