"""A simulation's outputs at their rate, written while the integrator runs.

:class:`Outputs` is the integrator's ``sink`` (see :meth:`rrr4.integrators.Integrator.run`):
every array of a :class:`~rrr4.simulation.Simulation` is allocated once for the run's
outputs, and the kept states are turned into them a block of :attr:`Outputs.BLOCK` outputs
at a time as they arrive. A run then holds its output arrays and one block of states: never
all its states, per-step records or a whole-run temporary, so a long run needs little more
memory than its outputs (``benchmarks/bench_memory.py``).
"""

from __future__ import annotations

import time

import numpy as np

from ..control import path_rows
from ..dynamics.builder import Equations, profiles_of
from ..dynamics.energy import energy_audit_residual, energy_terms
from ..functions import mapped
from ..integrators import System
from ..problem import Problem
from .result import Simulation
from .system import extremes

__all__ = ["Outputs"]


class Outputs:
    """The outputs of one run at the times t_out (N,) [s], output 0 at the initial state x0.

    efforts(t, q, qd) -> (m, n): what the controller commands at states (torque mode);
    references(t) -> (theta_ref, theta_d_ref, theta_dd_ref) (m, n each) of the prescribed
    mode, or None. Call it with (k, states) for the kept states (m, system.kept) of outputs
    k + 1, k + 2, ... (the integrator's sink), then :meth:`simulation`. `seconds`: the wall
    time spent turning states into outputs; `bad`: the first output whose state is not
    finite (None while all are)."""

    BLOCK = 4096  # outputs turned into arrays at once

    def __init__(self, problem: Problem, eqs: Equations, system: System, tree: bool, t_out: np.ndarray, x0,
                 efforts, references):
        self.problem, self.eqs, self.system, self.tree = problem, eqs, system, tree
        self.efforts, self.references = efforts, references
        self.t = t_out
        N, nq, nc = len(t_out), eqs.nq, len(eqs.clearance_joints)
        n, k = eqs.n_actuators, len(eqs.passive_ideal_joints)
        self.arrays = {"q": (N, nq), "qd": (N, nq), "qdd": (N, nq), "pose": (N, 3), "pose_ref": (N, 3),
                       "platform_error": (N,), "tau": (N, n), "contact_force": (N, nc, 2), "normal_force": (N, nc),
                       "friction_force": (N, nc),
                       "eccentricity": (N, nc, 2), "penetration": (N, nc), "reaction": (N, k, 2),
                       "driver_effort": (N, eqs.acceleration.size1_out("driver_effort")),
                       "film_force": (N, nc, 2)}  # zeros at dry joints (rrr4.contact.lubrication)
        self.arrays = {name: np.zeros(shape) for name, shape in self.arrays.items()}
        self.energy: dict[str, np.ndarray] = {}
        self._buffer = np.empty((min(self.BLOCK, N), system.kept))
        self._filled, self._first = 0, 0  # states in the buffer; the output of its first
        self.last = np.empty(system.kept)  # the kept state of the last output
        self.seconds = 0.0
        self.bad: int | None = None
        head, peaks = system.kept_entries
        self(-1, np.r_[np.asarray(x0, float)[head], np.asarray(x0, float)[peaks]][None, :])

    def __call__(self, k: int, states: np.ndarray) -> None:
        """Take the kept states of outputs k + 1 .. k + len(states), the next ones in order."""
        if k + 1 != self._first + self._filled:
            raise ValueError(f"Outputs: states of output {k + 1} given, {self._first + self._filled} expected")
        t0 = time.perf_counter()
        i = 0
        while i < len(states):
            take = min(len(states) - i, len(self._buffer) - self._filled)
            self._buffer[self._filled:self._filled + take] = states[i:i + take]
            self._filled, i = self._filled + take, i + take
            if self._filled == len(self._buffer):
                self.flush()
        if len(states):
            self.last[:] = states[-1]
        self.seconds += time.perf_counter() - t0

    def flush(self) -> None:
        """Turn the states taken and not yet turned into the outputs they stand for (after a
        run: the last of them)."""
        a, m = self._first, self._filled
        self._first, self._filled = a + m, 0
        if self.bad is not None or m == 0:
            return
        X = self._buffer[:m]
        eqs, model, nc, L = self.eqs, self.problem.model, len(self.eqs.clearance_joints), self.system.layout
        q, qd = X[:, L.in_x("q")], X[:, L.in_x("qd")]
        if self.tree:  # back to reference-point coordinates
            qs = mapped(eqs.tree_state, p=q.T, pd=qd.T)
            q, qd = qs["q"].T, qs["qd"].T
        finite = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(qd), axis=1) & np.all(np.isfinite(X), axis=1)
        if not finite.all():
            self.bad = a + int(np.argmax(~finite))
            return
        W, Dd, Df = X[:, L.in_x("energy")].T  # the kept state holds z's events in place (kept_entries)
        dd0, inc = X[:, L.in_x("delta_dot0")], X[:, L.in_x("in_contact")]
        t = self.t[a:a + m]
        out = {name: v[a:a + m] for name, v in self.arrays.items()}  # views: written in place
        out["q"][:], out["qd"][:] = q, qd
        n = eqs.n_actuators
        effort = th = th_d = th_dd = np.zeros((m, n))
        if eqs.mode == "torque":
            effort = self.efforts(t, q, qd)
        elif self.references is not None:
            th, th_d, th_dd = self.references(t)
        acc = mapped(eqs.acceleration, q=q.T, qd=qd.T, effort=effort.T, theta_ref=th.T, theta_d_ref=th_d.T,
                     theta_dd_ref=th_dd.T, delta_dot0=dd0.T, in_contact=inc.T, t=t[None, :])

        def per_joint(v, rows):  # (rows, cols * m) -> (m, cols, rows), or (cols, m) -> (m, cols)
            return np.asarray(v).reshape(rows, m, -1).transpose(1, 2, 0) if rows == 2 else np.asarray(v).T

        out["qdd"][:], out["tau"][:] = acc["qdd"].T, acc["tau"].T
        out["driver_effort"][:] = acc["driver_effort"].T.reshape(m, -1)
        if nc:
            for name, rows in (("contact_force", 2), ("normal_force", 1), ("friction_force", 1), ("eccentricity", 2),
                               ("penetration", 1)):
                out[name][:] = per_joint(acc[name], rows)
            if "film_force" in eqs.acceleration.name_out():
                out["film_force"][:] = per_joint(acc["film_force"], 2)
        if eqs.passive_ideal_joints:
            out["reaction"][:] = per_joint(acc["reaction"], 2)
        if model.task is not None:
            f = model.task_pose_function
            out["pose"][:] = mapped(f, **{f.name_in(0): q.T})[f.name_out(0)].T
            out["pose_ref"][:] = path_rows(self.problem.path, t)[:, :3]
            out["platform_error"][:] = np.linalg.norm(out["pose"][:, :2] - out["pose_ref"][:, :2], axis=1)
        for name, v in energy_terms(eqs.energy, q, qd, W, Dd, Df).items():
            if name not in self.energy:
                self.energy[name] = np.zeros(len(self.t))
            self.energy[name][a:a + m] = v

    def simulation(self, stats: dict) -> Simulation:
        """The Simulation of the outputs taken (all of them: the run is over, and no state was
        non-finite), with `stats`."""
        self.flush()
        eqs, model, L = self.eqs, self.problem.model, self.system.layout
        wear, at = {}, L.in_x("wear").start
        for joint, surface, m in eqs.worn:  # the depths worn over the run, per profile
            wear.setdefault(joint, {})[surface] = self.last[at:at + m].copy()
            at += m
        losses = {j: 0 for j in model.passive_joints}
        losses.update({j: int(round(v)) for j, v in zip(eqs.clearance_joints, self.last[L.in_x("losses")],
                                                         strict=True)})
        if eqs.clearance_joints:  # where the run ended: what a continued run starts from
            stats = {**stats, "end_contact": {"delta_dot0": self.last[L.in_x("delta_dot0")].copy(),
                                              "in_contact": self.last[L.in_x("in_contact")].copy(),
                                              "profiles": profiles_of(eqs)}}
        return Simulation(
            scene=self.problem.scene, clearance_joints=eqs.clearance_joints,
            ideal_passive_joints=eqs.passive_ideal_joints, terms=eqs.terms, t=self.t, **self.arrays,
            contact_loss_events=losses, energy=self.energy, energy_audit_residual=energy_audit_residual(self.energy),
            extremes=extremes(eqs, self.last[self.system.kept - self.system.n_peaks:]), stats=stats, wear=wear)
