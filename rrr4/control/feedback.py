"""The feedback law of the one controller:

    tau = clip(tau_ff + kp wrap(theta_ref - theta) + kd (theta_d_ref - theta_d), +-limit)

with the angle error of a revolute actuator wrapped to [-pi, pi) (a prismatic one's as is,
in m). One SX Function per actuator layout, its numbers (gains, limits) the last input
``settings``."""

from __future__ import annotations

import functools

import casadi as ca

from ..functions import fix_last_input
from ..problem import Problem

__all__ = ["feedback_function", "parametric_feedback", "feedback_settings"]


def feedback_function(problem: Problem) -> ca.Function:
    """SX Function 'feedback': theta_ref, theta_d_ref, tau_ff, theta, theta_d (n each) ->
    tau (n,), the law above with the problem's gains and limits folded in."""
    return fix_last_input(parametric_feedback(problem), feedback_settings(problem))


def feedback_settings(problem: Problem) -> list[float]:
    """The feedback law's input ``settings``: kp, kd, torque limits (n)."""
    a = problem.scene.actuation
    return [a.kp, a.kd, *problem.torque_limit]


def parametric_feedback(problem: Problem) -> ca.Function:
    """:func:`feedback_function` with the input ``settings`` (:func:`feedback_settings`) last."""
    return _feedback(tuple(problem.joint(j).type == "revolute" for j in problem.model.actuated_joints))


@functools.lru_cache(maxsize=16)  # per actuator kinds
def _feedback(revolute: tuple[bool, ...]) -> ca.Function:
    n = len(revolute)
    th_ref, thd_ref, ff, th, thd = (ca.SX.sym(s, n) for s in ("theta_ref", "theta_d_ref", "tau_ff", "theta",
                                                               "theta_d"))
    settings = ca.SX.sym("settings", 2 + n)
    kp, kd, lim = settings[0], settings[1], settings[2:]
    d = th_ref - th
    wrap = ca.DM([1.0 if r else 0.0 for r in revolute])
    e = d - wrap * 2 * ca.pi * ca.floor((d + ca.pi) / (2 * ca.pi))
    tau = ca.fmin(ca.fmax(ff + kp * e + kd * (thd_ref - thd), -lim), lim)
    return ca.Function("feedback", [th_ref, thd_ref, ff, th, thd, settings], [tau],
                       ["theta_ref", "theta_d_ref", "tau_ff", "theta", "theta_d", "settings"], ["tau"])
