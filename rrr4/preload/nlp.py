"""Trajectory preload NLP over the whole horizon (CasADi Opti + ipopt).

Decision: alpha_k (m,) at every grid sample k. With tau_k = tau_p,k + N_k alpha_k and
r_j,k = r_p,j,k + r_n,j,k alpha_k (:mod:`rrr4.dynamics.inverse`):

    minimise   sum_k dt_k tau_k^T W tau_k  +  w_s sum_k dt_k ||alpha''_k||^2
    subject to ||r_j,k||^2 >= f_min^2                          (contact kept)
               -L <= tau_k <= L                                 (actuator limits)
               r_j,k . r_j,k+1 >= 0,
               (r_j,k x r_j,k+1)^2 <= sin^2(omega dt_k) ||r_j,k||^2 ||r_j,k+1||^2
                                                                (direction turns at most omega [rad/s])

alpha'' is the second divided difference of alpha: the smoothness term penalises the
curvature of the preload, the only part of tau the preload chooses (tau_p is fixed by the
path). w_s = ``actuation.preload.smoothness_weight`` [s^4]; at the reference scene's 1e-4
it cuts the torque roughness about sevenfold against the pointwise QP for ~3 % more
effort. The turn-rate bound is the sine of the angle between consecutive reactions, squared so it
stays smooth; with omega dt < pi/2 the dot-product sign fixes the branch. The grid may be
coarser than the path's sample rate (alpha is then interpolated linearly and every sample
is re-checked by the caller).
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np

from ..functions import QUIET

__all__ = ["solve_trajectory_nlp", "IPOPT_OPTIONS"]

IPOPT_OPTIONS = {"print_time": False, **QUIET,
                 "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 500, "tol": 1e-8,
                           "mu_strategy": "adaptive", "nlp_scaling_method": "gradient-based"}}


def solve_trajectory_nlp(t, tau_p, tau_n, r_p, r_n, *, f_min: float, weights, limits,
                         smoothness_weight: float, max_turn_rate: float, alpha0,
                         options: dict | None = None):
    """Solve the horizon NLP on the samples given.

    t (K,) [s]; tau_p (K, n) [N m]; tau_n (K, n, m); r_p (K, nj, 2) [N]; r_n (K, nj, 2, m) [N];
    alpha0 (K, m) initial guess (e.g. the QP solution). Returns (alpha (K, m), statistics).
    """
    K, n = tau_p.shape
    m = tau_n.shape[2]
    nj = r_p.shape[1]
    dt = np.diff(t)
    opti = ca.Opti()
    alpha = opti.variable(m, K)
    tau = ca.DM(tau_p.T)
    rx, ry = ca.DM(r_p[:, :, 0].T), ca.DM(r_p[:, :, 1].T)  # (nj, K)
    for k in range(m):
        row = alpha[k, :]
        tau = tau + ca.DM(tau_n[:, :, k].T) * ca.repmat(row, n, 1)
        rx = rx + ca.DM(r_n[:, :, 0, k].T) * ca.repmat(row, nj, 1)
        ry = ry + ca.DM(r_n[:, :, 1, k].T) * ca.repmat(row, nj, 1)
    w = ca.DM(np.asarray(weights, float))
    wdt = ca.DM(np.r_[dt, 0.0] * 0.5 + np.r_[0.0, dt] * 0.5).T  # trapezoid weights (1, K)
    effort = ca.sum2(wdt * (w.T @ tau**2))
    # curvature of the preload itself: second divided differences of alpha
    rate = (alpha[:, 1:] - alpha[:, :-1]) / ca.repmat(ca.DM(dt).T, m, 1)
    mid = ca.DM(0.5 * (dt[1:] + dt[:-1])).T
    curv = (rate[:, 1:] - rate[:, :-1]) / ca.repmat(mid, m, 1)
    smooth = ca.sum2(mid * ca.sum1(curv**2))
    opti.minimize(effort + smoothness_weight * smooth)

    lim = ca.repmat(ca.DM(np.asarray(limits, float)), 1, K)
    opti.subject_to(opti.bounded(ca.vec(-lim), ca.vec(tau), ca.vec(lim)))
    norm2 = rx**2 + ry**2
    opti.subject_to(ca.vec(norm2) >= f_min**2)
    dot = rx[:, :-1] * rx[:, 1:] + ry[:, :-1] * ry[:, 1:]
    cross = rx[:, :-1] * ry[:, 1:] - ry[:, :-1] * rx[:, 1:]
    s2 = ca.repmat(ca.DM(np.sin(np.minimum(max_turn_rate * dt, np.pi / 2)) ** 2).T, nj, 1)
    opti.subject_to(ca.vec(dot) >= 0)
    opti.subject_to(ca.vec(cross**2 - s2 * norm2[:, :-1] * norm2[:, 1:]) <= 0)

    opti.set_initial(alpha, np.asarray(alpha0, float).reshape(K, m).T)
    opti.solver("ipopt", {**IPOPT_OPTIONS, **(options or {})})
    t0 = time.perf_counter()
    try:
        sol = opti.solve()
        a = np.array(sol.value(alpha)).reshape(m, K).T
        stats = sol.stats()
    except RuntimeError:  # not converged: report the last iterate, the caller re-checks feasibility
        a = np.array(opti.debug.value(alpha)).reshape(m, K).T
        stats = opti.stats()
    wall = time.perf_counter() - t0
    return a, {"solver": "ipopt", "return_status": stats.get("return_status"), "success": bool(stats.get("success")),
               "iterations": int(stats.get("iter_count", -1)), "nlp_wall_time": wall, "nlp_grid_points": K}
