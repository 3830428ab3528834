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

import functools

import casadi as ca

from ..errors import SceneError
from ..mechanism.graph import Model
from ..scene import Scene
from .exact import constraint_violation

__all__ = ["qp_preload_function", "QP_OPTIONS"]

QP_OPTIONS = {
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False},
    "osqp": {"osqp": {"verbose": False, "eps_abs": 1e-10, "eps_rel": 1e-10, "polish": True, "max_iter": 10000},
             "error_on_fail": False},
    "daqp": {"error_on_fail": False},
    "qpoases": {"printLevel": "none", "error_on_fail": False},
}
# relative tolerance on the constraints when the result is marked feasible
FEASIBILITY_TOL = 1e-6


@functools.cache
def _qp_parts(f_min: float, weights: tuple[float, ...], limits: tuple[float, ...],
              signs: tuple[float, ...], m: int) -> tuple[ca.Function, ca.Function]:
    """SX Functions 'qp_data' (inputs -> H, g, A, lba, uba) and 'qp_result'
    (inputs, alpha -> tau, feasible, margin); n actuators, nj = len(signs) joints, m alphas."""
    n, nj = len(weights), len(signs)
    tau_p, tau_n = ca.SX.sym("tau_p", n), ca.SX.sym("tau_n", n, m)
    r_p, r_n = ca.SX.sym("r_p", 2, nj), ca.SX.sym("r_n", 2, nj * m)
    W, lim, sig = ca.diag(ca.DM(weights)), ca.DM(limits), ca.DM(signs)

    # QP data in alpha: H = 2 N^T W N, g = 2 N^T W tau_p; rows: joints, then actuators
    H = 2 * tau_n.T @ W @ tau_n
    g = 2 * tau_n.T @ W @ tau_p
    rows, lba, uba = [], [], []
    for j in range(nj):
        d = r_n[:, j] / ca.fmax(ca.norm_2(r_n[:, j]), 1e-300)
        rows.append(ca.horzcat(*[d.T @ r_n[:, j + nj * k] for k in range(m)]))
        bound = sig[j] * f_min - d.T @ r_p[:, j]
        lba.append(ca.if_else(sig[j] > 0, bound, -ca.inf))
        uba.append(ca.if_else(sig[j] > 0, ca.inf, bound))
    A = ca.vertcat(*rows, tau_n)
    lba = ca.vertcat(*lba, -lim - tau_p)
    uba = ca.vertcat(*uba, lim - tau_p)
    # unit row norms: qrqp otherwise cycles on nearly parallel active rows of different scale
    scale = 1.0 / ca.fmax(ca.sqrt(ca.sum2(A**2)), 1e-300)
    data = ca.Function("qp_data", [tau_p, tau_n, r_p, r_n], [H, g, A * scale, lba * scale, uba * scale])

    # result: torques, reactions, feasibility (axial sign constraints and limits) and margin
    alpha = ca.SX.sym("alpha", m)
    tau = tau_p + tau_n @ alpha
    r = r_p + sum((alpha[k] * r_n[:, nj * k: nj * (k + 1)] for k in range(1, m)), alpha[0] * r_n[:, :nj])
    # signed axial force sigma_j d_j . r_j [N]
    axial = ca.vertcat(*[sig[j] * ca.dot(r_n[:, j], r[:, j]) / ca.fmax(ca.norm_2(r_n[:, j]), 1e-300)
                         for j in range(nj)])
    margin, viol = constraint_violation(tau, r, f_min, limits)
    axial_viol = ca.mmax((f_min - axial) / max(f_min, 1e-12))
    feasible = ca.logic_and(ca.fmax(viol, axial_viol) <= FEASIBILITY_TOL, ca.sum1(alpha == alpha) == m)
    result = ca.Function("qp_result", [tau_p, tau_n, r_p, r_n, alpha],
                         [tau, ca.if_else(feasible, 1.0, 0.0), margin])
    return data, result


@functools.cache
def _build(solver: str, f_min: float, weights: tuple[float, ...], limits: tuple[float, ...],
           signs: tuple[float, ...], m: int) -> ca.Function:
    n, nj = len(weights), len(signs)
    data, result = _qp_parts(f_min, weights, limits, signs, m)
    qp = ca.conic("qp_preload_solver", solver, {"h": ca.Sparsity.dense(m, m), "a": ca.Sparsity.dense(nj + n, m)},
                  QP_OPTIONS[solver])
    ins = [ca.MX.sym("tau_p", n), ca.MX.sym("tau_n", n, m), ca.MX.sym("r_p", 2, nj), ca.MX.sym("r_n", 2, nj * m)]
    Hm, gm, Am, lbam, ubam = data(*ins)
    sol = qp(h=Hm, g=gm, a=Am, lba=lbam, uba=ubam)
    a_opt = sol["x"]
    tau_m, feas_m, margin_m = result(*ins, a_opt)
    return ca.Function("qp_preload", ins, [a_opt, tau_m, feas_m, margin_m],
                       ["tau_p", "tau_n", "r_p", "r_n"], ["alpha", "tau", "feasible", "margin"])


def qp_preload_function(scene: Scene, solver: str = "qrqp", signs=1.0, f_min: float | None = None) -> ca.Function:
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
    model = Model.of(scene.graph)
    m, nj = model.redundancy, len(model.preload_joints)
    if m < 1:
        raise SceneError(f"mechanism: a preload is not allowed without actuation redundancy ({model.n_actuators} "
                         f"actuators for a {model.task_dof}-DOF task)")
    s = [float(signs)] * nj if isinstance(signs, (int, float)) else [float(v) for v in signs]
    if len(s) != nj or any(v not in (1.0, -1.0) for v in s):
        raise SceneError(f"signs: {signs!r} is not allowed (+1 or -1, or a list of {nj} of them)")
    p = scene.actuation.preload
    fm = p.min_force if f_min is None else float(f_min)
    return _build(solver, float(fm), tuple(p.weights), tuple(scene.actuation.torque_limit), tuple(s), m)
