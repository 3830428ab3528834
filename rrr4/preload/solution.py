"""`PreloadSolution`: the torque program along a path, with reactions and feasibility."""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

__all__ = ["PreloadSolution", "Infeasibility", "roughness"]


@dataclass(frozen=True)
class Infeasibility:
    """One violated condition at one path sample: time [s], joint ('B3', 'C1', or
    'actuator 2', or 'pose' for a singular pose) and a readable reason."""
    t: float
    joint: str
    reason: str


def roughness(t: np.ndarray, tau: np.ndarray) -> float:
    """RMS second time derivative of the torques [N m/s^2] (finite differences on the
    samples; t (N,) uniform, tau (N, n)). Jumps between samples make it large."""
    if len(t) < 3:
        return 0.0
    dt = float(np.mean(np.diff(t)))
    d2 = np.diff(tau, n=2, axis=0) / dt**2
    return float(np.sqrt(np.mean(np.sum(d2**2, axis=1))))


@dataclass(frozen=True)
class PreloadSolution:
    """Preload torques along a scene's path (one row per path sample).

    t (N,) [s]; pose, pose_d, pose_dd (N, 3) [m, m, rad] and rates; tau (N, n) [N m] =
    tau_particular + null_space alpha; alpha (N,) [N m] for one degree of redundancy,
    (N, m) for m; reactions (N, 2n, 2) [N], passive joints B1..Bn, C1..Cn, force of the
    inboard on the outboard body (= -lambda); feasible (N,) bool; margin (N,) [N] =
    min_j ||r_j|| - f_min; infeasible: every violated condition with time, joint, reason;
    statistics: solver name, wall time [s], iterations, ...
    """
    method: str
    t: np.ndarray
    pose: np.ndarray
    pose_d: np.ndarray
    pose_dd: np.ndarray
    tau: np.ndarray
    alpha: np.ndarray
    reactions: np.ndarray
    feasible: np.ndarray
    margin: np.ndarray
    tau_particular: np.ndarray
    null_space: np.ndarray
    f_min: float
    torque_limit: tuple[float, ...]
    joint_names: tuple[str, ...]
    infeasible: tuple[Infeasibility, ...] = ()
    statistics: dict = field(default_factory=dict)

    @property
    def all_feasible(self) -> bool:
        return bool(np.all(self.feasible))

    @property
    def roughness(self) -> float:
        """RMS d^2 tau/dt^2 [N m/s^2], see :func:`roughness`."""
        return roughness(self.t, self.tau)

    @property
    def reaction_magnitudes(self) -> np.ndarray:
        """||r_j|| (N, 2n) [N]."""
        return np.linalg.norm(self.reactions, axis=2)

    def torque_interpolant(self) -> ca.Function:
        """CasADi Function 'preload_torque': t [s] -> tau (n,) [N m], linear between samples
        (held at the end values outside the path's time span)."""
        return ca.interpolant("preload_torque", "linear", [self.t], self.tau.ravel().tolist())

    def report(self, max_lines: int = 20) -> str:
        """Readable summary: method, effort, smallest margin and every infeasible stretch
        (joint, time span, worst reason)."""
        n_bad = int(np.sum(~self.feasible))
        lines = [f"preload '{self.method}': {len(self.t)} samples over {self.t[-1] - self.t[0]:.3g} s, "
                 f"f_min = {self.f_min:g} N, feasible at {len(self.t) - n_bad}/{len(self.t)}",
                 f"  max |tau| = {np.max(np.abs(self.tau)):.4g} N m (limits "
                 f"{', '.join(f'{v:g}' for v in self.torque_limit)} N m), "
                 f"smallest margin = {np.min(self.margin):.4g} N, roughness = {self.roughness:.4g} N m/s^2"]
        runs = _stretches(self.infeasible, self.t)
        for joint, t0, t1, count, reason in runs[:max_lines]:
            span = f"t = {t0:.4f} s" if count == 1 else f"t = {t0:.4f}..{t1:.4f} s ({count} samples)"
            lines.append(f"  INFEASIBLE {joint}: {span}: {reason}")
        if len(runs) > max_lines:
            lines.append(f"  ... and {len(runs) - max_lines} more stretches")
        return "\n".join(lines)


def _stretches(items, t):
    """Group infeasibilities into contiguous runs per joint: (joint, t0, t1, count, first reason)."""
    dt = float(np.mean(np.diff(t))) if len(t) > 1 else 1.0
    runs: list[list] = []
    last: dict[str, list] = {}
    for it in items:
        r = last.get(it.joint)
        if r is not None and it.t - r[2] <= 1.5 * dt:
            r[2], r[3] = it.t, r[3] + 1
        else:
            r = [it.joint, it.t, it.t, 1, it.reason]
            last[it.joint] = r
            runs.append(r)
    return [tuple(r) for r in runs]
