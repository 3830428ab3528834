"""The controller step of a scene without a closed-form one: its references tabulated along
the path and the feedback law, in one CasADi Function (what ``rrr4 codegen`` writes for a
graph scene and runs in the loop).

Any scene with a task body and actuators has one: the references
(:func:`rrr4.control.tabulated`: IK by Newton, the effort family by SVD, the preload of the
scene's method, the clearance compensation by Newton around the predicted seats) are
computed once on :func:`reference_grid` and held as piecewise cubics (:func:`interpolants`,
the interpolation the simulation uses for tabulated references), looked up at the time t
(a binary search), and the feedback law (:mod:`rrr4.control.feedback`) closes the loop on
the measured actuator coordinates. No iteration runs in the step, so its cost is fixed.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline, PPoly

from ..errors import SceneError
from ..problem import Problem
from .feedback import feedback_settings, parametric_feedback
from .references import path_rows, tabulated
from .step import controller_function, pointwise_controller

__all__ = ["reference_grid", "interpolants", "table_controller", "controller_step", "step_inputs"]


def controller_step(problem: Problem) -> ca.Function:
    """The problem's controller step with its numbers folded in, what ``rrr4 codegen`` writes
    and the generated controller in the loop runs: the closed form
    (:func:`rrr4.control.controller_function`, inputs pose_des, pose_d_des, pose_dd_des,
    theta, theta_d, on the scene's preload sign) where the problem has one, else the table step
    (:func:`table_controller`, inputs t, theta, theta_d). Raises SceneError for a scene
    without a task body or without actuators (no controller to run)."""
    model = problem.model
    if model.task is None:
        raise SceneError(f"mechanism.task: scene {problem.name!r} has no task body, so it has no controller (its "
                         "drivers prescribe the motion; a controller needs a task body and actuators)")
    if not model.n_actuators:
        raise SceneError(f"mechanism.actuators: scene {problem.name!r} has no actuators, so it has no controller "
                         "(a controller needs a task body and actuators)")
    return controller_function(problem) if not pointwise_controller(problem) else table_controller(problem)


def step_inputs(step: ca.Function, path, t: np.ndarray) -> list[np.ndarray]:
    """The inputs of a controller step (:func:`controller_step`) before the measured theta
    and theta_d at the times t (N,) [s] on `path`: the times (1, N) for a table step, else the
    pose, its rate and acceleration (3, N each)."""
    t = np.asarray(t, float)
    if step.name_in(0) == "t":
        return [t[None, :]]
    rows = path_rows(path, t)
    return [rows[:, 3 * k:3 * k + 3].T for k in range(3)]


def reference_grid(problem: Problem) -> np.ndarray:
    """The times [s] the table step holds its references at, over the path's duration: the
    path's samples, or the control instants where the controller is sampled more coarsely
    (the grid the simulation tabulates a run of the path's duration on)."""
    T = problem.path.duration
    n = max(int(round(T * problem.path.sample_rate)), 2)
    rate = problem.scene.actuation.control_rate
    if rate is not None:
        n = min(n, max(int(round(T * rate)), 1))
    return np.linspace(0.0, T, max(n, 2) + 1)


def interpolants(t_s: np.ndarray, th, th_d, th_dd, ff) -> dict[str, PPoly]:
    """Piecewise cubics through references tabulated at the times t_s (at least 3): cubic
    Hermite 'th' (with th_d) and 'thd' (with th_dd), cubic splines 'thdd' and 'ff'; error
    ~ h^4, far below 1e-9 at 1 kHz."""
    return {"th": CubicHermiteSpline(t_s, th, th_d, axis=0), "thd": CubicHermiteSpline(t_s, th_d, th_dd, axis=0),
            "thdd": CubicSpline(t_s, th_dd, axis=0), "ff": CubicSpline(t_s, ff, axis=0)}


def _lookup(p: PPoly, i, dt) -> ca.MX:
    """The piecewise cubic p (columns) at the offset dt into its interval i (MX index)."""
    c = np.asarray(p.c)  # (4, intervals, columns)
    _, m, cols = c.shape
    table = ca.MX(ca.DM(c.transpose(1, 0, 2).ravel(order="F")))  # interval fastest, then order, then column
    out, dt2 = [], dt * dt
    for j in range(cols):
        a = [table.get_nz(False, i + m * (k + 4 * j)) for k in range(4)]
        # in scipy's order of operations (PPoly.__call__), so that the C computes the
        # simulation's interpolated references bit for bit
        out.append(((a[3] + a[2] * dt) + a[1] * dt2) + a[0] * (dt2 * dt))
    return ca.vertcat(*out)


def table_controller(problem: Problem) -> ca.Function:
    """MX Function 'controller_step' of a problem with a task and actuators: t [s], theta,
    theta_d (n each) [rad or m, and rates] -> tau (n,) [N m or N] (clipped), tau_ff (n,)
    (inverse dynamics + preload (+ friction compensation)), theta_ref, theta_d_ref (n,)
    (compensated if the scene says so), alpha (m,) [N m] (the preload along the null space),
    feasible (1.0 where the preload holds at both ends of t's interval, else 0.0). t is
    clamped to the path's [0, duration]. The feedback gains and limits
    (:func:`rrr4.control.feedback_settings`) are folded in as constants, like the table. Built once per problem."""
    return problem.memo("table_controller", lambda: _table_controller(problem))


def _table_controller(problem: Problem) -> ca.Function:
    t_s = reference_grid(problem)
    refs = tabulated(problem, t_s)
    p = interpolants(t_s, refs.theta_ref, refs.theta_d_ref, refs.theta_dd_ref, refs.tau_ff)
    m = refs.alpha.shape[1]
    alpha = CubicSpline(t_s, refs.alpha, axis=0) if m else None
    feasible = np.minimum(refs.feasible[:-1], refs.feasible[1:])
    n = refs.theta_ref.shape[1]
    t, theta, theta_d = ca.MX.sym("t"), ca.MX.sym("theta", n), ca.MX.sym("theta_d", n)
    tc = ca.fmin(ca.fmax(t, t_s[0]), t_s[-1])
    i = ca.low(ca.DM(t_s), tc, {"lookup_mode": "binary"})
    dt = tc - ca.MX(ca.DM(t_s)).get_nz(False, i)
    th, thd, ff = (_lookup(p[k], i, dt) for k in ("th", "thd", "ff"))
    tau = parametric_feedback(problem)(th, thd, ff, theta, theta_d,
                                         ca.DM(feedback_settings(problem)))
    return ca.Function("controller_step", [t, theta, theta_d],
                       [tau, ff, th, thd, _lookup(alpha, i, dt) if m else ca.MX(0, 1),
                        ca.MX(ca.DM(feasible)).get_nz(False, i)],
                       ["t", "theta", "theta_d"],
                       ["tau", "tau_ff", "theta_ref", "theta_d_ref", "alpha", "feasible"])
