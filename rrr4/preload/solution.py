"""`PreloadSolution`: the torque program along a path, with reactions and feasibility."""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

__all__ = ["PreloadSolution", "Infeasibility", "EffortExcess", "roughness"]


@dataclass(frozen=True)
class Infeasibility:
    """One violated condition at one path sample: time [s], joint ('B3', 'C1', or
    'actuator A2', or 'pose' for a singular pose), a readable reason, and by how much it
    fails (effort over the limit [N m or N], force short of f_min [N]; 0 where no number applies)."""
    t: float
    joint: str
    reason: str
    excess: float = 0.0


@dataclass(frozen=True)
class EffortExcess:
    """Where one actuator's planned effort exceeds its limit along the path: the peak |tau|
    it needs [N m or N] and when [s], its limit, the time spans [s] over the limit and their
    sample count. The simulation's controller clips its efforts at the limits there, so the
    preload does not hold."""
    actuator: str
    unit: str
    limit: float
    peak: float
    t_peak: float
    spans: tuple[tuple[float, float], ...]
    samples: int

    @property
    def excess(self) -> float:
        """peak - limit [N m or N]."""
        return self.peak - self.limit

    def describe(self) -> str:
        """One line: which actuator, the peak need against the limit, when, and where."""
        spans = ", ".join(f"{a:.4g} s" if a == b else f"{a:.4g}..{b:.4g} s" for a, b in self.spans[:4])
        more = f" and {len(self.spans) - 4} more spans" if len(self.spans) > 4 else ""
        return (f"actuator {self.actuator} needs {self.peak:.4g} {self.unit} at t = {self.t_peak:.4g} s against its "
                f"limit {self.limit:g} {self.unit} ({self.excess:.3g} {self.unit}, "
                f"{100 * self.excess / self.limit:.0f} % over); over the limit at {self.samples} samples in t = "
                f"{spans}{more}")


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
    statistics: solver name, wall time [s], iterations, ...; effort_excess: one
    :class:`EffortExcess` per actuator whose planned effort exceeds its limit somewhere.
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
    effort_excess: tuple[EffortExcess, ...] = ()

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

    def report(self, max_lines: int = 20, actuators: bool = True) -> str:
        """Readable summary: method, effort, smallest margin and every infeasible stretch
        (joint, time span, worst reason); without the actuators' stretches when `actuators`
        is False (:attr:`effort_excess` describes them)."""
        n_bad = int(np.sum(~self.feasible))
        lines = [f"preload '{self.method}': {len(self.t)} samples over {self.t[-1] - self.t[0]:.3g} s, "
                 f"f_min = {self.f_min:g} N, feasible at {len(self.t) - n_bad}/{len(self.t)}",
                 f"  max |tau| = {np.max(np.abs(self.tau)):.4g} N m (limits "
                 f"{', '.join(f'{v:g}' for v in self.torque_limit)} N m), "
                 f"smallest margin = {np.min(self.margin):.4g} N, roughness = {self.roughness:.4g} N m/s^2"]
        runs = _stretches([i for i in self.infeasible if actuators or not i.joint.startswith("actuator ")], self.t)
        for joint, t0, t1, count, reason, t_worst in runs[:max_lines]:
            span = (f"t = {t0:.4f} s" if count == 1 else
                    f"t = {t0:.4f}..{t1:.4f} s ({count} samples), worst at t = {t_worst:.4f} s")
            lines.append(f"  INFEASIBLE {joint}: {span}: {reason}")
        if len(runs) > max_lines:
            lines.append(f"  ... and {len(runs) - max_lines} more stretches")
        return "\n".join(lines)


def _stretches(items, t):
    """Group infeasibilities into contiguous runs per joint: (joint, t0, t1, count, the reason
    of the worst sample (largest excess; the first on ties), its time)."""
    dt = float(np.mean(np.diff(t))) if len(t) > 1 else 1.0
    runs: list[list] = []
    last: dict[str, list] = {}
    for it in items:
        r = last.get(it.joint)
        if r is not None and it.t - r[2] <= 1.5 * dt:
            r[2], r[3] = it.t, r[3] + 1
            if it.excess > r[6]:
                r[4], r[5], r[6] = it.reason, it.t, it.excess
        else:
            r = [it.joint, it.t, it.t, 1, it.reason, it.t, it.excess]
            last[it.joint] = r
            runs.append(r)
    return [tuple(r[:6]) for r in runs]


def effort_excess(t: np.ndarray, tau: np.ndarray, limits, over: np.ndarray, names, units) -> tuple[EffortExcess, ...]:
    """One :class:`EffortExcess` per actuator with a sample over its limit. t (N,) [s], tau
    (N, n), limits (n,), over (N, n) bool: the samples over the limit (with the caller's
    tolerance), names and units (n) of the actuators."""
    dt = float(np.mean(np.diff(t))) if len(t) > 1 else 1.0
    out = []
    for i in np.flatnonzero(over.any(axis=0)):
        k = np.flatnonzero(over[:, i])
        breaks = np.flatnonzero(np.diff(t[k]) > 1.5 * dt)
        starts, ends = np.r_[k[0], k[breaks + 1]], np.r_[k[breaks], k[-1]]
        worst = k[int(np.argmax(np.abs(tau[k, i])))]
        out.append(EffortExcess(names[i], units[i], float(limits[i]), float(abs(tau[worst, i])), float(t[worst]),
                                tuple((float(t[a]), float(t[b])) for a, b in zip(starts, ends, strict=True)), len(k)))
    return tuple(out)
