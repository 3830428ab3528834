"""Kinematics of a scene's mechanism: task IK, FK, Jacobian and null space.

:class:`Mechanism` works on any body/joint graph (:class:`~rrr4.mechanism.model.Model`):
position analysis by Newton on the constraint equations (CasADi ``rootfinder``), velocity
and acceleration analysis by linear solves, the actuator Jacobian J (d theta = J d pose)
and its null space. :class:`NRRRMechanism` is the n-RRR specialisation with the closed-form
IK (Zhang & Zhang 2017) that n-RRR scenes use.

pose = [x, y, theta] of the task body in m, m, rad; theta = actuator coordinates (n,) in
rad (revolute) or m (prismatic).
"""

from __future__ import annotations

import functools
import itertools

import casadi as ca
import numpy as np

from ..checks import describe
from ..errors import KinematicsError, SceneError
from ..functions import QUIET
from ..scene import NRRRSpec, Scene, bare_nrrr_graph
from . import kinematics as kin
from .model import Model

__all__ = ["Mechanism", "NRRRMechanism"]

NEWTON = {"abstol": 1e-13, "max_iter": 60, "error_on_fail": False, **QUIET}


def _vector(key: str, v, n: int) -> np.ndarray:
    """`v` as a finite float vector of n entries, or a one-line SceneError naming `key`."""
    try:
        x = np.asarray(v, float).ravel()
    except (TypeError, ValueError):
        x = None
    if x is None or x.size != n or not np.all(np.isfinite(x)):
        raise SceneError(f"{key}: {describe(v)} is not allowed (a vector of {n} finite numbers)")
    return x


