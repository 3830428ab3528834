"""The effort family along a path as an affine function of the path speed.

On the path geometry pose(s), s in [0, 1] (:func:`rrr4.trajectory.path_geometry_function`),
a time law enters the task motion only through b = s_dot^2 and a = s_ddot:
pose_d = pose_s sqrt(b), pose_dd = pose_s a + pose_ss b. The ideal inverse dynamics are
linear in the accelerations and quadratic in the velocities, so at each grid point every
actuator effort and every passive-joint reaction is

    tau = tau_a a + tau_b b + tau_g + tau_n alpha,   r_j = r_a a + r_b b + r_g + r_n alpha

(DESIGN.md §10; Verscheure et al. 2009). The coefficients come from the problem's own
effort family (:meth:`rrr4.problem.Problem.effort_family`: the closed form of an n-RRR or
the graph's SVD) evaluated at three motions: at rest with the scene's gravity (tau_g), and
without gravity at pose_dd = pose_s (tau_a) and at (pose_d, pose_dd) = (pose_s, pose_ss)
(tau_b). These are exact, not finite differences: the family is affine in (a, b) and the
null-space part depends on the pose only. For an n-RRR the geometry and the three
evaluations are one SX Function of s (common subexpressions shared), mapped once over all
grid points: one CasADi call per path.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..dynamics.family import EffortFamily
from ..functions import evaluate, mapped_function, nonzeros
from ..problem import Problem
from ..trajectory import path_geometry_function

__all__ = ["PathFamily", "path_family"]


@dataclass(frozen=True)
class PathFamily:
    """Coefficients at N grid points s (N,): pose, pose_s, pose_ss (N, 3); efforts
    tau_a, tau_b, tau_g (N, n) [N m or N, per unit a or b], tau_n (N, n, m); passive-joint
    reactions r_a, r_b, r_g (N, nj, 2) [N], r_n (N, nj, 2, m)."""
    s: np.ndarray
    pose: np.ndarray
    pose_s: np.ndarray
    pose_ss: np.ndarray
    tau_a: np.ndarray
    tau_b: np.ndarray
    tau_g: np.ndarray
    tau_n: np.ndarray
    r_a: np.ndarray
    r_b: np.ndarray
    r_g: np.ndarray
    r_n: np.ndarray

    def efforts(self, a, b, alpha) -> np.ndarray:
        """(N, n) efforts at accelerations a (N,), squared speeds b (N,), null-space efforts alpha (N, m)."""
        return (self.tau_a * a[:, None] + self.tau_b * b[:, None] + self.tau_g
                + np.einsum("knm,km->kn", self.tau_n, alpha))

    def reactions(self, a, b, alpha) -> np.ndarray:
        """(N, nj, 2) passive-joint reactions [N] at a, b, alpha (see :meth:`efforts`)."""
        return (self.r_a * a[:, None, None] + self.r_b * b[:, None, None] + self.r_g
                + np.einsum("kjcm,km->kjc", self.r_n, alpha))


def path_family(problem: Problem, s) -> PathFamily:
    """The :class:`PathFamily` of `problem`'s path at progress values s (N,) in [0, 1]."""
    s = np.asarray(s, float).ravel()
    N = len(s)
    if problem.closed_form_family:
        out = _evaluate(mapped_function(_family_function(problem), N), s)
        pose, pose_s, pose_ss = (v.T for v in out[:3])
        acc, vel, rest = (EffortFamily.from_raw(out[i:i + 4]) for i in (3, 7, 11))
        return PathFamily(s, pose, pose_s, pose_ss, acc.tau_p, vel.tau_p, rest.tau_p, rest.tau_n,
                          acc.r_p, vel.r_p, rest.r_p, rest.r_n)
    pose, pose_s, pose_ss = (np.array(v).T for v in path_geometry_function(problem.path).map(N)(s[None, :]))
    zero = np.zeros_like(pose)
    # a graph's coordinates along the path once for the three evaluations (Newton, continuation)
    q = problem.path_coordinates(pose, zero, zero)
    rest = problem.effort_family(pose, zero, zero, q=q)
    acc = problem.effort_family(pose, zero, pose_s, q=q, gravity=(0.0, 0.0))
    vel = problem.effort_family(pose, pose_s, pose_ss, q=q, gravity=(0.0, 0.0))
    return PathFamily(s, pose, pose_s, pose_ss, acc.tau_p, vel.tau_p, rest.tau_p, rest.tau_n,
                      acc.r_p, vel.r_p, rest.r_p, rest.r_n)


def _evaluate(f: ca.Function, s: np.ndarray) -> list[np.ndarray]:
    """f(s) as dense numpy arrays through CasADi's buffers (half the CPU time of a call that
    returns DMs, measured at N = 1000)."""
    res = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
    evaluate(f, [np.ascontiguousarray(s, float)], res)
    out = []
    for i, r in enumerate(res):
        sp = f.sparsity_out(i)
        dense = np.zeros(sp.numel())
        dense[nonzeros(sp)] = r
        out.append(dense.reshape(sp.size2(), sp.size1()).T)
    return out


def _family_function(problem: Problem) -> ca.Function:
    """SX Function of s: pose, pose_s, pose_ss, then the n-RRR's closed-form inverse dynamics
    (tau_p, tau_n, r_p, r_n) at pose_dd = pose_s, at (pose_d, pose_dd) = (pose_s, pose_ss)
    (both without gravity) and at rest (with it); built once per problem."""
    def build():
        s = ca.SX.sym("s")
        geometry = list(path_geometry_function(problem.path)(s))
        pose, pose_s, pose_ss = geometry
        zero = ca.SX.zeros(3)
        inertial = problem.inverse_dynamics((0.0, 0.0))
        out = geometry + list(inertial(pose, zero, pose_s)) + list(inertial(pose, pose_s, pose_ss)) \
            + list(problem.inverse_dynamics()(pose, zero, zero))
        return ca.Function("path_family", [s], ca.cse(out))
    return problem.memo(("path_family",), build)
