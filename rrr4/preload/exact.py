"""Exact pointwise preload of the 4-RRR: global optimum over the scalar null-space parameter.

At one instant the passive reactions are r_j(alpha) = r_p[:, j] + alpha r_n[:, j]
(:func:`rrr4.dynamics.inverse.inverse_dynamics_function`). Each contact condition
||r_j|| >= f_min is the quadratic inequality

    a_j alpha^2 + b_j alpha + c_j >= 0,  a_j = |r_n,j|^2 >= 0,  b_j = 2 r_p,j . r_n,j,
    c_j = |r_p,j|^2 - f_min^2,

violated only on the open interval (l_j, u_j) between its two real roots (or nowhere, or,
if r_n,j = 0 and c_j < 0, everywhere). The feasible set F is the box [lo, hi] from the
actuator limits |tau_i| <= L_i (and the branch, alpha >= 0 or <= 0) minus these
intervals: a union of closed intervals.

The weighted effort sum_i w_i tau_i^2 = D (alpha - alpha*)^2 + const (D > 0) grows with
the distance to its minimiser alpha*, so with x0 = alpha* clipped to the box the optimum
over F is the better of R = min(F ∩ [x0, inf)) and L = max(F ∩ (-inf, x0]) (if
alpha* > hi then x0 = hi and L is best, and vice versa). R is the fixed point of

    x <- max(x, max {u_j : l_j < x}),   x = x0 at the start.

Proof: (i) x <= R throughout: if l_j < x <= R then R, being feasible, is not in
(l_j, u_j), so R >= u_j. (ii) Every step that moves x adds at least one j with l_j < x
to the set of such j, so after 2n = 8 steps (one per joint) x no longer moves. (iii) A
fixed point lies in no interval and x >= x0, so x is joint-feasible, and by (i) x = R
if x <= hi; if x > hi there is no feasible point right of x0. L is the mirror image
(x <- min(x, min {l_j : u_j > x})). So the law is closed form: 8 roots and 2 x 8
compare-and-select passes, no solver, code-generable (Zhang & Zhang 2017 state the
problem; the interval argument is ours).

If F is empty the law returns, with feasible = 0, whichever of R and L clipped to the
box (on the branch's side of 0 if the box is empty) has the smaller relative violation
(:func:`constraint_violation`): the torques stay within the limits where the branch
allows it and alpha never leaves the branch.
"""

from __future__ import annotations

import functools

import casadi as ca

from ..errors import SceneError
from ..functions import fix_last_input
from ..problem import Problem

__all__ = ["exact_preload_function", "parametric_exact_preload", "constraint_violation"]

# Roots are pushed this far (relative) to the feasible side so that rounding cannot put
# a boundary point inside the forbidden interval.
_ROOT_NUDGE = 1e-12
_TINY = 1e-300


def constraint_violation(tau, r, f_min: float, limits):
    """(margin, violation) of torques tau (n,) and reactions r (2, 2n), SX or numeric.

    margin = min_j ||r_j|| - f_min [N]; violation >= 0 is the largest shortfall relative to
    its bound: max(f_min - ||r_j||)/f_min over joints and (|tau_i| - L_i)/L_i over actuators.
    One square root: that of the smallest squared norm (sqrt is monotone, so this equals
    the smallest norm exactly).
    """
    margin = ca.sqrt(ca.mmin(ca.sum1(r**2))) - f_min
    lim = limits if isinstance(limits, ca.SX) else ca.DM(limits)
    torque_gap = (ca.fabs(tau) - lim) / lim
    return margin, ca.fmax(0, ca.fmax(-margin / ca.fmax(f_min, 1e-12), ca.mmax(torque_gap)))


def _into_box(x, lo, hi, branch):
    """x clipped to [lo, hi]; if the box is empty (lo > hi) the end on the branch's side
    wins (lo for branch +1, where lo >= 0; hi otherwise)."""
    return ca.if_else(branch > 0, ca.fmax(ca.fmin(x, hi), lo), ca.fmin(ca.fmax(x, lo), hi))


@functools.lru_cache(maxsize=64)
def _fixed(f_min: float, weights: tuple[float, ...], limits: tuple[float, ...], branch: int, nj: int) -> ca.Function:
    return fix_last_input(parametric_exact_preload(len(weights), nj), [*weights, *limits, f_min, branch])