class Mechanism:
    """Kinematics of any graph. Build with :meth:`from_scene` (cached per scene graph).

    The position analysis solves, from a guess, Phi_k(q) = o_k for every joint k (o_k = 0
    for an ideal joint, the eccentricity of a clearance joint) and the task rows: the task
    body's pose = pose (3 rows), or, without a task, each driver's coordinate = its value.
    """

    def __init__(self, model: Model):
        self.model = model
        self.n = model.n_actuators
        self.nq = model.nq
        self.modes = None
        self.body_names = model.body_names
        self.joint_names = model.joint_names
        q, qd = ca.SX.sym("q", self.nq), ca.SX.sym("qd", self.nq)
        g = model.graph
        rows = ca.vertcat(*[model.joint_equations(q, j) for j in self.joint_names])
        if model.task is not None:
            task = model.task_pose(q)[:model.task_dof]
        else:
            task = ca.vertcat(*[model.joint_coordinate(q, d.joint) for d in g.drivers]) if g.drivers else ca.SX(0, 1)
        self.n_task = task.numel()
        if rows.numel() + self.n_task != self.nq:
            dof = self.nq - rows.numel()
            need = (f"a task of {self.n_task} coordinates" if model.task is not None else f"{self.n_task} driver(s)")
            raise SceneError(f"mechanism: the graph has {dof} degrees of freedom with every joint closed, and "
                             f"{need} cannot fix them (a task body needs 3 DOF, a task point 2; otherwise give one "
                             "driver per DOF)")
        target = ca.SX.sym("target", self.n_task)
        offset = ca.SX.sym("offset", rows.numel())
        residual = ca.vertcat(rows - offset, task - target)
        closure = ca.Function("closure", [q, ca.vertcat(target, offset)], [residual], ["q", "p"], ["residual"])
        self.assemble_function = ca.rootfinder("assemble", "newton", closure, NEWTON)
        self.closure_function = closure
        Jf = ca.jacobian(residual, q)
        gamma = -ca.jtimes(Jf @ qd, q, qd)
        s, S = model.actuator_coordinates_function(q)
        self.constraint_jacobian_function = ca.Function(
            "constraint_jacobian", [q, qd], [Jf, gamma, s, S], ["q", "qd"], ["Phi_q", "gamma", "s", "S"])
        # velocity and acceleration analysis (MX, one sparse LU per call)
        qm, td, tdd = ca.MX.sym("q", self.nq), ca.MX.sym("target_d", self.n_task), ca.MX.sym("target_dd", self.n_task)
        A, _, _, Sm = self.constraint_jacobian_function(qm, ca.MX.zeros(self.nq))
        pad = ca.MX.zeros(rows.numel())
        qdm = ca.solve(A, ca.vertcat(pad, td), "lapacklu")
        _, gam, _, _ = self.constraint_jacobian_function(qm, qdm)
        qddm = ca.solve(A, ca.vertcat(gam[:rows.numel()], tdd), "lapacklu")
        self.motion_function = ca.Function("motion", [qm, td, tdd], [qdm, qddm, Sm @ qdm, Sm @ qddm],
                                           ["q", "target_d", "target_dd"], ["qd", "qdd", "theta_d", "theta_dd"])
        self._n_rows = rows.numel()
        self._clearance_rows = [2 * self.joint_names.index(j) + k for j in model.clearance_joints for k in (0, 1)]

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_scene(cls, scene: Scene | NRRRSpec) -> Mechanism:
        if isinstance(scene, NRRRSpec):
            return _nrrr(scene, None)
        if scene.mechanism is not None:
            return _nrrr(scene.mechanism, scene.graph)
        return _generic(scene.graph)

    # ------------------------------------------------------------------ position analysis

    def assemble(self, target, offsets=None, guess=None) -> np.ndarray:
        """q (nq,) closing every joint (clearance joint k opened by offsets (nc, 2) [m], its
        second point minus its first: the eccentricity when the journal sits on the second
        body, minus it otherwise) with the task rows at `target`; Newton from `guess`
        (default: the bodies' pose guesses). Raises KinematicsError if it does not close."""
        target = _vector("target", target, self.n_task)
        off = np.zeros(self._n_rows)
        if offsets is not None:
            off[self._clearance_rows] = _vector("offsets", offsets, len(self._clearance_rows))
        guess = self.model.pose_guess if guess is None else _vector("guess", guess, self.nq)
        p = np.r_[target, off]
        q = np.array(self.assemble_function(guess, p)).ravel()
        res = np.array(self.closure_function(q, p)).ravel()
        if not (np.all(np.isfinite(q)) and np.max(np.abs(res), initial=0.0) <= 1e-9):
            raise KinematicsError(f"the mechanism does not assemble at target {np.round(target, 6).tolist()} "
                                  f"(constraint residual {np.max(np.abs(res)):.3g} after Newton from the pose "
                                  "guesses; check the geometry, or give bodies[].pose closer to an assembly)")
        return q

    def tracked_coordinates(self, targets, q0) -> tuple[np.ndarray, np.ndarray]:
        """(q (N, nq), closed (N,) bool) along targets (N, n_task), by continuation from q0:
        each Newton solve starts from the last solution that closed (one ``mapaccum``, no Python
        loop); q is NaN where the mechanism does not close (residual above 1e-9)."""
        targets = np.atleast_2d(np.asarray(targets, float))
        N = targets.shape[0]
        qs, t = ca.MX.sym("q", self.nq), ca.MX.sym("t", self.n_task)
        p = ca.vertcat(t, ca.MX.zeros(self._n_rows))
        q1 = self.assemble_function(qs, p)
        res = ca.norm_inf(self.closure_function(q1, p))
        closed = ca.logic_and(ca.fabs(ca.sum1(q1)) < np.inf, res <= 1e-9)  # |sum| < inf: finite
        track = ca.Function("track", [qs, t], [ca.if_else(closed, q1, qs), q1, closed])
        _, Q, ok = (np.array(v) for v in track.mapaccum(N)(np.asarray(q0, float), targets.T))
        ok = ok.ravel() > 0.5
        Q = Q.T
        Q[~ok] = np.nan
        return Q, ok

    def path_coordinates(self, targets, guess=None) -> np.ndarray:
        """q (N, nq) along targets (N, n_task), each Newton solve started from the previous
        solution (one ``mapaccum``, no Python loop). Raises KinematicsError where it fails."""
        targets = np.atleast_2d(np.asarray(targets, float))
        Q, ok = self.tracked_coordinates(targets, self.assemble(targets[0], guess=guess))
        bad = np.flatnonzero(~ok)
        if bad.size:
            raise KinematicsError(f"the mechanism does not assemble along the path from sample {bad[0]} "
                                  f"(target {np.round(targets[bad[0]], 6).tolist()})")
        return Q

    def driver_targets(self, t) -> np.ndarray:
        """(N, n_drivers) prescribed driver coordinates at times t (N,) [s]."""
        t = np.atleast_1d(np.asarray(t, float))
        return np.column_stack([d.initial + d.speed * t for d in self.model.graph.drivers] or [np.zeros((len(t), 0))])

    def path_jacobians(self, q) -> np.ndarray:
        """J (N, n, n_task) at states q (N, nq) of a task-driven graph: d theta = J d task."""
        V, S = self.velocity_maps(q)
        return S @ V

    def velocity_maps(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(V (N, nq, n_task), S (N, n, nq)) at states q (N, nq) of a task-driven graph:
        qd = V task_d (velocity analysis) and theta_d = S qd."""
        N = q.shape[0]
        Jf, _, _, S = (np.array(v).reshape(v.shape[0], N, v.shape[1] // N).transpose(1, 0, 2)
                       for v in self.constraint_jacobian_function.map(N)(q.T, np.zeros((self.nq, N))))
        rhs = np.vstack([np.zeros((self._n_rows, self.n_task)), np.eye(self.n_task)])
        return np.linalg.solve(Jf, np.broadcast_to(rhs, (N, *rhs.shape))), S

    def motion(self, q, target_d, target_dd):
        """(qd, qdd, theta_d, theta_dd) for q (N, nq) and task-row rates (N, n_task)."""
        q = np.atleast_2d(q)
        N = q.shape[0]
        out = self.motion_function.map(N)(q.T, np.atleast_2d(target_d).T, np.atleast_2d(target_dd).T)
        return tuple(np.array(v).T for v in out)

    # ------------------------------------------------------------------ public kinematics

    def body_motion(self, pose, pose_d=None, pose_dd=None):
        """q, qd, qdd (each (nq,)) of all bodies for a task pose and its rates (a point task
        uses their first two entries)."""
        k = self.n_task
        z = np.zeros(k)
        q = self.assemble(np.asarray(pose, float)[:k])
        qd, qdd, _, _ = self.motion(q, z if pose_d is None else np.asarray(pose_d, float)[:k],
                                    z if pose_dd is None else np.asarray(pose_dd, float)[:k])
        return q, qd.ravel(), qdd.ravel()

    def seated_coordinates(self, pose, offsets) -> np.ndarray:
        """q (nq,) with the task at pose and every clearance joint opened by its offset
        (nc, 2) [m] (second point minus first, see :meth:`assemble`), by Newton."""
        return self.assemble(pose, offsets, guess=self.assemble(pose))

    def actuator_coordinates(self, q) -> np.ndarray:
        return np.array(self.model.actuator_coordinates_function(np.asarray(q, float))[0]).ravel()

    def ik(self, pose, modes=None) -> np.ndarray:
        """Actuator coordinates theta (n,) for a task pose (3,) (a point task: its x, y), by
        Newton on the constraints from the bodies' pose guesses (modes: not used by a general graph)."""
        return self.actuator_coordinates(self.assemble(np.asarray(pose, float)[:self.n_task]))

    def jacobian(self, pose) -> np.ndarray:
        """J (n x n_task) with d theta = J d task (n_task = 3 for a body, 2 for a point)."""
        q = self.assemble(np.asarray(pose, float)[:self.n_task])
        Jf, _, _, S = (np.array(v) for v in self.constraint_jacobian_function(q, np.zeros(self.nq)))
        k = self.n_task
        return S @ np.linalg.solve(Jf, np.vstack([np.zeros((self._n_rows, k)), np.eye(k)]))

    def null_space(self, pose) -> np.ndarray:
        """Unit null-space basis of J^T: (n,) for one degree of redundancy, else (n, m)."""
        u, _, _ = np.linalg.svd(self.jacobian(pose))
        ns = u[:, self.n_task:]
        return ns[:, 0] if ns.shape[1] == 1 else ns

    def fk(self, theta, guess=None, tol: float = 1e-9) -> np.ndarray:
        """Task pose (3,) for actuator coordinates theta, by Newton on the constraints with
        the first actuators held; the others are checked (|residual| <= tol)."""
        theta = np.asarray(theta, float).ravel()
        q0 = self.model.pose_guess if guess is None else self.assemble(guess)
        return self._fk_newton(theta, q0, tol)

    @functools.cached_property
    def _fk_function(self):
        q, th = ca.SX.sym("q", self.nq), ca.SX.sym("theta", self.n)
        rows = ca.vertcat(*[self.model.joint_equations(q, j) for j in self.joint_names])
        s, _ = self.model.actuator_coordinates_function(q)
        k = self.nq - rows.numel()
        f = ca.Function("fk_residual", [q, th], [ca.vertcat(rows, s[:k] - th[:k])])
        return ca.rootfinder("fk", "newton", f, NEWTON), ca.Function("all", [q, th], [ca.vertcat(rows, s - th)])

    def _fk_newton(self, theta, q0, tol):
        solve, check = self._fk_function
        q = np.array(solve(q0, theta)).ravel()
        res = np.abs(np.array(check(q, theta)).ravel())
        if not (np.all(np.isfinite(q)) and res.max() <= tol):
            raise KinematicsError(f"forward kinematics did not converge for theta {np.round(theta, 6).tolist()} "
                                  f"(residual {res.max():.3g} > {tol:g}); try another guess")
        pose = np.array(self.model.task_pose_function(q)).ravel()
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        return pose[:self.n_task]


class NRRRMechanism(Mechanism):
    """n-RRR kinematics in closed form (Zhang & Zhang 2017); everything else as :class:`Mechanism`."""

    def __init__(self, data: NRRRSpec, graph=None):
        super().__init__(Model.of(graph or bare_nrrr_graph(data)))
        self.data = data
        self.n = n = data.n_chains
        self.modes = np.array([c.working_mode for c in data.chains], dtype=float)

        pose = ca.SX.sym("pose", 3)
        pose_d = ca.SX.sym("pose_d", 3)
        pose_dd = ca.SX.sym("pose_dd", 3)
        modes = ca.SX.sym("modes", n)
        q = ca.SX.sym("q", self.nq)
        qd = ca.SX.sym("qd", self.nq)
        theta = ca.SX.sym("theta", n)

        # --- inverse kinematics (closed form), both branches via `modes`
        iks = [kin.chain_ik(data, i, pose, modes[i]) for i in range(n)]
        self.ik_function = ca.Function(
            "ik", [pose, modes], [ca.vertcat(*[r[0] for r in iks]), ca.vertcat(*[r[1] for r in iks])],
            ["pose", "modes"], ["theta", "cos_arg"])

        # --- body coordinates and their rates along a platform motion (scene's modes)
        m = ca.DM(self.modes)
        qp = kin.body_coordinates(data, pose, m)
        qp_d = ca.jtimes(qp, pose, pose_d)
        qp_dd = ca.jtimes(qp_d, pose, pose_d) + ca.jtimes(qp_d, pose_d, pose_dd)
        ecc = ca.SX.sym("eccentricity", 2, 2 * n)
        self.seated_coordinates_function = ca.Function(
            "seated_coordinates", [pose, ecc], [kin.body_coordinates(data, pose, m, ecc)],
            ["pose", "eccentricity"], ["q"])
        self.body_motion_function = ca.Function(
            "body_motion", [pose, pose_d, pose_dd], [qp, qp_d, qp_dd],
            ["pose", "pose_d", "pose_dd"], ["q", "qd", "qdd"])

        # --- Jacobian J (n x 3), dtheta = J dpose, and the unit null space of J^T
        A, den = kin.jacobian_parts(data, pose, m)
        iks_m = [kin.chain_ik(data, i, pose, m[i]) for i in range(n)]
        J = ca.diag(1.0 / den) @ A
        sin_transmission = ca.vertcat(*[
            kin.cross(kin.unit(iks_m[i][0]), iks_m[i][3] - iks_m[i][2])
            / data.chains[i].following.length for i in range(n)])
        self.jacobian_function = ca.Function(
            "jacobian", [pose], [J, A, den, sin_transmission],
            ["pose"], ["J", "A", "den", "sin_transmission"])
        if n == 4:
            JT = J.T
            cof = ca.vertcat(*[(-1) ** k * ca.det(JT[:, [c for c in range(4) if c != k]]) for k in range(4)])
            nvec = cof / ca.norm_2(cof)
            self.null_space_function = ca.Function("null_space", [pose], [nvec], ["pose"], ["n"])
        else:
            self.null_space_function = None

        # --- joint points: column j = outboard point - inboard point (0 for an ideal pin)
        pts = kin.joint_points(data, q)
        gap = ca.horzcat(*[o - i for _, i, o in pts])
        self.joint_gap_function = ca.Function("joint_gap", [q], [gap], ["q"], ["gap"])
        self.joint_point_function = ca.Function(
            "joint_points", [q], [ca.horzcat(*[i for _, i, _ in pts]), ca.horzcat(*[o for _, _, o in pts])],
            ["q"], ["inboard", "outboard"])
        self._q, self._qd, self._gap = q, qd, gap

        # --- forward kinematics: Newton on the loop closure of the first three chains
        res = []
        for i in range(3):
            c = data.chains[i]
            B = ca.DM(c.base) + c.driving.length * kin.unit(theta[i])
            C = kin.platform_point(data, i, pose)
            res.append((ca.sumsqr(C - B) - c.following.length**2) / c.following.length)
        closure = ca.Function("closure", [pose, theta], [ca.vertcat(*res)], ["pose", "theta"], ["residual"])
        self.fk_function = ca.rootfinder("fk", "newton", closure,
                                         {**NEWTON, "abstol": 1e-14, "max_iter": 50})
        all_res = []
        for i, c in enumerate(data.chains):
            B = ca.DM(c.base) + c.driving.length * kin.unit(theta[i])
            all_res.append(ca.norm_2(kin.platform_point(data, i, pose) - B) - c.following.length)
        self.loop_residual_function = ca.Function(
            "loop_residual", [pose, theta], [ca.vertcat(*all_res)], ["pose", "theta"], ["residual"])

    def constraints(self, joints: tuple[str, ...] | None = None) -> ca.Function:
        """Ideal-joint constraints of the named joints (default: all 3n), see :meth:`Model.constraints`."""
        return self.model.constraints(self.joint_names if joints is None else tuple(joints))

    # ------------------------------------------------------------------ numeric API

    def _modes(self, modes):
        if modes is None:
            return self.modes
        m = np.asarray(modes, dtype=float).reshape(-1)
        if m.shape != (self.n,) or not np.all(np.abs(m) == 1):
            raise ValueError(f"modes: {modes!r} is not allowed (a list of {self.n} values, each +1 or -1)")
        return m

    def ik(self, pose, modes=None) -> np.ndarray:
        """Actuator angles theta (n,) [rad] for pose (3,); modes (n,) of +-1 (default: scene's).

        Raises KinematicsError if a chain cannot reach the pose.
        """
        theta, cos_arg = self.ik_function(np.asarray(pose, float), self._modes(modes))
        cos_arg = np.array(cos_arg).ravel()
        bad = np.flatnonzero(~(np.abs(cos_arg) <= 1.0))
        if bad.size:
            raise KinematicsError(f"pose {np.round(pose, 6).tolist()} is out of reach of chain {bad[0] + 1} "
                                  f"(cos argument {cos_arg[bad[0]]:.12g}, allowed [-1, 1])")
        return np.array(theta).ravel()

    def jacobian(self, pose) -> np.ndarray:
        """J (n x 3) with dtheta = J dpose."""
        return np.array(self.jacobian_function(np.asarray(pose, float))[0])

    def null_space(self, pose) -> np.ndarray:
        """Unit null-space basis of J^T: (4,) for a 4-RRR; (n, n-3) otherwise."""
        if self.null_space_function is not None:
            return np.array(self.null_space_function(np.asarray(pose, float))).ravel()
        J = self.jacobian(pose)
        u, _, _ = np.linalg.svd(J)
        return u[:, 3:]

    def body_motion(self, pose, pose_d=None, pose_dd=None):
        """q, qd, qdd (each (nq,)) of all bodies for a platform pose and its rates."""
        z = np.zeros(3)
        out = self.body_motion_function(np.asarray(pose, float),
                                        z if pose_d is None else np.asarray(pose_d, float),
                                        z if pose_dd is None else np.asarray(pose_dd, float))
        return tuple(np.array(v).ravel() for v in out)

    def seated_coordinates(self, pose, eccentricity) -> np.ndarray:
        """q (nq,) with the platform at pose (3,) and each passive joint B1..Bn, C1..Cn
        opened by its eccentricity (2n, 2) [m] (outboard point - inboard point)."""
        e = np.asarray(eccentricity, float).reshape(2 * self.n, 2).T
        return np.array(self.seated_coordinates_function(np.asarray(pose, float), e)).ravel()

    def fk(self, theta, guess=None, tol: float = 1e-9) -> np.ndarray:
        """Platform pose (3,) from actuator angles by Newton from `guess`
        (default: centroid of the bases, theta_o = 0). Raises KinematicsError when Newton
        fails or the remaining chains do not close (|residual| > tol m).
        """
        theta = np.asarray(theta, float).ravel()
        if guess is None:
            guess = np.r_[np.mean([c.base for c in self.data.chains], axis=0), 0.0]
        pose = np.array(self.fk_function(np.asarray(guess, float), theta)).ravel()
        res = np.array(self.loop_residual_function(pose, theta)).ravel()
        if not np.all(np.isfinite(pose)) or np.max(np.abs(res)) > tol:
            raise KinematicsError(f"forward kinematics did not converge for theta {np.round(theta, 6).tolist()} "
                                  f"(loop residual {np.max(np.abs(res)):.3g} m > {tol:g} m); try another guess")
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        return pose

    def assembly_modes(self, theta, grid: int = 7, tol: float = 1e-9) -> np.ndarray:
        """All platform poses (k, 3) that close every chain for these actuator angles,
        found by Newton from a grid of guesses over the workspace and orientation."""
        bases = np.array([c.base for c in self.data.chains])
        lo, hi = bases.min(axis=0), bases.max(axis=0)
        found: list[np.ndarray] = []
        for x, y, phi in itertools.product(np.linspace(lo[0], hi[0], grid), np.linspace(lo[1], hi[1], grid),
                                           np.linspace(-np.pi, np.pi, 2 * grid, endpoint=False)):
            try:
                p = self.fk(theta, guess=(x, y, phi), tol=tol)
            except KinematicsError:
                continue
            if not any(np.linalg.norm(np.r_[p[:2] - f[:2], np.angle(np.exp(1j * (p[2] - f[2])))]) < 1e-7
                       for f in found):
                found.append(p)
        return np.array(found).reshape(-1, 3)


@functools.cache
def _nrrr(data: NRRRSpec, graph) -> NRRRMechanism:
    return NRRRMechanism(data, graph)


@functools.cache
def _generic(graph) -> Mechanism:
    return Mechanism(Model.of(graph))
