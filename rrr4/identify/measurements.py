"""Measurements for identification: time, the task body's pose, the actuators' angles and
rates, the actuators' efforts, with a noise level per column.

Column names are those of a study's ``timeseries.csv`` (:func:`rrr4.results.write_timeseries_csv`),
so a simulated run feeds back in: ``t_s`` (or ``t``), ``x_m``, ``y_m``, ``theta_rad`` (the
task body), ``theta_<A>_rad`` and ``theta_d_<A>_rad_s`` (actuator A's angle and rate),
``tau_<A>_Nm`` (or ``_N`` on a prismatic actuator), ``alpha_Nm`` (the preload), each
optionally behind an arm prefix (``with_preload_x_m``). A driven scene (drivers, no task: the
slider-crank) has no task body and no actuators; its columns are those of its runs'
``timeseries.csv``: per body B ``B_x_m``, ``B_y_m``, ``B_theta_rad`` (its centre of mass and
angle) and per driver D ``D_effort_Nm`` (``_N`` on a prismatic joint: what the driver applies).
Every other column is ignored.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..checks import describe
from ..errors import KinematicsError, MeasurementError, SceneError
from ..files import read_text, shown
from ..problem import Problem
from ..trajectory import trajectory_function

__all__ = ["Measurements", "read_measurements", "measurements_from_simulation",
           "POSE_COLUMNS", "measurement_columns",
           "driven_scene", "body_rows"]

POSE_COLUMNS = ("x_m", "y_m", "theta_rad")
MAX_ROWS = 2_000_000
MAX_BYTES = 256 * 2**20  # largest measurement file read [bytes]
ANGLE_TOL = 0.5  # [rad] the farthest a measured actuator angle may lie from the scene's along its path
CHECKED_ROWS = 200  # rows (evenly spread) at which the actuator angles are compared with the scene's


def measurement_columns(problem: Problem) -> dict[str, list[str]]:
    """The columns identification reads for `problem`, by kind: pose, angle, rate, effort
    (without an arm prefix), 'preload' (alpha_Nm), and for a driven scene (no task body:
    no pose) 'body' (B_x_m, B_y_m, B_theta_rad per body B, in the order of the bodies'
    coordinates) and 'driver' (D_effort_Nm, or _N on a prismatic joint, per driver D)."""
    model = problem.model
    rev = [problem.joint(j).type == "revolute" for j in model.actuated_joints]
    names = model.actuator_names
    driven = driven_scene(problem)
    return {"pose": [] if driven else list(POSE_COLUMNS),
            "angle": [f"theta_{a}_{'rad' if r else 'm'}" for a, r in zip(names, rev, strict=True)],
            "rate": [f"theta_d_{a}_{'rad_s' if r else 'm_s'}" for a, r in zip(names, rev, strict=True)],
            "effort": [f"tau_{a}_{'Nm' if r else 'N'}" for a, r in zip(names, rev, strict=True)],
            "preload": ["alpha_Nm"],
            "body": [f"{b}_{c}" for b in model.body_names for c in POSE_COLUMNS] if driven else [],
            "driver": [f"{d.name}_effort_{'Nm' if problem.joint(d.joint).type == 'revolute' else 'N'}"
                       for d in model.graph.drivers] if driven else []}


def body_rows(problem: Problem) -> np.ndarray:
    """The entries of the reference-point coordinates q that hold the 'body' columns of a
    driven scene (:func:`measurement_columns`; none for another scene): x, y, theta of each body."""
    if not driven_scene(problem):
        return np.zeros(0, int)
    model = problem.model
    return np.concatenate([np.arange(model.nq)[model.coordinates(b)] for b in model.body_names])


def driven_scene(problem: Problem) -> bool:
    """Whether `problem` is a driven scene: drivers prescribe its motion, no task body follows a path."""
    return problem.model.task is None and bool(problem.model.graph.drivers)


@dataclass(frozen=True)
class Measurements:
    """t (N,) [s], strictly increasing; columns: name -> (N,) values in SI units (names as in
    :func:`measurement_columns`, no arm prefix); noise: name -> standard deviation (given; the
    rest is estimated from the residuals); source: where they came from."""
    t: np.ndarray
    columns: dict
    noise: dict = field(default_factory=dict)
    source: str = ""

    def __post_init__(self):
        where = self.source or "measurements"
        t = np.asarray(self.t, float)
        if t.ndim != 1 or t.size < 2:
            raise MeasurementError(f"{where}: t has {t.size} values (at least 2 instants are required)")
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            raise MeasurementError(f"{where}: t is {t[bad[0]]} in row {bad[0] + 1} (finite times are required)")
        step = np.flatnonzero(np.diff(t) <= 0)
        if step.size:
            k = step[0]
            raise MeasurementError(f"{where}: t is not increasing at row {k + 2} ({t[k]:.9g} s then {t[k + 1]:.9g} s; "
                                   "strictly increasing times are required)")
        for name, v in self.columns.items():
            v = np.asarray(v, float)
            if v.shape != t.shape:
                raise MeasurementError(f"{where}: column {name} has {v.size} values for {t.size} times")
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                raise MeasurementError(f"{where}: column {name} is {v[bad[0]]} in row {bad[0] + 1} "
                                       "(finite numbers are required; drop or fill the row)")
        for name, s in self.noise.items():
            if name not in self.columns:
                raise MeasurementError(f"noise: unknown column {name!r} (choose one of: {', '.join(self.columns)})")
            if not (isinstance(s, (int, float)) and math.isfinite(s) and s > 0):
                raise MeasurementError(f"noise.{name}: {describe(s)} is not allowed (a standard deviation > 0 in "
                                       "the column's unit)")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "columns", {k: np.asarray(v, float) for k, v in self.columns.items()})

    def __len__(self) -> int:
        return self.t.size

    def has(self, kind_columns) -> list[str]:
        """The columns of `kind_columns` that are present."""
        return [c for c in kind_columns if c in self.columns]

    def write_csv(self, path, prefix: str = "") -> Path:
        """Write t_s and the columns (behind `prefix`, e.g. 'with_preload_') as a CSV file
        that :func:`read_measurements` reads back."""
        names = list(self.columns)
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["t_s", *(c if c == "alpha_Nm" else prefix + c for c in names)])
            w.writerows(np.column_stack([self.t, *(self.columns[c] for c in names)]).tolist())
        return Path(path)

    def window(self, t0: float, t1: float) -> Measurements:
        """The rows with t0 <= t <= t1 (at least two)."""
        rows = (self.t >= t0) & (self.t <= t1)
        if np.count_nonzero(rows) < 2:
            raise MeasurementError(f"window: [{t0:g}, {t1:g}] s holds {np.count_nonzero(rows)} instants of "
                                   f"{self.source or 'the measurements'} (t runs from {self.t[0]:g} to "
                                   f"{self.t[-1]:g} s; at least 2 are required)")
        return Measurements(self.t[rows], {k: v[rows] for k, v in self.columns.items()}, self.noise, self.source)


def _arms(header: list[str], wanted: set[str]) -> list[str]:
    """The arm prefixes ('' for none) under which wanted columns appear."""
    out = []
    for h in header:
        for w in wanted:
            if h == w and "" not in out:
                out.append("")
            elif h.endswith("_" + w) and h[:-len(w) - 1] not in out and not h.startswith("theta_d_"):
                out.append(h[:-len(w) - 1])
    return out


def select_columns(problem: Problem, header: list[str], rows: dict, where: str, arm: str | None = None) -> dict:
    """{name: values} of the columns identification uses, from a table whose header may
    carry arm prefixes; MeasurementError when none is there or the arm is ambiguous."""
    kinds = measurement_columns(problem)
    wanted = {c for k in ("pose", "angle", "rate", "effort", "body", "driver") for c in kinds[k]}
    arms = _arms(header, wanted)
    arms = [a for a in arms if not any(a == w or a.endswith("_" + w) for w in wanted)]
    if not arms and driven_scene(problem):
        raise MeasurementError(f"{where}: no body or driver column of the driven scene {problem.name!r} (expected "
                               f"some of: {', '.join(kinds['driver'] + kinds['body'])}, optionally behind an arm "
                               "prefix such as with_clearance_)")
    if not arms:
        raise MeasurementError(f"{where}: no pose or effort column (expected some of: "
                               f"{', '.join(kinds['pose'] + kinds['effort'])}, optionally behind an arm prefix such "
                               "as with_preload_; actuator angles theta_<A>_rad)")
    if arm is None:
        if len(arms) > 1:
            raise MeasurementError(f"{where}: columns of several arms ({', '.join(a or '(no prefix)' for a in arms)}); "
                                   "choose one with arm= (--arm)")
        arm = arms[0]
    elif arm not in arms:
        raise MeasurementError(f"arm: unknown arm {arm!r} in {where} (choose one of: "
                               f"{', '.join(a or '(no prefix)' for a in arms)})")
    prefix = f"{arm}_" if arm else ""
    out = {c: rows[prefix + c] for c in sorted(wanted, key=lambda c: header.index(prefix + c) if prefix + c in header
                                                else 0) if prefix + c in rows}
    if "alpha_Nm" in rows:
        out["alpha_Nm"] = rows["alpha_Nm"]
    return out


def read_measurements(path, problem: Problem | None = None, arm: str | None = None, noise: dict | None = None,
                      scene=None) -> Measurements:
    """Measurements from a CSV file with a header row (see the module docstring). `problem`
    (or `scene`) names the actuators; `arm` picks one arm's columns of a study's
    timeseries.csv; `noise` {column: standard deviation} (column names without the prefix).
    Raises MeasurementError (one line) for a missing file, missing columns, non-monotone
    time, NaN, and units the scene makes implausible (:func:`check_units`)."""
    problem = Problem.from_scene(problem if problem is not None else scene)
    header, data = _read_rows(path)
    tname = "t_s" if "t_s" in header else "t" if "t" in header else None
    if tname is None:
        raise MeasurementError(f"{shown(path)}: no time column (t_s or t) among {describe(header)}")
    cols = {}
    for j, name in enumerate(header):
        try:
            cols[name] = np.array([float(r[j]) if r[j].strip() else np.nan for r in data])
        except ValueError:
            bad = next(i for i, r in enumerate(data) if not _is_number(r[j]))
            raise MeasurementError(f"{shown(path)}: column {name} is {describe(data[bad][j])} in row {bad + 2} "
                                   "(numbers are required)") from None
    used = select_columns(problem, header, cols, shown(path), arm)
    m = Measurements(cols[tname], used, dict(noise or {}), shown(path))
    check_units(problem, m)
    return m


def _read_rows(path) -> tuple[list[str], list[list[str]]]:
    """The header and the rows of the CSV file (read by :func:`rrr4.files.read_text`); one-line
    MeasurementError for a file that is not there, not a regular UTF-8 text file, too large,
    not CSV (a cell beyond the CSV reader's field limit), ragged or empty."""
    text = read_text(path, "measurement file", "a CSV text file with a header row", MAX_BYTES, MeasurementError)
    reader = csv.reader(io.StringIO(text, newline=""))
    data: list[list[str]] = []
    try:
        header = [h.strip() for h in next(reader)]
        for k, row in enumerate(reader):
            if k >= MAX_ROWS:
                raise MeasurementError(f"{shown(path)}: more than {MAX_ROWS} rows (split the run into windows)")
            if not row:
                continue
            if len(row) != len(header):
                raise MeasurementError(f"{shown(path)}: row {k + 2} has {len(row)} values for {len(header)} columns")
            data.append(row)
    except StopIteration:
        raise MeasurementError(f"{shown(path)}: the file is empty (a header row with t_s and measured columns is "
                               "required)") from None
    except csv.Error as e:
        raise MeasurementError(f"{shown(path)}: not a readable CSV at row {reader.line_num} ({e}; a CSV text file "
                               "with a header row is required)") from None
    return header, data


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def check_units(problem: Problem, m: Measurements) -> None:
    """The units' plausibility against the scene, before any fit (MeasurementError in one line):
    the task body's position within the mechanism's reach (millimetres are refused), each
    revolute actuator's angle within ANGLE_TOL of the scene's along its path at the same time
    (degrees, another zero or another working mode are refused), each prismatic actuator's
    position within the reach of the scene's."""
    where, reach = m.source or "measurements", _reach(problem)
    for c in ("x_m", "y_m", *(c for c in measurement_columns(problem)["body"] if not c.endswith("_theta_rad"))):
        if c in m.columns and np.max(np.abs(m.columns[c])) > reach:
            raise MeasurementError(f"{where}: column {c} reaches {np.max(np.abs(m.columns[c])):.4g}, beyond the "
                                   f"mechanism's reach ({reach:.3g} m): is it in millimetres? (metres are required)")
    angles = measurement_columns(problem)["angle"]
    if not any(c in m.columns for c in angles) or problem.model.task is None:
        return
    rows = np.unique(np.linspace(0, len(m) - 1, min(len(m), CHECKED_ROWS)).astype(int))
    expected = _path_angles(problem, np.clip(m.t[rows], 0.0, problem.path.duration))
    if expected is None:
        return
    for i, c in enumerate(angles):
        if c not in m.columns:
            continue
        v = m.columns[c][rows]
        revolute = c.endswith("_rad")
        d = np.abs(np.angle(np.exp(1j * (v - expected[:, i])))) if revolute else np.abs(v - expected[:, i])
        k = int(np.argmax(d))
        if d[k] > (ANGLE_TOL if revolute else reach):
            hint = ("is it in degrees? (radians are required)" if revolute and np.max(np.abs(v)) > 2 * np.pi else
                    "another zero, or another working mode?" if revolute else "is it in millimetres? (metres are "
                    "required)")
            raise MeasurementError(f"{where}: column {c} is {v[k]:.6g} at t = {m.t[rows][k]:.6g} s where the scene's "
                                   f"actuator is at {expected[k, i]:.6g} along its path (allowed within "
                                   f"{ANGLE_TOL if revolute else reach:.3g}): {hint}")


def _path_angles(problem: Problem, t: np.ndarray) -> np.ndarray | None:
    """The actuators' coordinates (N, n) of the scene along its path at the times t (None where
    the mechanism does not assemble there: then the fit says so)."""
    rows = np.array(trajectory_function(problem.path).map(len(t))(t[None, :])[0]).T
    try:
        q = problem.path_coordinates(rows[:, :3], rows[:, 3:6], rows[:, 6:9])
    except (KinematicsError, SceneError):
        return None
    return np.array(problem.model.actuator_coordinates_function.map(len(t))(q.T)[0]).T


def _reach(problem: Problem) -> float:
    if problem.closed_form:
        return max(float(np.hypot(*c.base)) + c.driving.length + c.following.length
                   for c in problem.scene.mechanism.chains)
    return 1.0


def measurements_from_simulation(sim, every: int = 1, noise: dict | None = None) -> Measurements:
    """The measurements a run would give (task pose, actuator angles and rates, efforts; the
    controller's preload alpha where it has one; a driven scene's body poses and driver
    efforts), every `every`-th output instant: what
    :func:`read_measurements` reads from the run's timeseries.csv."""
    problem = Problem.from_scene(sim.scene)
    kinds = measurement_columns(problem)
    rows = np.arange(0, len(sim.t), every)
    f = problem.model.actuator_coordinates_function
    theta = np.array(f.map(len(rows))(sim.q[rows].T)[0]).T
    theta_d = np.array([np.array(f(q)[1]) @ qd for q, qd in zip(sim.q[rows], sim.qd[rows], strict=True)])
    cols = {c: sim.pose[rows, k] for k, c in enumerate(kinds["pose"])}
    cols.update({c: theta[:, k] for k, c in enumerate(kinds["angle"])})
    cols.update({c: theta_d[:, k] for k, c in enumerate(kinds["rate"])})
    cols.update({c: sim.tau[rows, k] for k, c in enumerate(kinds["effort"])})
    cols.update({c: sim.q[rows, k] for c, k in zip(kinds["body"], body_rows(problem), strict=True)})
    cols.update({c: sim.driver_effort[rows, k] for k, c in enumerate(kinds["driver"])})
    return Measurements(sim.t[rows], cols, dict(noise or {}), f"simulation of {sim.scene.name}")
