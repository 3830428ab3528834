"""Checks that a scene's path stays inside the workspace and away from singularities."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene import Scene
from ..trajectory import sample_path
from .model import Mechanism


@dataclass(frozen=True)
class PathKinematics:
    """Kinematic quality along the sampled path."""
    t: np.ndarray                 # (N,) [s]
    cos_arg: np.ndarray           # (N, n) IK acos argument; |.| <= 1 where reachable
    sin_transmission: np.ndarray  # (N, n) sin of the angle between driving and following link
    condition: np.ndarray         # (N,) 2-norm condition number of J

    @property
    def worst_condition(self) -> tuple[float, float]:
        k = int(np.argmax(self.condition))
        return float(self.condition[k]), float(self.t[k])


def path_kinematics(scene: Scene, mech: Mechanism | None = None) -> PathKinematics:
    mech = mech or Mechanism.from_scene(scene)
    s = sample_path(scene.path)
    N = len(s.t)
    _, cos_arg = mech.ik_function.map(N)(s.pose.T, np.tile(mech.modes[:, None], (1, N)))
    cos_arg = np.array(cos_arg).T
    J, _, _, sin_tr = mech.jacobian_function.map(N)(s.pose.T)
    J = np.array(J).T.reshape(N, 3, mech.n).transpose(0, 2, 1)
    with np.errstate(invalid="ignore"):
        cond = np.where(np.all(np.isfinite(J), axis=(1, 2)),
                        np.linalg.cond(np.nan_to_num(J)), np.inf)
    return PathKinematics(s.t, cos_arg, np.array(sin_tr).T, cond)


def check_path(scene: Scene, mech: Mechanism | None = None) -> PathKinematics:
    """Raise SceneError (naming time and chain) where the path leaves the workspace,
    flips a working mode, comes near a serial singularity or near a parallel one."""
    pk = path_kinematics(scene, mech)
    p = scene.path
    reach = ~(np.abs(pk.cos_arg) <= 1.0)
    if reach.any():
        k, i = np.argwhere(reach)[0]
        raise SceneError(f"path: leaves the workspace at t = {pk.t[k]:.4g} s: chain {i + 1} cannot reach the "
                         f"platform (IK cos argument {pk.cos_arg[k, i]:.4g}, allowed [-1, 1])")
    sign = np.sign(pk.sin_transmission) * np.array([c.working_mode for c in scene.mechanism.chains])
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
    cond, t = pk.worst_condition
    if not cond <= p.max_condition_number:
        raise SceneError(f"path: passes through a parallel singularity at t = {t:.4g} s "
                         f"(condition number of J {cond:.3g}, allowed <= path.max_condition_number = "
                         f"{p.max_condition_number:g})")
    return pk
