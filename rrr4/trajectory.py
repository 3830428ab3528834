"""Platform trajectories: a path in pose space composed with a smooth time law.

``trajectory_function(path)`` is a CasADi Function ``t -> pose, pose_d, pose_dd``
(pose = [x, y, theta_o] in m, m, rad; derivatives per s and s^2). It is symbolic, so
controllers, inverse dynamics and generated code all use the same expression.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

from .scene import DriverSpec, PathSpec

__all__ = ["trajectory_function", "path_geometry_function", "driver_function", "sample_path", "PathSamples"]


def _time_law(law: str, tau):
    """Normalised progress s(tau) on [0, 1]; quintic and cycloidal have zero rate and
    acceleration at both ends."""
    if law == "quintic":
        return tau**3 * (10 - 15 * tau + 6 * tau**2)
    if law == "cycloidal":
        return tau - ca.sin(2 * ca.pi * tau) / (2 * ca.pi)
    return tau


def _tabulated_progress(table, t):
    """s(t) of a time table (rows t, s, s_dot; :mod:`rrr4.scene.time_table`) at t in [0, T]:
    piecewise quadratic with a constant acceleration per row, exactly. With L the linear
    interpolant of s, E that of t^2 and a the slope of the linear interpolant of s_dot,
    s(t) = L(t) - a(t) (E(t) - t^2) / 2, since E(t) - t^2 = tau (h - tau) on a segment of
    length h (tau = t - t_k). Interpolants are code-generable, so are their derivatives."""
    tk, sk, vk = (np.array(c, float) for c in zip(*table, strict=True))
    grid = [tk.tolist()]
    lin_s = ca.interpolant("time_table_s", "linear", grid, sk.tolist())
    lin_t2 = ca.interpolant("time_table_t2", "linear", grid, (tk**2).tolist())
    lin_v = ca.interpolant("time_table_s_dot", "linear", grid, vk.tolist())
    tt = ca.SX.sym("tt")
    a = ca.Function("time_table_s_ddot", [tt], [ca.jacobian(lin_v(tt), tt)])(t)
    return lin_s(t) - 0.5 * a * (lin_t2(t) - t**2)


def _progress(law: str, table, duration: float, t):
    """s(t) in [0, 1] of a time law over [0, duration] (or its time table), held at its ends
    outside it: the one rule of a path and of a driver's motion law."""
    if law == "table":
        return _tabulated_progress(table, ca.fmin(ca.fmax(t, 0.0), duration))
    return _time_law(law, ca.fmin(ca.fmax(t / duration, 0.0), 1.0))


def _pose_of_progress(spec: PathSpec, s):
    if spec.type == "none":  # no task body: the drivers set the motion
        return ca.vertcat(0 * s, 0 * s, 0 * s)
    if spec.type == "circle":
        phi = spec.start_angle + 2 * ca.pi * spec.revolutions * s
        cx, cy = spec.center
        return ca.vertcat(cx + spec.radius * ca.cos(phi), cy + spec.radius * ca.sin(phi), spec.orientation)
    if spec.type == "line":
        a, b = np.array(spec.start), np.array(spec.end)
        return ca.DM(a) + s * ca.DM(b - a)
    # waypoints: clamped cubic spline through the poses at uniform parameter knots
    pts = np.array(spec.points)
    knots = np.linspace(0.0, 1.0, len(pts))
    spline = CubicSpline(knots, pts, bc_type="clamped")
    c = spline.c  # (4, segments, 3)
    out = None
    for k in range(len(knots) - 2, -1, -1):
        u = s - knots[k]
        seg = ca.vertcat(*[c[0, k, d] * u**3 + c[1, k, d] * u**2 + c[2, k, d] * u + c[3, k, d] for d in range(3)])
        out = seg if out is None else ca.if_else(s < knots[k + 1], seg, out)
    return out


@functools.lru_cache(maxsize=64)  # per path (a sweep over the path makes one per case)
def trajectory_function(spec: PathSpec) -> ca.Function:
    """CasADi Function 'trajectory': t [s] -> pose (3), pose_d (3), pose_dd (3).

    Before t = 0 and after the duration the pose rests at the end points.
    """
    t = ca.SX.sym("t")
    pose = _pose_of_progress(spec, _progress(spec.time_law, spec.time_table, spec.duration, t))
    pose_d = ca.jacobian(pose, t)
    pose_dd = ca.jacobian(pose_d, t)
    return ca.Function("trajectory", [t], [pose, pose_d, pose_dd], ["t"], ["pose", "pose_d", "pose_dd"])


@functools.lru_cache(maxsize=64)
def driver_function(spec: DriverSpec) -> ca.Function:
    """CasADi Function 'driver': t [s] -> value [rad or m], rate, acceleration of a driver whose
    time_law is not 'constant': initial + travel s(t), s the path's law over the driver's
    duration (or its time table), at rest at both ends of [0, duration] outside it."""
    t = ca.SX.sym("t")
    value = spec.initial + spec.travel * _progress(spec.time_law, spec.time_table, spec.duration, t)
    rate = ca.jacobian(value, t)
    return ca.Function("driver", [t], [value, rate, ca.jacobian(rate, t)], ["t"], ["value", "rate", "acceleration"])


@functools.lru_cache(maxsize=64)
def path_geometry_function(spec: PathSpec) -> ca.Function:
    """CasADi Function 'path_geometry': s [-] in [0, 1] -> pose (3), pose_s (3), pose_ss (3):
    the path's pose as a function of its progress and its first two derivatives in s, the
    geometry a time law moves along (pose_d = pose_s s_dot, pose_dd = pose_s s_ddot + pose_ss
    s_dot^2)."""
    s = ca.SX.sym("s")
    pose = _pose_of_progress(spec, s)
    pose_s = ca.jacobian(pose, s)
    return ca.Function("path_geometry", [s], [pose, pose_s, ca.jacobian(pose_s, s)], ["s"],
                       ["pose", "pose_s", "pose_ss"])


@dataclass(frozen=True)
class PathSamples:
    t: np.ndarray        # (N,) [s]
    pose: np.ndarray     # (N, 3) [m, m, rad]
    pose_d: np.ndarray   # (N, 3) [m/s, m/s, rad/s]
    pose_dd: np.ndarray  # (N, 3) [m/s^2, m/s^2, rad/s^2]


def sample_path(spec: PathSpec, sample_rate: float | None = None) -> PathSamples:
    """Evaluate the trajectory on a uniform grid from 0 to the duration (both included)."""
    rate = sample_rate or spec.sample_rate
    n = max(int(round(spec.duration * rate)) + 1, 2)
    t = np.linspace(0.0, spec.duration, n)
    f = trajectory_function(spec).map(n)
    p, pd, pdd = (np.array(v).T for v in f(t[None, :]))
    return PathSamples(t, p, pd, pdd)
