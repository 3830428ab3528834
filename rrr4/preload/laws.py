"""The pointwise preload law of a problem's controller: the exact law on one branch, or the
fixed-sign axial-force QP in closed form (one degree of redundancy), as one SX Function
tau_p, tau_n, r_p, r_n -> alpha, tau, feasible, margin that the controller step calls and
``rrr4 codegen`` writes."""

from __future__ import annotations

import casadi as ca

from ..errors import SceneError
from ..functions import fix_last_input
from ..problem import Problem
from .exact import parametric_exact_preload
from .qp import parametric_scalar_qp_preload
from .signs import preload_sign

__all__ = ["why_not_pointwise", "preload_law", "parametric_preload_law", "law_settings"]


def why_not_pointwise(problem: Problem) -> str:
    """'' if the problem's preload (if any) is a pointwise law in closed form, else why not."""
    if problem.has_preload:
        m = problem.redundancy
        if m > 1:
            return f"a pointwise preload in closed form needs one degree of redundancy, the scene has {m}"
        if problem.scene.actuation.preload.method == "nlp":
            return "the 'nlp' preload is a trajectory optimisation, not a pointwise law"
    return ""


def law_settings(problem: Problem, weights, limits, f_min, sign):
    """The input ``settings`` of the problem's preload law (numbers or symbols): weights,
    limits, f_min, then the exact law's branch, or the QP's axial-force sign of every joint."""
    qp = problem.scene.actuation.preload.method == "qp"
    signs = [sign] * len(problem.model.preload_joints) if qp else [sign]
    return ca.vertcat(*weights, *limits, f_min, *signs)


def parametric_preload_law(problem: Problem) -> ca.Function | None:
    """The preload law of :func:`preload_law` with its numbers (weights, limits, f_min, sign)
    as the last input ``settings`` (:func:`law_settings`); None without a preload."""
    if not problem.has_preload:
        return None
    why = why_not_pointwise(problem)
    if why and problem.closed_form:
        raise SceneError(f"actuation.preload.method: {problem.scene.actuation.preload.method!r} is not allowed in "
                         f"a controller step ({why}; choose exact or qp, or pass preload= to simulate)")
    n, nj = problem.model.n_actuators, len(problem.model.preload_joints)
    if problem.scene.actuation.preload.method == "exact":
        return parametric_exact_preload(n, nj)
    return parametric_scalar_qp_preload(n, nj)


def preload_law(problem: Problem, sign: int | None = None) -> ca.Function | None:
    """The pointwise preload of the problem's controller, an SX Function tau_p, tau_n, r_p,
    r_n -> alpha, tau, feasible, margin (None without a preload): the exact law on the
    branch `sign`, or the closed-form QP with that axial-force sign (default:
    :func:`rrr4.preload.signs.preload_sign`)."""
    law = parametric_preload_law(problem)
    if law is None:
        return None
    p = problem.scene.actuation.preload
    return fix_last_input(law, law_settings(problem, p.weights, problem.torque_limit, p.min_force,
                                            preload_sign(problem) if sign is None else int(sign)))
