"""Exact pointwise preload of the 4-RRR: global optimum over the scalar null-space parameter.

At one instant the passive reactions are r_j(alpha) = r_p[:, j] + alpha r_n[:, j]
(:func:`rrr4.dynamics.inverse.inverse_dynamics_function`). Each contact condition
||r_j|| >= f_min is the quadratic inequality

    a_j alpha^2 + b_j alpha + c_j >= 0,  a_j = |r_n,j|^2 >= 0,  b_j = 2 r_p,j . r_n,j,
    c_j = |r_p,j|^2 - f_min^2,

violated only strictly between its two real roots, so the feasible set is a union of
intervals; the actuator limits |tau_i| <= L_i cut it to a box [lo, hi]. The weighted
effort sum_i w_i tau_i^2 is a convex quadratic in alpha, so its minimum over that set is
the box-clipped unconstrained minimiser or an interval end: a root or a box end. All
candidates are evaluated and the feasible one with the least effort wins (if_else
selection, no solver, code-generable). If none is feasible the candidate with the least
violation is returned with feasible = 0.
"""

from __future__ import annotations

import functools

import casadi as ca

from ..scene import Scene

__all__ = ["exact_preload_function", "constraint_violation"]

# Roots are pushed this far (relative) to the feasible side so that rounding cannot put
# a boundary candidate inside the forbidden interval.
_ROOT_NUDGE = 1e-12
_TINY = 1e-300


def constraint_violation(tau, r, f_min: float, limits):
    """(margin, violation) of torques tau (n,) and reactions r (2, 2n), SX or numeric.

    margin = min_j ||r_j|| - f_min [N]; violation >= 0 is the largest shortfall relative to
    its bound: max(f_min - ||r_j||)/f_min over joints and (|tau_i| - L_i)/L_i over actuators.
    """
    norms = ca.sqrt(ca.sum1(r**2)).T
    margin = ca.mmin(norms) - f_min
    lim = ca.DM(limits)
    force_gap = (f_min - norms) / max(f_min, 1e-12)
    torque_gap = (ca.fabs(tau) - lim) / lim
    return margin, ca.fmax(0, ca.fmax(ca.mmax(force_gap), ca.mmax(torque_gap)))


@functools.cache
def _build(f_min: float, weights: tuple[float, ...], limits: tuple[float, ...], branch: int = 0) -> ca.Function:
    n = len(weights)
    nj = 2 * n
    tau_p, tau_n = ca.SX.sym("tau_p", n), ca.SX.sym("tau_n", n, 1)
    r_p, r_n = ca.SX.sym("r_p", 2, nj), ca.SX.sym("r_n", 2, nj)
    w, lim = ca.DM(weights), ca.DM(limits)
    big = ca.inf

    # box from the actuator limits: -L <= tau_p + alpha tau_n <= L
    lo, hi = -big, big
    for i in range(n):
        tn = tau_n[i]
        safe = ca.if_else(tn >= 0, 1.0, -1.0) * ca.fmax(ca.fabs(tn), _TINY)
        a1, a2 = (-lim[i] - tau_p[i]) / safe, (lim[i] - tau_p[i]) / safe
        active = ca.fabs(tn) > 1e-14
        lo = ca.if_else(active, ca.fmax(lo, ca.fmin(a1, a2)), lo)
        hi = ca.if_else(active, ca.fmin(hi, ca.fmax(a1, a2)), hi)
    if branch > 0:
        lo = ca.fmax(lo, 0.0)
    elif branch < 0:
        hi = ca.fmin(hi, 0.0)

    # unconstrained minimiser of sum w_i (tau_p,i + alpha tau_n,i)^2, clipped to the box
    den = ca.dot(w, tau_n**2)
    alpha_free = -ca.dot(w, tau_p * tau_n) / ca.fmax(den, _TINY)
    cands = [ca.fmin(ca.fmax(alpha_free, lo), hi), lo, hi]
    valid = [ca.SX(1), lo > -big, hi < big]
    for j in range(nj):
        a = ca.sumsqr(r_n[:, j])
        b = 2 * ca.dot(r_p[:, j], r_n[:, j])
        c = ca.sumsqr(r_p[:, j]) - f_min**2
        disc = b**2 - 4 * a * c
        ok = ca.logic_and(a > 1e-14 * (1 + ca.fabs(c)), disc >= 0)
        sq = ca.sqrt(ca.fmax(disc, 0))
        a2 = 2 * ca.fmax(a, _TINY)
        for sgn in (-1.0, 1.0):
            root = (-b + sgn * sq) / a2
            cands.append(root + sgn * _ROOT_NUDGE * (1 + ca.fabs(root)))
            valid.append(ok)

    best = None
    for alpha, ok in zip(cands, valid, strict=True):
        alpha = ca.if_else(ok, alpha, 0.0)
        tau = tau_p + alpha * tau_n
        r = r_p + alpha * r_n
        margin, viol = constraint_violation(tau, r, f_min, limits)
        cost = ca.dot(w, tau**2)
        in_box = ca.logic_and(alpha >= lo - 1e-12 * (1 + ca.fabs(alpha)), alpha <= hi + 1e-12 * (1 + ca.fabs(alpha)))
        feas = ca.logic_and(ca.logic_and(ok, in_box), viol <= 1e-9)
        viol = ca.if_else(ok, viol, big)
        if best is None:
            best = [alpha, tau, feas, margin, cost, viol]
            continue
        b_alpha, b_tau, b_feas, b_margin, b_cost, b_viol = best
        better = ca.if_else(feas, ca.logic_or(ca.logic_not(b_feas), cost < b_cost),
                            ca.logic_and(ca.logic_not(b_feas), viol < b_viol))
        best = [ca.if_else(better, x, y) for x, y in zip([alpha, tau, feas, margin, cost, viol], best, strict=True)]
    alpha, tau, feas, margin = best[:4]
    return ca.Function("exact_preload", [tau_p, tau_n, r_p, r_n], [alpha, tau, ca.if_else(feas, 1.0, 0.0), margin],
                       ["tau_p", "tau_n", "r_p", "r_n"], ["alpha", "tau", "feasible", "margin"])


def exact_preload_function(scene: Scene, f_min: float | None = None, branch: int = 0) -> ca.Function:
    """SX Function 'exact_preload' for a 4-RRR scene:
    tau_p (4,) [N m], tau_n (4, 1), r_p (2, 8) [N], r_n (2, 8) [N] ->
    alpha [N m], tau (4,) [N m], feasible (1.0 / 0.0), margin [N] = min_j ||r_j|| - f_min.

    f_min (default ``actuation.preload.min_force``), weights and torque limits come from
    the scene. Global optimum of sum_i w_i tau_i^2 subject to ||r_j|| >= f_min at all
    eight passive joints and |tau_i| <= L_i. branch = +1 (-1) restricts the preload to
    alpha >= 0 (<= 0): still closed form, and continuous along a path where the global
    optimum would jump between the two branches of equal cost. Cached per arguments.
    """
    if scene.mechanism.n_chains != 4:
        from ..errors import SceneError
        raise SceneError(f"mechanism.chains: {scene.mechanism.n_chains} chains is not allowed for the exact preload "
                         "(it needs one degree of redundancy: 4 chains)")
    p = scene.actuation.preload
    fm = p.min_force if f_min is None else float(f_min)
    if branch not in (0, 1, -1):
        from ..errors import SceneError
        raise SceneError(f"branch: {branch!r} is not allowed (0 for both, +1 or -1)")
    return _build(float(fm), tuple(p.weights), tuple(scene.actuation.torque_limit), int(branch))
