"""What a study produces (:func:`rrr4.studies.study.run_study`): the :class:`Study` and its
arms, and the names of the arms, for everything that reads, draws or tabulates it.

Arms of a scene with a task body: ``with_preload``, ``with_preload_compensated``,
``without_preload`` (:data:`PRELOAD_ARMS`); of a scene moved by drivers: ``with_clearance``
and its ``ideal`` twin (:data:`DRIVEN_ARMS`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..preload import PreloadSolution
from ..problem import Problem
from ..scene import Scene
from ..simulation import Simulation

__all__ = ["Study", "StudyArm", "ARMS", "PRELOAD_ARMS", "DRIVEN_ARMS"]

PRELOAD_ARMS = ("with_preload", "with_preload_compensated", "without_preload")   # scenes with a task body
DRIVEN_ARMS = ("with_clearance", "ideal")             # scenes moved by drivers
ARMS = PRELOAD_ARMS + DRIVEN_ARMS


@dataclass(frozen=True)
class StudyArm:
    """One clearance simulation of the study, its wall time [s] (building + stepping, without
    compiling C) and the C compiler's time [s] for it (0 when its libraries were cached);
    convergence: with ``run_study(converge=...)``, the steps tried until its verdict passed
    (steps_s, energy_audit_residuals, wall_time_s and compile_time_s of all of them, budget_s,
    converged)."""
    name: str
    simulation: Simulation
    wall_time: float
    compile_time: float = 0.0
    convergence: dict | None = None


@dataclass(frozen=True)
class Study:
    """Result of :func:`rrr4.studies.study.run_study`.

    t_path (N,) [s] path samples; tau_min_norm (N, n) [N m] minimum-norm inverse-dynamics
    torques tau_p of the ideal mechanism; preload: the PreloadSolution (None without a
    preload arm); arms: name -> StudyArm, keys from :data:`ARMS`; preload_warning: the
    infeasibility report of the preload ('' if feasible); refinement: a driven scene's
    clearance arm rerun at half the step (None otherwise); skip [s]: the start-up window the
    metrics over the output samples discard (:mod:`rrr4.results.metrics`); overrides: what the
    caller set instead of the scene (t_end_s, integrator, step_s, output_rate_Hz, skip_s,
    converge_budget_s), as
    given, for summary.json; foresight: the one-line warnings said before the run
    (:func:`rrr4.simulation.foresight.foresight_lines`).
    """
    scene: Scene
    t_path: np.ndarray
    tau_min_norm: np.ndarray
    preload: PreloadSolution | None
    preload_warning: str
    arms: dict
    t_end: float
    step: float
    refinement: StudyArm | None = None
    skip: float = 0.0
    overrides: dict = field(default_factory=dict)
    foresight: tuple[str, ...] = ()

    @property
    def problem(self) -> Problem:
        """The Problem of the study's scene (built once per scene)."""
        return Problem.from_scene(self.scene)
