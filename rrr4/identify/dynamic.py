"""Method 'dynamic': fit through the simulation itself (single shooting), for runs where the
journals are not (only) seated: start-up, light preload, no preload.

Each candidate parameter vector is a scene (the nominal scene's YAML with the values at their
keys) simulated from the scene's initial state (t = 0) over the measured span by
:func:`rrr4.simulate`, with the nominal scene as the controller's model (the controller the
measured run had). Contact numbers enter the compiled stepping as inputs, so every
candidate steps the same compiled code. The simulated task pose, actuator angles and efforts
at the measured instants are the prediction; their sensitivities are forward differences of
whole runs (one run per parameter and iteration, a step of 1 % of each parameter's scale).
At the solution, forward and central differences are compared: where they disagree by more
than :data:`CHAOS_LIMIT`, the run is too sensitive to its parameters for shooting over this
span (journals that rattle make it chaotic) and the method says so instead of returning a
number.
"""

from __future__ import annotations

import numpy as np

from ..control.references import path_rows
from ..errors import MeasurementError, SceneError, SimulationError
from ..problem import Problem
from ..scene import parse_scene
from ..simulation import simulate
from .measurements import Measurements, measurement_columns
from .parameters import Parameter, identified_data

__all__ = ["DynamicData", "DYNAMIC_KINDS", "CHAOS_LIMIT", "FD_STEP"]

DYNAMIC_KINDS = ("clearance", "friction", "stiffness")  # contact numbers: inputs of the compiled stepping
CHAOS_LIMIT = 0.25  # relative disagreement of forward and central differences beyond which shooting fails
FD_STEP = 1e-2  # finite-difference step in each parameter's scaled coordinate


