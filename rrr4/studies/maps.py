"""Workspace maps of a scene with a task body (DESIGN section 8): over a grid of platform
positions at the scene's orientation, the Jacobian's condition number, the smallest
transmission (n-RRR: the closed form; a graph has none), and
whether (and with what torque) the controller's preload holds f_min at every passive joint
within the torque limits, at rest and under the path's peak acceleration (the worst of 8
directions). Every quantity is evaluated for the whole grid at once with CasADi ``map``
(:func:`rrr4.mechanism.workspace.path_kinematics`, the closed-form inverse dynamics and the
controller's preload law), never in a Python loop over points; a graph is assembled at every
point by one continuation (``mapaccum``) over the grid.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..files import atomic_file, write_atomic
from ..mechanism.workspace import condition_number, path_kinematics
from ..preload import preload_law
from ..problem import Problem
from ..scene import GROUND, Scene
from ..trajectory import PathSamples, sample_path

__all__ = ["workspace_map", "write_map", "GRID", "DIRECTIONS"]

GRID = 101        # points per axis
DIRECTIONS = 8    # directions of the peak path acceleration tried at each point


def _extent(problem: Problem) -> tuple[float, float, float, float]:
    """The square-ish region around the ground anchors (an n-RRR's bases): their centre, 0.75 of
    their half-span; anchors on one line also span the path."""
    scene = problem.scene
    anchors = np.array([j.points[k] for j in scene.graph.joints for k in (0, 1) if j.bodies[k] == GROUND])
    lo, hi = anchors.min(axis=0), anchors.max(axis=0)
    if np.min(hi - lo) < 1e-9:
        pts = np.vstack([anchors, sample_path(scene.path).pose[:, :2]])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
    c, h = (lo + hi) / 2, 0.75 * (hi - lo) / 2
    return c[0] - h[0], c[0] + h[0], c[1] - h[1], c[1] + h[1]


def _preload(problem: Problem, pose, pose_dd, q=None) -> tuple[np.ndarray, np.ndarray]:
    """(feasible (N,) bool, max |tau| (N,) [N m]) of the controller's preload at poses (N, 3)
    at rest with platform acceleration pose_dd (N, 3); NaN torque where unreachable. q: a
    graph's coordinates at the poses."""
    N = len(pose)
    fam = problem.effort_family(pose, np.zeros_like(pose), pose_dd, q=q)
    law = preload_law(problem)
    limits = np.asarray(problem.torque_limit)
    if law is None:  # no preload: the minimum-norm torques, feasible if within the limits
        tau = fam.tau_p
        feasible = np.all(np.abs(tau) <= limits, axis=1)
    else:
        _, tau, feas, _ = (np.array(v) for v in law.map(N)(*fam.raw))
        tau, feasible = tau.T, feas.ravel() > 0.5
    peak = np.max(np.abs(tau), axis=1)
    ok = np.all(np.isfinite(tau), axis=1)
    return feasible & ok, np.where(ok, peak, np.nan)


def _snake(grid: int) -> np.ndarray:
    """Indices of a grid x grid raster (row-major) in boustrophedon order: each point next to
    the one before, so that continuation carries the assembly from point to point."""
    idx = np.arange(grid * grid).reshape(grid, grid)
    idx[1::2] = idx[1::2, ::-1]
    return idx.ravel()


def _graph_coordinates(problem: Problem, pose: np.ndarray, order: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(q (N, nq), reachable (N,)) of a graph at the grid's poses (row-major), by continuation
    from the path's start assembly: 50 steps to the first grid point, then through the grid in
    `order`; each point's Newton starts from the last one that closed."""
    mech = problem.mechanism
    k = mech.n_task
    start = sample_path(problem.path).pose[0, :k]
    lead = np.linspace(start, pose[order[0], :k], 50)
    Q, ok = mech.tracked_coordinates(np.vstack([lead, pose[order, :k]]), mech.assemble(start))
    q, reachable = np.empty((len(pose), mech.nq)), np.empty(len(pose), bool)
    q[order], reachable[order] = Q[len(lead):], ok[len(lead):]
    return q, reachable


def workspace_map(scene: Scene | Problem, grid: int = GRID) -> dict:
    """Arrays over a grid x (grid,), y (grid,) [m] at the path's orientation: reachable,
    condition, min_transmission (n-RRR only; NaN for a graph), feasible_rest, torque_rest_Nm,
    feasible_peak, torque_peak_Nm (grid, grid) [y index, x index]; and a_peak [m/s^2], the
    path's peak acceleration. A graph scene is assembled at each point by continuation from the
    path's start (see :func:`_graph_coordinates`), so its maps show that assembly branch."""
    if not isinstance(grid, int) or isinstance(grid, bool) or not 3 <= grid <= 1001:
        raise SceneError(f"--grid: {grid!r} is not allowed (an integer from 3 to 1001)")
    problem = Problem.from_scene(scene)
    scene = problem.scene
    if problem.model.task is None:
        raise SceneError(f"path.type: 'none' is not allowed for rrr4 map (scene {scene.name!r} has no task body: "
                         "its drivers set the motion, so there is no workspace to map)")
    x0, x1, y0, y1 = _extent(problem)
    x, y = np.linspace(x0, x1, grid), np.linspace(y0, y1, grid)
    X, Y = np.meshgrid(x, y)
    N = X.size
    theta = scene.path.orientation
    pose = np.column_stack([X.ravel(), Y.ravel(), np.full(N, theta)])
    zero = np.zeros_like(pose)
    if problem.closed_form:
        pk = path_kinematics(problem.mechanism, PathSamples(np.zeros(N), pose, zero, zero))
        reachable = np.all(np.abs(pk.cos_arg) <= 1.0, axis=1)
        cond = np.where(reachable, pk.condition, np.nan)
        trans = np.where(reachable, np.min(np.abs(pk.sin_transmission), axis=1), np.nan)
        q, at = None, slice(None)
    else:
        mech, order = problem.mechanism, _snake(grid)
        q_all, reachable = _graph_coordinates(problem, pose, order)
        at = order[reachable[order]]  # the reachable points in continuation order: the effort
        q = q_all[at]                 # basis is kept continuous from one to the next
        cond, trans = np.full(N, np.nan), np.full(N, np.nan)
        if at.size:
            cond[at] = condition_number(mech.path_jacobians(q))
    s = sample_path(scene.path)
    a_peak = float(np.max(np.linalg.norm(s.pose_dd[:, :2], axis=1)))
    feas_rest, tau_rest = np.zeros(N, bool), np.full(N, np.nan)
    if reachable.any():
        feas_rest[at], tau_rest[at] = _preload(problem, pose[at], zero[at], q)
    feas_peak, tau_peak = feas_rest.copy(), tau_rest.copy()
    for k in range(DIRECTIONS if reachable.any() else 0):
        phi = 2 * np.pi * k / DIRECTIONS
        acc = np.zeros_like(pose)
        acc[:, 0], acc[:, 1] = a_peak * np.cos(phi), a_peak * np.sin(phi)
        f, t = _preload(problem, pose[at], acc[at], q)
        feas_peak[at] &= f
        tau_peak[at] = np.fmax(tau_peak[at], t)
    shape = (grid, grid)
    out = {"x": x, "y": y, "reachable": reachable.reshape(shape), "condition": cond.reshape(shape),
           "min_transmission": trans.reshape(shape),
           "feasible_rest": (feas_rest & reachable).reshape(shape),
           "torque_rest_Nm": np.where(reachable, tau_rest, np.nan).reshape(shape),
           "feasible_peak": (feas_peak & reachable).reshape(shape),
           "torque_peak_Nm": np.where(reachable, tau_peak, np.nan).reshape(shape), "a_peak": a_peak,
           "orientation": theta, "preload": problem.has_preload}
    return out


def write_map(scene: Scene | Problem, out: Path, grid: int = GRID) -> list[Path]:
    """Compute the maps and write ``map.png`` (:func:`rrr4.results.figures.plot_map`),
    ``map.npz`` (the arrays) and ``map.json`` (a summary) into out, each atomically."""
    from ..results.figures import plot_map
    problem = Problem.from_scene(scene)
    m = workspace_map(problem, grid)
    out.mkdir(parents=True, exist_ok=True)
    npz = atomic_file(out / "map.npz", lambda tmp: np.savez_compressed(tmp, **{k: np.asarray(v) for k, v in m.items()}))
    summary = {"scene": problem.name, "grid": grid, "orientation_rad": m["orientation"],
               "extent_m": [m["x"][0], m["x"][-1], m["y"][0], m["y"][-1]], "path_peak_acceleration_m_s2": m["a_peak"],
               "reachable_fraction": float(m["reachable"].mean()),
               "preload_holds_at_rest_fraction": float(m["feasible_rest"].mean()),
               "preload_holds_at_peak_acceleration_fraction": float(m["feasible_peak"].mean()),
               "condition_min": float(np.nanmin(m["condition"])),
               "torque_rest_min_Nm": float(np.nanmin(np.where(m["feasible_rest"], m["torque_rest_Nm"], np.nan)))}
    js = out / "map.json"
    write_atomic(js, json.dumps(summary, indent=1) + "\n")
    return [plot_map(m, problem, out / "map.png"), npz, js]
