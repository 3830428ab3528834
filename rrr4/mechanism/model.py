"""`Mechanism`: the immutable symbolic model of an n-RRR, built once per scene.

All CasADi Functions are SX, named, with named inputs/outputs, and built when the
model is created. Numeric wrappers take and return numpy arrays.
pose = [x, y, theta_o] in m, m, rad; theta = actuator angles (n,) in rad.
"""

from __future__ import annotations

import functools
import itertools

import casadi as ca
import numpy as np

from ..errors import KinematicsError
from ..scene import Mechanism_, Scene
from . import kinematics as kin

__all__ = ["Mechanism"]


class Mechanism:
    """Symbolic kinematics of one mechanism. Build with :meth:`from_scene` (cached)."""

    def __init__(self, data: Mechanism_):
        self.data = data
        self.n = n = data.n_chains
        self.modes = np.array([c.working_mode for c in data.chains], dtype=float)
        self.nq = 3 * (2 * n + 1)
        self.body_names = tuple(f"{i + 1}{k}" for i in range(n) for k in (1, 2)) + ("o",)
        self.joint_names = tuple(f"{p}{i + 1}" for p in "ABC" for i in range(n))

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
        self._constraint_cache: dict[tuple[str, ...], ca.Function] = {}

        # --- forward kinematics: Newton on the loop closure of the first three chains
        res = []
        for i in range(3):
            c = data.chains[i]
            B = ca.DM(c.base) + c.driving.length * kin.unit(theta[i])
            C = kin.platform_point(data, i, pose)
            res.append((ca.sumsqr(C - B) - c.following.length**2) / c.following.length)
        closure = ca.Function("closure", [pose, theta], [ca.vertcat(*res)], ["pose", "theta"], ["residual"])
        self.fk_function = ca.rootfinder("fk", "newton", closure,
                                         {"abstol": 1e-14, "max_iter": 50, "error_on_fail": False})
        all_res = []
        for i, c in enumerate(data.chains):
            B = ca.DM(c.base) + c.driving.length * kin.unit(theta[i])
            all_res.append(ca.norm_2(kin.platform_point(data, i, pose) - B) - c.following.length)
        self.loop_residual_function = ca.Function(
            "loop_residual", [pose, theta], [ca.vertcat(*all_res)], ["pose", "theta"], ["residual"])

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_scene(cls, scene: Scene | Mechanism_) -> Mechanism:
        data = scene.mechanism if isinstance(scene, Scene) else scene
        return _cached(data)

    # ------------------------------------------------------------------ constraints

    def constraints(self, joints: tuple[str, ...] | None = None) -> ca.Function:
        """Ideal-joint constraints Phi(q) = 0 for the named joints (default: all 3n).

        Returns Function 'constraints': q, qd -> phi (2m,), phi_q (2m x nq),
        gamma (2m,) with Phi_q qdd = gamma, gamma = -(Phi_q qd)_q qd.
        Rows come in joint order as given, x then y per joint.
        """
        joints = self.joint_names if joints is None else tuple(joints)
        if joints not in self._constraint_cache:
            self._constraint_cache[joints] = self._build_constraints(joints)
        return self._constraint_cache[joints]

    def _build_constraints(self, joints: tuple[str, ...]) -> ca.Function:
        idx = [self.joint_names.index(j) for j in joints]
        phi = ca.vertcat(*[self._gap[:, k] for k in idx]) if idx else ca.SX(0, 1)
        phi_q = ca.jacobian(phi, self._q)
        gamma = -ca.jtimes(phi_q @ self._qd, self._q, self._qd)
        return ca.Function("constraints", [self._q, self._qd], [phi, phi_q, gamma],
                           ["q", "qd"], ["phi", "phi_q", "gamma"])

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
            raise KinematicsError(f"pose {list(np.round(pose, 6))} is out of reach of chain {bad[0] + 1} "
                                  f"(cos argument {cos_arg[bad[0]]:.6g}, allowed [-1, 1])")
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
            raise KinematicsError(f"forward kinematics did not converge for theta {list(np.round(theta, 6))} "
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
def _cached(data: Mechanism_) -> Mechanism:
    return Mechanism(data)