class DynamicData:
    """The measured run and the simulations that predict it (see the module docstring)."""

    def __init__(self, problem: Problem, m: Measurements, params: list[Parameter], scene_data):
        where = m.source or "measurements"
        bad = [q.key for q in params if q.kind not in DYNAMIC_KINDS]
        if bad:
            raise SceneError(f"parameters: {', '.join(bad)} is not allowed with method 'dynamic' (it shoots with "
                             "contact numbers only: clearances, friction coefficient, contact stiffness; use "
                             "'seated' for link lengths and base positions)")
        if scene_data is None:
            raise SceneError(f"scene: {problem.name!r} has no YAML file to vary (method 'dynamic' simulates the "
                             "scene with each candidate's values; load it with rrr4.load_scene)")
        if m.t[0] < -1e-12 or m.t[-1] > problem.path.duration + 1e-9:
            raise MeasurementError(f"{where}: t runs from {m.t[0]:.6g} s to {m.t[-1]:.6g} s (the scene's path runs "
                                   f"from 0 to {problem.path.duration:g} s; times are path times)")
        kinds = measurement_columns(problem)
        self.problem, self.m, self.params, self.scene_data = problem, m, params, scene_data
        self.pose_cols = m.has(kinds["pose"])
        self.angle_cols = m.has(kinds["angle"])
        self.effort_cols = m.has(kinds["effort"])
        self.kinds = kinds
        dt = float(np.median(np.diff(m.t)))
        self.rate = 1.0 / dt
        self.t_end = float(m.t[-1]) + 0.5 * dt
        self.runs, self._runs = 0, {}
        self.angles_measured = bool(self.angle_cols)
        self.preload, self.lag = "simulated controller", 0.0
        self.chaos = None

    def columns(self) -> list[str]:
        return self.pose_cols + self.angle_cols + self.effort_cols

    def scene(self, p):
        """The scene of the parameter values p."""
        data = identified_data(self.problem, self.params, p, self.scene_data)
        return parse_scene(data, name=str(data.get("name", "candidate")), source="")

    def simulate(self, p) -> dict:
        """{column: (N,)} simulated at the measured instants with the parameter values p (the
        last few runs are kept: a step that is accepted is not simulated again)."""
        key = tuple(np.asarray(p, float).tolist())
        if key not in self._runs:
            if len(self._runs) > 4 * (len(self.params) + 1):
                self._runs.clear()
            self._runs[key] = self._simulate(p)
        return self._runs[key]

    def _simulate(self, p) -> dict:
        self.runs += 1
        sim = simulate(self.scene(p), t_end=self.t_end, model=self.problem.scene, output_rate=self.rate)
        model = Problem.from_scene(sim.scene).model
        theta = np.array(model.actuator_coordinates_function.map(len(sim.t))(sim.q.T)[0]).T
        out = {}
        for c in self.pose_cols:
            out[c] = np.interp(self.m.t, sim.t, sim.pose[:, self.kinds["pose"].index(c)])
        for c in self.angle_cols:
            out[c] = np.interp(self.m.t, sim.t, theta[:, self.kinds["angle"].index(c)])
        for c in self.effort_cols:
            out[c] = np.interp(self.m.t, sim.t, sim.tau[:, self.kinds["effort"].index(c)])
        return out

    def _steps(self, p) -> np.ndarray:
        return np.array([q.value(q.coordinate(v) + FD_STEP) - v for q, v in zip(self.params, p, strict=True)])

    def residuals(self, p, sigma: dict, jacobian: bool = True, central: bool = False) -> dict:
        """As :meth:`rrr4.identify.seated.SeatedData.residuals`; the Jacobian by forward (or
        central) differences of whole runs (none without `jacobian`)."""
        p = np.asarray(p, float)
        base = self.simulate(p)
        h = self._steps(p)
        cols = []
        for i in range(len(p) if jacobian else 0):
            up = self.simulate(p + np.eye(len(p))[i] * h[i])
            if central:
                down = self.simulate(p - np.eye(len(p))[i] * h[i])
                cols.append({c: (up[c] - down[c]) / (2 * h[i]) for c in base})
            else:
                cols.append({c: (up[c] - base[c]) / h[i] for c in base})
        rs, js, raw, expected, explained = [], [], {}, {}, {}
        pose_ref, theta_ref = self._references()
        for c in self.columns():
            raw[c] = self.m.columns[c] - base[c]
            if c in ("theta_rad", *self.angle_cols):
                raw[c] = np.arctan2(np.sin(raw[c]), np.cos(raw[c]))
            expected[c] = np.ones(len(raw[c]))
            if c in self.pose_cols:
                explained[c] = base[c] - pose_ref[:, self.kinds["pose"].index(c)]
            elif c in self.angle_cols and theta_ref is not None:
                d = base[c] - theta_ref[:, self.kinds["angle"].index(c)]
                explained[c] = np.arctan2(np.sin(d), np.cos(d))
            else:
                explained[c] = base[c]
            rs.append(raw[c] / sigma[c])
            if cols:
                js.append(-np.column_stack([d[c] for d in cols]) / sigma[c])
        return {"r": np.concatenate(rs), "J": np.vstack(js) if js else None, "raw": raw, "expected": expected,
                "prediction": base, "explained": explained}

    def _references(self):
        """The path's poses (N, 3) at the measured instants and, for an n-RRR, the ideal IK's
        actuator angles (N, n) (what the figures show offsets from)."""
        if not hasattr(self, "_refs"):
            pose_ref = path_rows(self.problem.path, self.m.t)[:, :3]
            theta_ref = None
            if self.problem.closed_form:
                mech = self.problem.mechanism
                theta_ref = np.array(mech.ik_function.map(len(self.m.t))(pose_ref.T, mech.modes)[0]).T
            self._refs = pose_ref, theta_ref
        return self._refs

    def initial_noise(self) -> dict:
        out = {}
        for c in self.columns():
            out[c] = 1e-5 if c == "theta_rad" else 1e-6 if c in ("x_m", "y_m") else 1e-5 if c in self.angle_cols \
                else max(0.01 * float(np.sqrt(np.mean(self.m.columns[c] ** 2))), 1e-9)
        return out

    def check_sensitivities(self, p, sigma: dict, J_forward: np.ndarray) -> float:
        """The relative disagreement of forward and central differences at p; SimulationError
        where it exceeds CHAOS_LIMIT (the run is too sensitive for shooting over this span)."""
        J_central = self.residuals(p, sigma, central=True)["J"]
        d = float(np.linalg.norm(J_forward - J_central) / max(np.linalg.norm(J_central), 1e-300))
        self.chaos = d
        if not d <= CHAOS_LIMIT:
            raise SimulationError(f"method 'dynamic': the simulated run over 0 to {self.t_end:.3g} s is too sensitive "
                                  f"to its parameters for shooting (forward and central differences differ by "
                                  f"{100 * d:.0f} %, allowed {100 * CHAOS_LIMIT:.0f} %): journals that rattle make it "
                                  "chaotic; fit a shorter span from the start, or a preloaded run with 'seated'")
        return d