@functools.lru_cache(maxsize=16)  # per size
def parametric_exact_preload(n: int, nj: int) -> ca.Function:
    """The law of :func:`exact_preload_function` with the input ``settings`` last
    (weights (n), torque limits (n) [N m], f_min [N], branch in {-1, 0, +1})."""
    tau_p, tau_n = ca.SX.sym("tau_p", n), ca.SX.sym("tau_n", n, 1)
    r_p, r_n = ca.SX.sym("r_p", 2, nj), ca.SX.sym("r_n", 2, nj)
    settings = ca.SX.sym("settings", 2 * n + 2)
    w, limits, f_min, branch = settings[:n], settings[n:2 * n], settings[2 * n], settings[2 * n + 1]
    lim = limits
    inf = ca.inf

    # box from the actuator limits: -L <= tau_p + alpha tau_n <= L
    lo, hi = -inf, inf
    for i in range(n):
        tn = tau_n[i]
        safe = ca.if_else(tn >= 0, 1.0, -1.0) * ca.fmax(ca.fabs(tn), _TINY)
        a1, a2 = (-lim[i] - tau_p[i]) / safe, (lim[i] - tau_p[i]) / safe
        active = ca.fabs(tn) > 1e-14
        lo = ca.if_else(active, ca.fmax(lo, ca.fmin(a1, a2)), lo)
        hi = ca.if_else(active, ca.fmin(hi, ca.fmax(a1, a2)), hi)
    lo = ca.if_else(branch > 0, ca.fmax(lo, 0.0), lo)
    hi = ca.if_else(branch < 0, ca.fmin(hi, 0.0), hi)

    # unconstrained minimiser of sum w_i (tau_p,i + alpha tau_n,i)^2, into the box
    den = ca.dot(w, tau_n**2)
    x0 = _into_box(-ca.dot(w, tau_p * tau_n) / ca.fmax(den, _TINY), lo, hi, branch)

    # forbidden interval (l_j, u_j) of each joint, roots nudged outwards; (inf, inf) if none
    a = ca.sum1(r_n**2).T
    b = 2 * ca.sum1(r_p * r_n).T
    c = ca.sum1(r_p**2).T - f_min**2
    disc = b**2 - 4 * a * c
    flat = a <= 1e-14 * (1 + ca.fabs(c))
    has = ca.logic_and(ca.logic_not(flat), disc >= 0)
    dead = ca.mmax(ca.logic_and(flat, c < 0))  # a joint that never reaches f_min
    sq = ca.sqrt(ca.fmax(disc, 0))
    half = 0.5 / ca.fmax(a, _TINY)
    l_root, u_root = (-b - sq) * half, (-b + sq) * half
    low = ca.if_else(has, l_root - _ROOT_NUDGE * (1 + ca.fabs(l_root)), inf)
    up = ca.if_else(has, u_root + _ROOT_NUDGE * (1 + ca.fabs(u_root)), inf)

    # least feasible point >= x0 (right) and greatest <= x0 (left): 2n passes reach the fixed point
    right, left = x0, x0
    for _ in range(nj):
        right = right + ca.fmax(0, ca.mmax(ca.if_else(low < right, up - right, 0)))
        left = left + ca.fmin(0, ca.mmin(ca.if_else(up > left, low - left, 0)))

    out = []
    for x in (right, left):
        ok = ca.logic_and(ca.logic_and(x >= lo, x <= hi), ca.logic_not(dead))
        x = _into_box(x, lo, hi, branch)
        tau = tau_p + x * tau_n
        margin, viol = constraint_violation(tau, r_p + x * r_n, f_min, limits)
        out.append((x, tau, ok, margin, ca.dot(w, tau**2), viol))
    (xr, tau_r, ok_r, m_r, cost_r, viol_r), (xl, tau_l, ok_l, m_l, cost_l, viol_l) = out
    take_left = ca.if_else(ok_l, ca.logic_or(ca.logic_not(ok_r), cost_l < cost_r),
                           ca.logic_and(ca.logic_not(ok_r), viol_l < viol_r))
    alpha = ca.if_else(take_left, xl, xr)
    tau = ca.if_else(take_left, tau_l, tau_r)
    margin = ca.if_else(take_left, m_l, m_r)
    feasible = ca.if_else(ca.logic_or(ok_l, ok_r), 1.0, 0.0)
    return ca.Function("exact_preload", [tau_p, tau_n, r_p, r_n, settings], [alpha, tau, feasible, margin],
                       ["tau_p", "tau_n", "r_p", "r_n", "settings"], ["alpha", "tau", "feasible", "margin"])


def exact_preload_function(problem: Problem, f_min: float | None = None, branch: int = 0) -> ca.Function:
    """SX Function 'exact_preload' for a scene with one degree of redundancy (the 4-RRR:
    tau_p (4,) [N m], tau_n (4, 1), r_p (2, 8) [N], r_n (2, 8) [N]) ->
    alpha [N m], tau (4,) [N m], feasible (1.0 / 0.0), margin [N] = min_j ||r_j|| - f_min.

    f_min (default ``actuation.preload.min_force``), weights and torque limits come from
    the scene. Global optimum of sum_i w_i tau_i^2 subject to ||r_j|| >= f_min at all
    eight passive joints and |tau_i| <= L_i. branch = +1 (-1) restricts the preload to
    alpha >= 0 (<= 0): still closed form, and continuous along a path where the global
    optimum would jump between the two branches of equal cost. Cached per arguments.
    """
    model = problem.model
    if model.redundancy != 1:
        raise SceneError(f"actuation.preload.method: 'exact' is not allowed with {model.redundancy} degrees of "
                         "actuation redundancy (it needs exactly one; use qp or nlp)")
    p = problem.scene.actuation.preload
    fm = p.min_force if f_min is None else float(f_min)
    if branch not in (0, 1, -1):
        raise SceneError(f"branch: {branch!r} is not allowed (0 for both, +1 or -1)")
    return _fixed(float(fm), tuple(p.weights), problem.torque_limit, int(branch),
                  len(model.preload_joints))
