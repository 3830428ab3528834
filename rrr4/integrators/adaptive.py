"""Shared loop of the adaptive methods (CasADi plugins, scipy solve_ivp).

An adaptive method integrates one output interval ("frame") at a time with its own step
control, inside its compiled core (SUNDIALS, CasADi, or scipy for the baseline); the
discrete contact state z is updated at each frame end, as the fixed-step methods do after
each step (between updates the force uses the onset rule, see
:mod:`rrr4.dynamics.builder`). Python runs once per frame, never once per step.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np

from ..errors import Rrr4Error
from .base import Integrator, Run, System, frame_inputs


class AdaptiveIntegrator(Integrator):
    """Base of the error-controlled methods: rtol, atol (relative and absolute local error).

    Capabilities: adaptive = True (error control, no step); compiles = False (the stepping
    is the solver's own); ladder: the rtol values `rrr4 bench accuracy` tries by default."""
    adaptive = True
    compiles = False
    ladder: tuple[float, ...] = (1e-3, 1e-5, 1e-7, 1e-9)

    def __init__(self, jit: bool = False, rtol: float = 1e-8, atol: float = 1e-10):
        for key, v in (("integrator.rtol", rtol), ("integrator.atol", atol)):
            if not (np.isfinite(v) and v > 0):
                raise Rrr4Error(f"{key}: {v!r} is not allowed (must be a finite number > 0)")
        self.jit, self.rtol, self.atol = False, float(rtol), float(atol)

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        return cls(jit=jit, rtol=settings.rtol, atol=settings.atol)

    @abstractmethod
    def prepare(self, system: System, h0: float) -> None:
        """Build what `integrate_frame` needs (once per run); h0 [s] is a first-step hint."""

    @abstractmethod
    def integrate_frame(self, t_a: float, t_b: float, y, z, u) -> tuple[np.ndarray, dict]:
        """(y at t_b, counters of this frame: steps, rejected, rhs, jacobians)."""

    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
            progress: bool = False, every: int = 1, sink=None) -> Run:
        """States at the end of every `every`-th frame, (n_frames / every, system.kept), and the solver's
        counters; frame k spans [u[k, 0], u[k, 1]]; sink: see :meth:`Integrator.run` (it gets
        each output as it is made). The discrete state, and with it the running peaks, is
        updated at each frame end: the solver's inner steps are its own."""
        self.prepare(system, h)
        u_frames = frame_inputs(u_frames)
        ny = system.ny
        x = np.asarray(x0, float)
        n_out = u_frames.shape[0] // every
        out = np.full((n_out, system.kept), np.nan) if sink is None else None
        made = 0  # outputs made

        def put(state):
            nonlocal made
            if sink is None:
                out[made] = state
            else:
                sink(made, state[None, :])
            made += 1

        totals = {"steps": 0, "rejected_steps": 0, "rhs_evaluations": 0, "jacobians": 0}
        frames = range(u_frames.shape[0])
        if progress:
            from tqdm import tqdm
            frames = tqdm(frames, desc=f"simulate ({self.name})", unit="frame")
        try:
            for k in frames:
                y, z = x[1:1 + ny], x[1 + ny:]
                u = np.array(system.held(y, z, u_frames[k]), float).ravel()
                t_a, t_b = u[0], u[1]
                y1, counts = self.integrate_frame(t_a, t_b, y, z, u)
                for key in totals:
                    totals[key] += int(counts.get(key, 0))
                if not np.all(np.isfinite(y1)):
                    break
                z1 = np.array(system.update(t_b, y1, z, u)).ravel()
                x = np.r_[t_b, y1, z1]
                if k % every == every - 1:  # keep the outputs only
                    put(np.r_[tuple(x[s] for s in system.kept_entries)])
        finally:
            if progress:
                frames.close()
        if sink is not None and made < n_out:  # a blown-up run: NaN from there on
            sink(made, np.full((n_out - made, system.kept), np.nan))
        return Run(out, {**totals, "rtol": self.rtol, "atol": self.atol})
