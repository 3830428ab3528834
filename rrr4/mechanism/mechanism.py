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
from dataclasses import replace

import casadi as ca
import numpy as np

from ..checks import describe
from ..errors import KinematicsError, SceneError
from ..functions import QUIET
from ..scene import GROUND, NRRRSpec, Scene, bare_nrrr_graph
from . import kinematics as kin
from .model import Model
from .modes import knee_conditions, mode_function, mode_values

__all__ = ["Mechanism", "NRRRMechanism", "wrap_angle"]

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
        self._memo: dict = {}  # what is derived from this mechanism, see memo
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
        # every row's gamma, the task rows' too: a task point off its body's origin moves on a
        # circle about it, so its acceleration has the centripetal part -omega^2 u
        qddm = ca.solve(A, gam + ca.vertcat(pad, tdd), "lapacklu")
        self.motion_function = ca.Function("motion", [qm, td, tdd], [qdm, qddm, Sm @ qdm, Sm @ qddm],
                                           ["q", "target_d", "target_dd"], ["qd", "qdd", "theta_d", "theta_dd"])
        self._n_rows = rows.numel()
        self._clearance_rows = [2 * self.joint_names.index(j) + k for j in model.clearance_joints for k in (0, 1)]
        # assembly: the residual's Jacobian (least squares from seeded starts) and the named mode
        p = ca.vertcat(target, offset)
        self._residual_jacobian = ca.Function("assembly_jacobian", [q, p], [residual, Jf])
        self.assembly = g.assembly
        self.mode_function = ca.Function("assembly_mode", [q], [mode_values(model, q, g.assembly)], ["q"], ["mode"])
        self.assembled_branch = None  # the branch the last assembly without a guess chose, see assemble
        self._rng_scale = _scene_scale(model)

    def memo(self, key, build):
        """build() once per mechanism and key: what is derived from this mechanism alone (its
        closed-form inverse dynamics, branch functions) lives on it and goes with it, never in
        a module-level cache keyed by the mechanism's identity. Mechanisms themselves are
        cached per scene graph (:meth:`from_scene`, the :data:`MECHANISMS` most recent)."""
        if key not in self._memo:
            self._memo[key] = build()
        return self._memo[key]

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
        body, minus it otherwise) with the task rows at `target`.

        With a `guess`: Newton from it (continuation; the caller owns the branch). Without:
        the scene's assembly, robust and on the named branch (``mechanism.assembly``): Newton
        from the bodies' pose guesses if the scene gives any (not all zero), then, unless that
        closed in the named mode, damped least squares from seeded starts (deterministic)
        polished by Newton, keeping the first closure in the named mode; angles wrapped to
        (-pi, pi]. Raises KinematicsError if it does not close."""
        target = _vector("target", target, self.n_task)
        off = np.zeros(self._n_rows)
        if offsets is not None:
            off[self._clearance_rows] = _vector("offsets", offsets, len(self._clearance_rows))
        p = np.r_[target, off]
        if guess is not None:
            q, res = self._newton(_vector("guess", guess, self.nq), p)
            if res > 1e-9:
                raise KinematicsError(f"the mechanism does not assemble at target {np.round(target, 6).tolist()} "
                                      f"(constraint residual {res:.3g} after Newton from the given guess)")
            return q
        return self._assemble_robust(target, p)

    # number of seeded starts the robust assembly tries before it gives up
    STARTS = 200

    def _newton(self, q0, p) -> tuple[np.ndarray, float]:
        """(q, max |residual|) by Newton from q0; inf when it fails or leaves finite numbers."""
        q = np.array(self.assemble_function(q0, p)).ravel()
        if not np.all(np.isfinite(q)):
            return q, np.inf
        res = np.array(self.closure_function(q, p)).ravel()
        return q, float(np.max(np.abs(res), initial=0.0))

    def _least_squares(self, q0, p, residual_jacobian=None) -> np.ndarray:
        """Levenberg-Marquardt on the residual from q0 (robust far from a solution: no
        singular Newton step, no NaN), a few dozen iterations at most; the assembly's residual
        unless `residual_jacobian` (q, p -> r, dr/dq) is given."""
        f = residual_jacobian or self._residual_jacobian
        q, lam = np.array(q0, float), 1e-3
        r, J = (np.array(v) for v in f(q, p))
        r = r.ravel()
        cost = r @ r
        for _ in range(100):
            if cost < 1e-20:
                break
            JtJ, g = J.T @ J, J.T @ r
            step = np.linalg.solve(JtJ + lam * (np.diag(np.diag(JtJ)) + 1e-9 * np.eye(self.nq)), -g)
            r1, J1 = (np.array(v) for v in f(q + step, p))
            r1 = r1.ravel()
            c1 = r1 @ r1
            if np.isfinite(c1) and c1 < cost:
                q, r, J, cost, lam = q + step, r1, J1, c1, max(lam / 3, 1e-12)
            else:
                lam *= 4
                if lam > 1e12:
                    break
        return q

    def mode_values(self, q) -> np.ndarray:
        """The measures of the scene's assembly conditions at q (one per mechanism.assembly
        entry): the normalised cross (bend) or dot (stretch) product, in [-1, 1]."""
        return np.array(self.mode_function(np.asarray(q, float))).ravel()

    def in_mode(self, q) -> bool:
        """True if q is on the named branch: every condition's measure has its sign (|measure| > 1e-6)."""
        signs = np.array([m.sign for m in self.assembly], float)
        return bool(np.all(self.mode_values(q) * signs > 1e-6))

    def _assemble_robust(self, target, p) -> np.ndarray:
        found = []
        best = np.inf
        if np.any(self.model.pose_guess != 0.0):
            q, res = self._newton(self.model.pose_guess, p)
            best = min(best, res)
            if res <= 1e-9:
                if self.in_mode(q):
                    return self._chosen(q)
                found.append(q)
        for q0 in self._seeds():
            q, res = self._newton(self._least_squares(q0, p), p)
            best = min(best, res)
            if res <= 1e-9:
                if self.in_mode(q):
                    return self._chosen(q)
                found.append(q)
        where = f"at target {np.round(target, 6).tolist()}"
        if not found:
            raise KinematicsError(f"the mechanism does not assemble {where} (smallest constraint residual "
                                  f"{best:.3g} from the pose guesses and {self.STARTS} seeded starts; check the "
                                  "geometry: link lengths that cannot close the loops, or a target out of reach)")
        seen = sorted({self.branch_text(f) for f in found})
        more = f"; and {len(seen) - 3} more" if len(seen) > 3 else ""
        raise KinematicsError(f"the mechanism does not assemble in the named mode {where} "
                              f"({self.mode_text()}); it closes only in {len(seen)} other branch(es): "
                              f"{'; '.join(seen[:3])}{more} (check mechanism.assembly)")

    def _seeds(self):
        """The seeded starts of the robust position analyses: :attr:`STARTS` configurations,
        every body at a random place of the scene's extent and a random angle (deterministic)."""
        rng = np.random.default_rng(20260)
        L, centre = self._rng_scale
        for _ in range(self.STARTS):
            q0 = np.empty(self.nq)
            q0.reshape(-1, 3)[:, :2] = centre + L * rng.uniform(-1.0, 1.0, (self.nq // 3, 2))
            q0.reshape(-1, 3)[:, 2] = rng.uniform(-np.pi, np.pi, self.nq // 3)
            yield q0

    def _chosen(self, q) -> np.ndarray:
        q = q.copy()
        q[2::3] = wrap_angle(q[2::3])
        self.assembled_branch = self.branch_text(q)
        return q

    def mode_text(self) -> str:
        """The named mode, e.g. 'bend + at C' (or 'none named')."""
        return ", ".join(f"{m.measure} {'+' if m.sign > 0 else '-'} at {m.joint}" for m in self.assembly) \
            or "none named"

    def branch_text(self, q) -> str:
        """The branch of q: at each joint of the named mode (with no mode named, at every
        revolute joint between two bodies with one other joint each, the loops' knees) the
        signs of bend and stretch and the angle from the first body's line to the second's,
        e.g. 'C: bend +, stretch - (+131.2 deg)'."""
        conds = {m.joint: m for m in self.assembly or self._knees()[0]}
        if not conds:
            return "the only one (no loop)"
        both = tuple(replace(m, measure=k) for m in conds.values() for k in ("bend", "stretch"))
        branch = self.memo(("branch", both), lambda: mode_function(self.model, both))
        v = np.array(branch(np.asarray(q, float))).ravel().reshape(-1, 2)

        def sign(x):
            return "+" if x > 1e-6 else "-" if x < -1e-6 else "0"

        return ", ".join(f"{j}: bend {sign(b)}, stretch {sign(d)} ({np.degrees(np.arctan2(b, d)):+.1f} deg)"
                         for j, (b, d) in zip(conds, v, strict=True))

    def _knees(self) -> tuple:
        """(the bend conditions at the loops' knees, their Function q -> values), built once."""
        def build():
            conds = knee_conditions(self.model)
            return conds, mode_function(self.model, conds)
        return self.memo(("knees",), build)

    def branches(self, target, starts: int = 48) -> list[np.ndarray]:
        """One closure q per assembly branch that closes at `target` (from the pose guesses and
        the first `starts` seeded starts), told apart by the bend sign at every knee (the joints
        :meth:`branch_text` reports when no mode is named); [] when the scene names its mode (an
        n-RRR names its chains' working modes) or has no knee."""
        conds, f = self._knees()
        if self.assembly or self.modes is not None or not conds:
            return []
        p = np.r_[_vector("target", target, self.n_task), np.zeros(self._n_rows)]
        found: dict = {}
        for q0 in itertools.chain([self.model.pose_guess], itertools.islice(self._seeds(), starts)):
            q, res = self._newton(self._least_squares(q0, p), p)
            signs = np.sign(np.array(f(q)).ravel()) if res <= 1e-9 else np.zeros(1)
            if np.all(signs != 0):
                found.setdefault(tuple(signs.astype(int)), self._chosen(q))
        return list(found.values())

    def branch_hint(self, target) -> str:
        """'' or one sentence for a scene that names no assembly mode where several branches
        close at `target`: how many, and the ``mechanism.assembly`` entries that name each."""
        found = self.branches(target)
        if len(found) < 2:
            return ""
        conds, f = self._knees()

        def entries(q):
            signs = np.array(f(q)).ravel()
            return "[" + ", ".join(f"{{joint: {c.joint}, bend: '{'+' if v > 0 else '-'}'}}"
                                   for c, v in zip(conds, signs, strict=True)) + "]"
        taken = entries(self.assemble(target))
        others = [e for e in map(entries, found) if e != taken]
        more = f"; and {len(others) - 3} more" if len(others) > 3 else ""
        return (f"{len(found)} assembly branches close here and the scene names none (the one taken: {taken}); "
                f"another may be the one meant: name it in mechanism.assembly, e.g. {'; '.join(others[:3])}{more}")

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
        if not self.model.graph.drivers:
            return np.zeros((len(t), 0))
        return np.array(self.model.driver_values(ca.DM(t).T)[0]).T.reshape(len(t), -1)

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
        """Actuator coordinates theta (n,) for a task pose (3,) (a point task: its x, y), on
        the scene's assembly mode (see :meth:`assemble`; modes: not used by a general graph)."""
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
        """Task pose for actuator coordinates theta: Newton on the constraints with the first
        actuators held, the others checked (|residual| <= tol). From the assembly at the task
        pose `guess` if one is given (continuation; the caller owns the branch); without one,
        as the n-RRR's closed form does, from the mechanism assembled with the task at the
        centre of the ground points (angle 0), then from the bodies' pose guesses, then from
        seeded starts (damped least squares on every constraint and actuator row, polished by
        Newton), keeping the first closure on the scene's named assembly mode (a parallel
        mechanism may close in several assembly modes for the same actuator coordinates: give
        `guess` to choose). Raises KinematicsError."""
        theta = _vector("theta", theta, self.n)
        if guess is not None:
            return self._fk_pose(self._fk_newton(theta, self.assemble(guess), tol))
        best, other = np.inf, 0
        starts = [q for q in (self._fk_start, self.model.pose_guess) if q is not None and np.any(q != 0.0)]
        for q0 in itertools.chain(starts, (self._least_squares(q, theta, self._fk_residual_jacobian)
                                           for q in self._seeds())):
            q, res = self._fk_solve(theta, q0)
            best = min(best, res)
            if res <= tol:
                if self.in_mode(q):
                    return self._fk_pose(q)
                other += 1
        raise KinematicsError(f"forward kinematics found no closure for theta {np.round(theta, 6).tolist()} "
                              + (f"on the named mode ({self.mode_text()}); {other} start(s) closed on another branch"
                                 if other else f"(smallest residual {best:.3g} from {self.STARTS} seeded starts: "
                                               "actuator coordinates the mechanism cannot take?)"))

    @functools.cached_property
    def _fk_start(self) -> np.ndarray | None:
        """The assembly with the task at the centre of the ground points (angle 0), or None
        where it does not assemble: fk's first start (built once)."""
        try:
            return self.assemble(np.r_[self._rng_scale[1], 0.0][:self.n_task])
        except KinematicsError:
            return None

    @functools.cached_property
    def _fk_function(self):
        q, th = ca.SX.sym("q", self.nq), ca.SX.sym("theta", self.n)
        rows = ca.vertcat(*[self.model.joint_equations(q, j) for j in self.joint_names])
        s, _ = self.model.actuator_coordinates_function(q)
        k = self.nq - rows.numel()
        f = ca.Function("fk_residual", [q, th], [ca.vertcat(rows, s[:k] - th[:k])])
        every = ca.vertcat(rows, s - th)
        return (ca.rootfinder("fk", "newton", f, NEWTON), ca.Function("all", [q, th], [every]),
                ca.Function("fk_jacobian", [q, th], [every, ca.jacobian(every, q)]))

    @property
    def _fk_residual_jacobian(self):
        return self._fk_function[2]

    def _fk_solve(self, theta, q0) -> tuple[np.ndarray, float]:
        """(q, max |residual| over every row) by Newton from q0; inf when not finite."""
        solve, check, _ = self._fk_function
        q = np.array(solve(q0, theta)).ravel()
        if not np.all(np.isfinite(q)):
            return q, np.inf
        return q, float(np.abs(np.array(check(q, theta)).ravel()).max())

    def _fk_newton(self, theta, q0, tol):
        q, res = self._fk_solve(theta, q0)
        if not res <= tol:
            raise KinematicsError(f"forward kinematics did not converge for theta {np.round(theta, 6).tolist()} "
                                  f"(residual {res:.3g} > {tol:g}); try another guess")
        return q

    def _fk_pose(self, q) -> np.ndarray:
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

    def assemble(self, target, offsets=None, guess=None) -> np.ndarray:
        """As :meth:`Mechanism.assemble`; without a guess, Newton from the closed-form
        coordinates in the scene's working modes (the bare graph names no assembly mode, so the
        seeded search could close on another elbow)."""
        if guess is None:
            target = _vector("target", target, self.n_task)
            guess = self.body_motion(target)[0]
            if not np.all(np.isfinite(guess)):
                raise KinematicsError(f"the mechanism does not assemble at target {np.round(target, 6).tolist()} "
                                      "(a chain cannot reach it in its working mode)")
        return super().assemble(target, offsets, guess)

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


def wrap_angle(a):
    """a wrapped to (-pi, pi]."""
    a = np.asarray(a, float)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def _scene_scale(model: Model) -> tuple[float, np.ndarray]:
    """(L, centre): a length [m] covering the mechanism (the sum of every body's point spans
    and the ground points' spread) and the centre of the ground points, for seeded starts."""
    ground = [p for j in model.graph.joints for b, p in zip(j.bodies, j.points, strict=True) if b == GROUND]
    centre = np.mean(ground, axis=0) if ground else np.zeros(2)
    L = sum(float(np.max(np.linalg.norm(np.array([p for _, p in b.points]), axis=1), initial=0.0))
            for b in model.graph.bodies if b.points)
    if ground:
        L += float(np.max(np.linalg.norm(np.array(ground) - centre, axis=1)))
    return max(L, 1e-3), centre


MECHANISMS = 64  # mechanisms kept per scene graph (a geometry sweep makes one per case)


@functools.lru_cache(maxsize=MECHANISMS)
def _nrrr(data: NRRRSpec, graph) -> NRRRMechanism:
    return NRRRMechanism(data, graph)


@functools.lru_cache(maxsize=MECHANISMS)
def _generic(graph) -> Mechanism:
    return Mechanism(Model.of(graph))
