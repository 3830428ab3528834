"""The controller step: one CasADi Function per problem, run by the simulation and written
to C (DESIGN sections 1.3(b) and 7).

For an n-RRR problem the whole step is one closed-form SX Function,
:func:`controller_function` ('controller_step'): from the desired pose and its first two
derivatives it computes

- the ideal inverse dynamics, the affine family tau = tau_p + alpha tau_n;
- the preload alpha with the scene's ``actuation.preload`` (:mod:`rrr4.preload.laws`):
  ``exact`` on a fixed branch, ``qp`` (the fixed-sign axial-force QP, solved in closed form
  for one degree of redundancy), or none (``method: none`` or ``min_force: 0``: alpha = 0);
- the references theta_ref, theta_d_ref: the IK of the pose, or with ``actuation.compensation:
  clearance`` the IK with every clearance journal at its predicted seat
  (:mod:`rrr4.control.compensation`), and its rate with the seats held (their drift is below
  1 % of the remaining error on the reference scene, and following it would triple the
  instructions);
- the feedback law (:mod:`rrr4.control.feedback`).

`rrr4.simulate` runs this Function (inlined in CasADi, or its generated C in the loop
through ``casadi.external``) and ``rrr4.codegen`` writes it: there is no second controller.
A general graph has no closed-form step: its references are tabulated on the path samples
(:mod:`rrr4.control.references`) and the same feedback law runs on them.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..dynamics.inverse import actuator_motion_function
from ..errors import SceneError
from ..functions import fix_last_input
from ..preload import law_settings, parametric_preload_law, preload_sign, why_not_pointwise
from ..problem import Problem
from .compensation import friction_feed_forward, nrrr_slip, seats
from .feedback import feedback_settings, parametric_feedback

__all__ = ["controller_function", "parametric_controller", "controller_settings", "pointwise_controller"]


def pointwise_controller(problem: Problem) -> str:
    """'' if the problem's controller is one closed-form Function (:func:`controller_function`),
    else why not (then the simulation tabulates its references)."""
    if not problem.closed_form:
        return "a graph scene has no closed-form IK (its references are tabulated on the path samples)"
    if problem.compensates and problem.scene.actuation.seat_model == "rolling":
        return ("the rolling seat model follows the journals' slip along the path (its references are tabulated "
                "on the path samples)")
    if problem.element_forces is not None:
        return ("known force elements other than constant loads on the platform are balanced by the effort family "
                "(its references are tabulated on the path samples)")
    return why_not_pointwise(problem)


def controller_function(problem: Problem, sign: int | None = None) -> ca.Function:
    """SX Function 'controller_step' of an n-RRR problem: pose_des, pose_d_des, pose_dd_des,
    (3 each) [m, rad and their rates], theta, theta_d (n each) [rad, rad/s] ->
    tau (n,) [N m] (clipped), tau_ff (n,) [N m] (inverse dynamics + preload), theta_ref,
    theta_d_ref (n,) [rad, rad/s] (compensated if the scene says so), alpha (m,) [N m],
    feasible (1.0 / 0.0; 1.0 without a preload).

    sign: the preload branch / axial-force sign (default: :func:`rrr4.preload.preload_sign`).
    The problem's numbers are folded in as constants (what ``rrr4 codegen`` writes); the same
    graph with them as an input is :func:`parametric_controller`.
    Raises SceneError for a problem without a closed-form controller (:func:`pointwise_controller`).
    """
    return fix_last_input(parametric_controller(problem), controller_settings(problem, sign))


def controller_settings(problem: Problem, sign: int | None = None) -> np.ndarray:
    """The numbers of the controller step that :func:`parametric_controller` takes as its
    input ``settings``: kp, kd, torque limits (n) (:func:`rrr4.control.feedback_settings`),
    the preload's weights (n), f_min [N] and sign (+1 / -1; 0 without a preload), then, with
    clearance compensation, the contact numbers (``Problem.contact_parameters``)."""
    a, n = problem.scene.actuation, problem.model.n_actuators
    s = 0 if not problem.has_preload else (preload_sign(problem) if sign is None else int(sign))
    out = [*feedback_settings(problem), *a.preload.weights[:n], a.preload.min_force, float(s)]
    return np.array([*out, *(problem.contact_parameters if problem.compensates else [])], float)


def parametric_controller(problem: Problem) -> ca.Function:
    """:func:`controller_function` with the input ``settings`` (:func:`controller_settings`)
    last: one Function for every problem of the same structure (``Problem.controller_key``:
    mechanism, gravity, preload method, compensation, friction law), so that compiled code
    built on it is shared by problems that differ only in gains, limits, f_min, the preload's
    sign or contact numbers."""
    why = pointwise_controller(problem)
    if why:
        if not problem.closed_form:
            raise SceneError(f"mechanism.kind: no closed-form controller step for scene {problem.name!r} ({why})")
        raise SceneError(f"actuation.preload.method: no closed-form controller step for scene {problem.name!r} "
                         f"({why}; choose exact or qp for the preload)")
    structure = problem.structure("controller")
    return structure.memo("parametric_controller", lambda: _controller(structure))


def _controller(problem: Problem) -> ca.Function:
    mech = problem.mechanism
    n = mech.n
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose_des", "pose_d_des", "pose_dd_des"))
    theta, theta_d = ca.SX.sym("theta", n), ca.SX.sym("theta_d", n)
    compensates = problem.compensates
    n_contact = problem.contact_parameters.size if compensates else 0
    settings = ca.SX.sym("settings", 2 * n + 4 + n_contact)
    gains, weights, f_min_sign, contact = (settings[:2 + n], settings[2 + n:2 + 2 * n], settings[2 + 2 * n:4 + 2 * n],
                                           settings[4 + 2 * n:])
    tau_p, tau_n, r_p, r_n = problem.inverse_dynamics()(pose, pose_d, pose_dd)
    law = parametric_preload_law(problem)
    if law is None:
        alpha, tau_ff, feasible = ca.SX.zeros(tau_n.shape[1]), tau_p, ca.SX(1.0)
    else:
        alpha, tau_ff, feasible, _ = law(tau_p, tau_n, r_p, r_n, law_settings(
            problem, ca.vertsplit(weights), ca.vertsplit(gains[2:]), f_min_sign[0], f_min_sign[1]))
    motion = actuator_motion_function(mech)
    if compensates:
        r = r_p + (alpha * r_n if alpha.numel() else 0)
        slip = nrrr_slip(problem, pose, pose_d, contact)
        gap, f_t = seats(problem, r, slip, contact)
        if problem.scene.effects.friction.law != "none":
            tau_ff = tau_ff + friction_feed_forward(problem, pose, pose_d, slip, f_t)
        # the IK closed around the seats; its rate at fixed seats (their drift adds < 1 % of
        # the remaining error on the reference scene, for a third of the instructions)
        u_ref, theta_d_ref = motion(pose, pose_d, gap[:, :n] + gap[:, n:])
    else:
        # theta_ref from the driving-link directions the inverse dynamics computes anyway
        u_ref, theta_d_ref = motion(pose, pose_d, ca.SX.zeros(2, n))
    theta_ref = ca.atan2(u_ref[1, :], u_ref[0, :]).T
    tau = parametric_feedback(problem)(theta_ref, theta_d_ref, tau_ff, theta, theta_d, gains)
    return ca.Function("controller_step", [pose, pose_d, pose_dd, theta, theta_d, settings],
                       ca.cse([tau, tau_ff, theta_ref, theta_d_ref, alpha, feasible]),
                       ["pose_des", "pose_d_des", "pose_dd_des", "theta", "theta_d", "settings"],
                       ["tau", "tau_ff", "theta_ref", "theta_d_ref", "alpha", "feasible"])
