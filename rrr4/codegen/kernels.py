"""The Functions the generated C computes: one :class:`Kernel` per entry of :data:`KERNELS`.

Kernels are built once per problem by calling the problem's own Functions symbolically
(inverse kinematics, Jacobian, null space, path, inverse dynamics, the exact and QP preload
laws, the controller step), so the C computes exactly what the Python does. A closed-form
4-RRR gets all of them; any other scene with a task body and actuators (a graph, another
n-RRR, a preload without a pointwise law) gets the path and its controller step
(:func:`rrr4.control.controller_step`: the table step on references tabulated along the
path, or an n-RRR's closed form), :data:`STEP_KERNELS`. Each is a CasADi
Function ``rrr4_raw_<name>`` (:data:`RAW`) with dense inputs and outputs; the wrappers
``rrr4_<name>`` (:data:`WRAPPER`) around them are written by :mod:`rrr4.codegen.text`.

The exact preload law is exposed twice: ``exact_preload`` takes the affine reaction family
(tau_p, tau_n, r_p, r_n) and ``preload`` takes the desired motion (pose, pose_d, pose_dd).
A platform wrench alone does not fix the passive-joint reactions: they also carry the
inertia forces of every driving and following link, so the law needs the motion (or the
family computed from it by ``inverse_dynamics``).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ..control import controller_step
from ..errors import SceneError
from ..preload.exact import exact_preload_function
from ..preload.qp import qp_preload_function
from ..preload.signs import preload_sign
from ..problem import Problem
from ..trajectory import trajectory_function

__all__ = ["Kernel", "KERNELS", "STEP_KERNELS", "kernels", "table_step", "preload_branch", "RAW", "WRAPPER"]

RAW = "rrr4_raw"  # stem of CasADi's generated .c/.h and prefix of its symbols
WRAPPER = "rrr4"  # stem of the wrapper .c/.h and prefix of the wrapper functions
KERNELS = ("ik", "jacobian", "null_space", "trajectory", "inverse_dynamics", "exact_preload", "preload",
           "controller_step", "qp_preload")
STEP_KERNELS = ("trajectory", "controller_step")  # of a scene other than a closed-form 4-RRR

_KERNEL_DOC = {
    "ik": "Inverse kinematics, closed form, in the scene's working modes.",
    "jacobian": "Jacobian of the actuator angles with respect to the platform pose.",
    "null_space": "Null space of J^T (the preload direction).",
    "trajectory": "The scene's desired path: pose and its derivatives at time t.",
    "inverse_dynamics": "Inverse dynamics of the ideal mechanism: the affine family tau = tau_p + alpha tau_n "
                        "and the passive reactions r_j = r_p[:, j] + alpha r_n[:, j] (force of the inboard on "
                        "the outboard body, global frame).",
    "exact_preload": "Exact preload law on a given reaction family: the least sum_i w_i tau_i^2 subject to "
                     "|r_j| >= min_force at all passive joints and |tau_i| <= limit_i, with alpha on the branch "
                     "RRR4_PRELOAD_BRANCH (closed form, no iterations).",
    "preload": "Exact preload law for a desired motion: inverse_dynamics followed by exact_preload.",
    "controller_step": "One controller step, the one rrr4.simulate runs: tau = clip(tau_ff + kp (theta_ref - "
                       "theta) + kd (theta_d_ref - theta_d), +-limit), the angle error wrapped to [-pi, pi); tau_ff "
                       "= inverse dynamics + the scene's preload (RRR4_PRELOAD_METHOD on RRR4_PRELOAD_SIGN); "
                       "theta_ref = ik(pose_des), or with RRR4_COMPENSATION clearance the IK closed around the "
                       "predicted journal seats, plus the torques that overcome their friction.",
    "table_step": "One controller step, the one rrr4.simulate runs as the generated controller in the loop: "
                  "tau = clip(tau_ff + kp (theta_ref - theta) + kd (theta_d_ref - theta_d), +-limit), revolute "
                  "errors wrapped to [-pi, pi); theta_ref, theta_d_ref, tau_ff (inverse dynamics + the scene's "
                  "preload RRR4_PRELOAD_METHOD, with RRR4_COMPENSATION clearance the IK around the predicted "
                  "journal seats plus their friction torques) and alpha are piecewise cubics through references "
                  "tabulated at RRR4_TABLE_SAMPLES instants over [0, RRR4_PATH_DURATION] (t is clamped to it), "
                  "looked up by binary search: no iteration, a fixed cost per call.",
    "qp_preload": "Preload as a QP (qrqp active set, no allocation): fixed-sign axial force >= min_force in "
                  "every following link, torque limits, least weighted effort. Returns non-zero, with the "
                  "outputs undefined, when qrqp stops without a solution (an infeasible QP).",
}


@dataclass(frozen=True)
class Kernel:
    """One generated function: ``name`` (C wrapper ``rrr4_<name>``), the CasADi Function
    ``rrr4_raw_<name>`` with dense inputs and outputs, and a one-line description."""
    name: str
    function: ca.Function
    doc: str


def _renamed(f: ca.Function, name: str, fixed: dict | None = None) -> ca.Function:
    """f under a new name, with dense outputs and common subexpressions merged (CasADi's
    ``cse``, 10-25 % fewer instructions); inputs named in `fixed` are bound to constants."""
    fixed = fixed or {}
    sym = ca.SX if f.is_a("SXFunction") else ca.MX
    ins = {f.name_in(i): sym.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())}
    outs = f.call({k: fixed.get(k, v) for k, v in ins.items()})
    free = [k for k in ins if k not in fixed]
    return ca.Function(name, [ins[k] for k in free], [ca.densify(outs[k]) for k in f.name_out()],
                       free, list(f.name_out()), {"cse": True})


def kernels(problem: Problem, branch: int = 1) -> tuple[Kernel, ...]:
    """The generated kernels of a problem (built once per problem and branch, cached on it):
    of a closed-form 4-RRR with a pointwise controller step, :data:`KERNELS` in order, the exact
    preload (in exact_preload and preload) on `branch` (+1, -1, 0); of any other problem with a
    task body and actuators, :data:`STEP_KERNELS`. Raises SceneError for a problem without
    a task body or actuators."""
    return problem.memo(("kernels", branch), lambda: _kernels(problem, branch))


def table_step(ks: tuple[Kernel, ...]) -> bool:
    """Whether the controller step of the kernels `ks` is the table step (input t)."""
    return next(k for k in ks if k.name == "controller_step").function.name_in(0) == "t"


def _kernels(problem: Problem, branch: int) -> tuple[Kernel, ...]:
    step = controller_step(problem)
    table = step.name_in(0) == "t"
    if table or not problem.closed_form or problem.mechanism.n != 4:
        doc = _KERNEL_DOC["table_step" if table else "controller_step"]
        return (Kernel("trajectory", _renamed(trajectory_function(problem.path), f"{RAW}_trajectory"),
                       _KERNEL_DOC["trajectory"]), Kernel("controller_step", _renamed(step, f"{RAW}_controller_step"),
                                                          doc))
    mech = problem.mechanism
    inv, exact = problem.inverse_dynamics(), exact_preload_function(problem, branch=branch)
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose", "pose_d", "pose_dd"))
    preload = ca.Function("preload", [pose, pose_d, pose_dd], exact(*inv(pose, pose_d, pose_dd)),
                          ["pose", "pose_d", "pose_dd"], exact.name_out())
    jac = ca.Function("jacobian", [pose], mech.jacobian_function(pose)[::3], ["pose"], ["J", "sin_transmission"])
    sources = {
        "ik": (mech.ik_function, {"modes": ca.SX(ca.DM(mech.modes))}),
        "jacobian": (jac, None),
        "null_space": (mech.null_space_function, None),
        "trajectory": (trajectory_function(problem.path), None),
        "inverse_dynamics": (inv, None),
        "exact_preload": (exact, None),
        "preload": (preload, None),
        "controller_step": (step, None),
        "qp_preload": (qp_preload_function(problem, "qrqp"), None),
    }
    return tuple(Kernel(k, _renamed(sources[k][0], f"{RAW}_{k}", sources[k][1]), _KERNEL_DOC[k]) for k in KERNELS)


def preload_branch(problem: Problem, branch="auto") -> int:
    """The exact-preload branch of the exact_preload and preload kernels as +1 (alpha >= 0),
    -1 (alpha <= 0) or 0 (global optimum per instant). 'auto' is the controller's own sign
    (:func:`rrr4.preload.preload_sign`; +1 without a preload)."""
    if branch == "auto":
        return preload_sign(problem) or 1
    if branch in (0, 1, -1) and not isinstance(branch, bool):
        return int(branch)
    raise SceneError(f"branch: {branch!r} is not allowed (choose one of: auto, 1, -1, 0)")
