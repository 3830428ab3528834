"""Checks a scene against its model: the mechanism assembles along the whole motion, and
the task path stays inside the workspace and away from singularities. :func:`load_scene`
is the front door that reads a scene file and runs these checks."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import KinematicsError, SceneError
from ..scene import PathSpec, Scene, read_scene
from ..trajectory import PathSamples, sample_path
from .mechanism import Mechanism, NRRRMechanism

__all__ = ["PathKinematics", "path_kinematics", "check_scene", "load_scene", "near_singular"]


@dataclass(frozen=True)
class PathKinematics:
    """Kinematic quality along the sampled path (n actuators; n-RRR fields None otherwise)."""
    t: np.ndarray                        # (N,) [s]
    condition: np.ndarray                # (N,) 2-norm condition number of J (1 without a task)
    cos_arg: np.ndarray | None           # (N, n) n-RRR IK acos argument; |.| <= 1 where reachable
    sin_transmission: np.ndarray | None  # (N, n) n-RRR: sin of the angle between driving and following link
    mode: np.ndarray | None = None       # (N, k) graph: the measures of the named assembly mode's k conditions

    @property
    def worst_condition(self) -> tuple[float, float]:
        k = int(np.argmax(self.condition))
        return float(self.condition[k]), float(self.t[k])


def condition_number(J: np.ndarray) -> np.ndarray:
    """cond(J) (N,) of Jacobians J (N, n, k); inf where J is not finite."""
    with np.errstate(all="ignore"):
        return np.where(np.all(np.isfinite(J), axis=(1, 2)), np.linalg.cond(np.nan_to_num(J)), np.inf)


def path_kinematics(mech: Mechanism, s: PathSamples) -> PathKinematics:
    """Quality of the motion at the path samples `s` (:func:`rrr4.trajectory.sample_path`).
    Raises KinematicsError where a general graph does not assemble."""
    N = len(s.t)
    if isinstance(mech, NRRRMechanism):  # closed form
        _, cos_arg = mech.ik_function.map(N)(s.pose.T, np.tile(mech.modes[:, None], (1, N)))
        J, _, _, sin_tr = mech.jacobian_function.map(N)(s.pose.T)
        J = np.array(J).T.reshape(N, 3, mech.n).transpose(0, 2, 1)
        return PathKinematics(s.t, condition_number(J), np.array(cos_arg).T, np.array(sin_tr).T)
    if mech.model.task is None:
        Q = mech.path_coordinates(mech.driver_targets(s.t))
        return PathKinematics(s.t, np.ones(N), None, None, _mode_along(mech, Q))
    Q = mech.path_coordinates(s.pose[:, :mech.n_task])
    return PathKinematics(s.t, condition_number(mech.path_jacobians(Q)), None, None, _mode_along(mech, Q))


def _mode_along(mech: Mechanism, Q: np.ndarray) -> np.ndarray | None:
    """(N, k) the named assembly mode's measures at the states Q (N, nq), None if none is named."""
    if not mech.assembly:
        return None
    return np.array(mech.mode_function.map(len(Q))(Q.T)).T


def near_singular(path: PathSpec, pk: PathKinematics) -> np.ndarray:
    """(N,) reason string or '' per sample: near a serial or parallel singularity (the
    margins of `path`)."""
    out = np.full(len(pk.t), "", dtype=object)
    cmax, smin = path.max_condition_number, path.min_transmission
    sin_tr = np.ones((len(pk.t), 1)) if pk.sin_transmission is None else np.abs(pk.sin_transmission)
    for k in np.flatnonzero(~(pk.condition <= cmax) | np.any(~(sin_tr >= smin), axis=1)):
        why = f"near-singular pose: cond(J) = {pk.condition[k]:.3g} (allowed <= {cmax:g})"
        if pk.sin_transmission is not None:
            why += (f", smallest transmission |sin| = {sin_tr[k].min():.3g} at chain {int(np.argmin(sin_tr[k])) + 1}"
                    f" (allowed >= {smin:g})")
        out[k] = why
    return out


def check_scene(scene: Scene) -> Scene:
    """Return `scene` if its mechanism assembles along the motion and the path keeps clear
    of the workspace boundary, working-mode flips and singularities; else raise SceneError
    naming the time and the chain or body."""
    try:
        mech = Mechanism.from_scene(scene)
        pk = path_kinematics(mech, sample_path(scene.path))
    except KinematicsError as e:
        raise SceneError(f"mechanism: {e}") from None
    p = scene.path
    if pk.cos_arg is not None:
        reach = ~(np.abs(pk.cos_arg) <= 1.0)
        if reach.any():
            k, i = np.argwhere(reach)[0]
            raise SceneError(f"path: leaves the workspace at t = {pk.t[k]:.4g} s: chain {i + 1} cannot reach the "
                             f"platform (IK cos argument {pk.cos_arg[k, i]:.12g}, allowed [-1, 1])")
        sign = np.sign(pk.sin_transmission) * mech.modes
        flip = sign != sign[0]
        if flip.any():
            k, i = np.argwhere(flip)[0]
            raise SceneError(f"path: chain {i + 1} flips its working mode at t = {pk.t[k]:.4g} s "
                             "(the path crosses a serial singularity)")
        weak = np.abs(pk.sin_transmission) < p.min_transmission
        if weak.any():
            k, i = np.argwhere(weak)[0]
            raise SceneError(f"path: passes through a serial singularity at t = {pk.t[k]:.4g} s, chain {i + 1} "
                             f"(|sin| of the link angle {abs(pk.sin_transmission[k, i]):.3g}, "
                             f"allowed >= path.min_transmission = {p.min_transmission:g})")
    if pk.mode is not None:
        signs = np.array([m.sign for m in mech.assembly], float)
        off = ~(pk.mode * signs > 1e-6)
        if off.any():
            k, i = np.argwhere(off)[0]
            m = mech.assembly[i]
            raise SceneError(f"mechanism.assembly[{i}]: {m.measure} {'+' if m.sign > 0 else '-'} at {m.joint} does "
                             f"not hold along the motion (it is {pk.mode[k, i]:+.3g} at t = {pk.t[k]:.4g} s; a mode "
                             "must hold on the whole branch: choose a joint and points whose sign the motion keeps)")
    cond, t = pk.worst_condition
    if not cond <= p.max_condition_number:
        hint = mech.branch_hint(sample_path(p).pose[0, :mech.n_task]) if mech.model.task is not None else ""
        raise SceneError(f"path: passes through a parallel singularity at t = {t:.4g} s "
                         f"(condition number of J {cond:.3g}, allowed <= path.max_condition_number = "
                         f"{p.max_condition_number:g})" + (f"; {hint}" if hint else ""))
    return scene


def load_scene(path) -> Scene:
    """Read a YAML scene file, validate it and check it against its model. Raises SceneError."""
    return check_scene(read_scene(path))
