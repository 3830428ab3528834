"""The controller's references along the path, computed once and tabulated.

- :func:`reference_function`: the closed-form IK of an n-RRR's path, t -> pose_ref,
  theta_ref and its rates (the prescribed mode's driving references);
- :func:`tabulated`: the controller's references (theta_ref, theta_d_ref, theta_dd_ref,
  tau_ff with the preload, alpha) on a time grid: the closed-form controller's own outputs
  where it has one, else :func:`graph_references` (IK by Newton, the effort family by SVD,
  the preload from :func:`rrr4.solve_preload`, the compensated IK by Newton around the
  predicted journal seats);
- :func:`path_rows`: the path and its derivatives at given times.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

from ..functions import mapped
from ..preload import solve_preload
from ..problem import Problem
from ..scene import PathSpec
from ..trajectory import trajectory_function
from .compensation import compensated_ik, rolling_friction, slip_rows
from .step import controller_function, pointwise_controller

__all__ = ["References", "graph_references", "prescribed_references", "reference_function", "tabulated", "path_rows"]


@dataclass(frozen=True)
class References:
    """Controller references on a time grid t (N,) [s]: theta_ref, theta_d_ref,
    theta_dd_ref, tau_ff (N, n) (actuator coordinates [rad or m], their rates, the
    feed-forward efforts [N m or N] with the preload), alpha (N, m), pose (N, 3), feasible
    (N,) (1.0 where the preload holds every passive joint loaded within the limits, else 0.0;
    1.0 without a preload or with a given one)."""
    t: np.ndarray
    pose: np.ndarray
    theta_ref: np.ndarray
    theta_d_ref: np.ndarray
    theta_dd_ref: np.ndarray
    tau_ff: np.ndarray
    alpha: np.ndarray
    feasible: np.ndarray


def path_rows(path: PathSpec, t: np.ndarray) -> np.ndarray:
    """(N, 9) [pose, pose_d, pose_dd] of the path at the times t (N,)."""
    out = mapped(trajectory_function(path), t=np.asarray(t, float)[None, :])
    return np.vstack(list(out.values())).T


def reference_function(problem: Problem) -> ca.Function | None:
    """SX Function 'references' of an n-RRR problem: t [s] -> pose_ref (3), theta_ref (n) [rad],
    theta_d_ref, theta_dd_ref (the closed-form IK of the path, for the prescribed mode); None
    for a graph, which has no closed-form IK (:func:`prescribed_references` samples either).
    Built once per mechanism and path (``Problem.path_key``)."""
    if not problem.closed_form:
        return None
    structure = problem.structure("path")

    def build():
        mech = structure.mechanism
        t = ca.SX.sym("t")
        pose = trajectory_function(structure.path)(t)[0]
        theta = mech.ik_function(pose, ca.DM(mech.modes))[0]
        theta_d = ca.jacobian(theta, t)
        theta_dd = ca.jacobian(theta_d, t)
        return ca.Function("references", [t], [pose, theta, theta_d, theta_dd],
                           ["t"], ["pose_ref", "theta_ref", "theta_d_ref", "theta_dd_ref"])
    return structure.memo("reference_function", build)


def prescribed_references(problem: Problem, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """theta_ref, theta_d_ref, theta_dd_ref (N, n) of the path at the times t (N,) [s] without a
    controller (the prescribed mode): the closed-form IK where there is one, else Newton along
    the path (:func:`graph_references`)."""
    refs = reference_function(problem)
    if refs is not None:
        return tuple(np.array(v).T for v in refs.map(len(t))(np.asarray(t, float)[None, :])[1:])
    g = graph_references(problem, t)
    return g.theta_ref, g.theta_d_ref, g.theta_dd_ref


def tabulated(problem: Problem, t: np.ndarray, given=None) -> References:
    """The controller's references on the grid t (N,) [s]: the closed-form controller's own
    outputs where it has one (an n-RRR without a given preload), else :func:`graph_references`;
    revolute actuators' angles unwrapped along t (continuous, so that cubics through them
    never cross a 2 pi jump; the feedback law wraps the error anyway)."""
    refs = _tabulated(problem, t, given)
    revolute = [i for i, j in enumerate(problem.model.actuated_joints) if problem.joint(j).type == "revolute"]
    refs.theta_ref[:, revolute] = np.unwrap(refs.theta_ref[:, revolute], axis=0)
    return refs


def _tabulated(problem: Problem, t: np.ndarray, given) -> References:
    if given is None and not pointwise_controller(problem):
        f = controller_function(problem)
        rows = path_rows(problem.path, t)
        n = f.size1_in(3)
        out = f.map(len(t))(*(rows[:, 3 * k:3 * k + 3].T for k in range(3)), np.zeros((n, len(t))),
                            np.zeros((n, len(t))))
        _, ff, th, th_d, alpha, feasible = (np.array(v).T for v in out)
        th_dd = CubicSpline(t, th_d, axis=0)(t, 1) if len(t) > 2 else np.zeros_like(th_d)
        return References(t, rows[:, :3], th, th_d, th_dd, ff, alpha.reshape(len(t), -1), feasible.ravel())
    return graph_references(problem, t, given)


def graph_references(problem: Problem, t: np.ndarray, preload=None) -> References:
    """The controller references of any problem with a task body at the times t (N,) [s]:
    IK by Newton along the path (the closed form for an n-RRR), the effort family, the
    preload (``preload``: an object with t and tau, e.g. a PreloadSolution, else
    :func:`rrr4.solve_preload` with the scene's method when it preloads) and, with
    compensation, the Newton IK around the predicted journal seats. Rates of compensated
    references by central differences of the IK over +-1e-4 of a sample step (second order,
    error ~ 1e-10 rad/s on the reference scene)."""
    mech = problem.mechanism
    model, N, k = problem.model, len(t), mech.n_task
    traj = trajectory_function(problem.path)
    p, pd, pdd = (np.array(v).T for v in traj.map(N)(t[None, :]))
    q = problem.path_coordinates(p, pd, pdd)
    qd, _, th_d, th_dd = mech.motion(q, pd[:, :k], pdd[:, :k])
    th = np.array(model.actuator_coordinates_function.map(N)(q.T)[0]).T
    fam = problem.effort_family(p, pd, pdd, q=q)  # with every known force element
    m = fam.tau_n.shape[2]
    alpha = np.zeros((N, m))
    tau_ff, feasible = fam.tau_p, np.ones(N)
    if preload is not None:
        tau_ff = np.column_stack([np.interp(t, preload.t, np.asarray(preload.tau)[:, i]) for i in range(mech.n)])
        alpha = np.einsum("knm,kn->km", fam.tau_n, tau_ff - fam.tau_p)
    elif problem.has_preload:
        sol = solve_preload(problem, branch="auto")  # exact: one branch, as the n-RRR controller
        alpha = np.column_stack([np.interp(t, sol.t, np.asarray(sol.alpha).reshape(len(sol.t), -1)[:, i])
                                 for i in range(m)])
        tau_ff = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, alpha)
        feasible = (np.interp(t, sol.t, np.asarray(sol.feasible, float)) == 1.0).astype(float)
    if problem.compensates:
        r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha)
        W = slip_rows(problem)
        slip = qd @ W.T
        dt = 1e-4 * (t[1] - t[0] if N > 1 else 1e-3)
        mu = rolling_friction(problem, t) if problem.scene.actuation.seat_model == "rolling" else None
        th, f_t = compensated_ik(problem, p[:, :k], r, slip, q, mu)
        shifted = [compensated_ik(problem, p[:, :k] + s * dt * pd[:, :k], r + s * dt * np.gradient(r, t, axis=0),
                                  slip, q, mu)[0] for s in (1.0, -1.0)]
        th_d = (shifted[0] - shifted[1]) / (2 * dt)
        th_dd = np.gradient(th_d, t, axis=0) if N > 2 else np.zeros_like(th_d)
        if problem.scene.effects.friction.law != "none":  # the friction moments, by virtual power (see the n-RRR step)
            V, S = mech.velocity_maps(q)
            J, G = S @ V, W @ V
            rhs = -np.einsum("kjt,kj->kt", G, f_t)
            JtJ = np.einsum("knt,kns->kts", J, J)
            tau_ff = tau_ff + np.einsum("knt,kt->kn", J, np.linalg.solve(JtJ, rhs[..., None])[..., 0])
    return References(t, p, th, th_d, th_dd, tau_ff, alpha, feasible)
