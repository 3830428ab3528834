"""The reference study of a scene: does a preload keep every clearance joint in contact,
and what does it buy in accuracy?

Pipeline (DESIGN section 1.4): scene -> inverse dynamics of the ideal mechanism along the
path -> preload torques with the scene's ``actuation.preload.method`` -> the clearance
simulation (:func:`rrr4.simulate`) twice, with the same PD controller:

- ``with_preload``: feed-forward = the preload torques tau_p + alpha n;
- ``without_preload``: feed-forward = the minimum-norm torques tau_p (alpha = 0).

The "with preload" arm exists only when the mechanism has actuation redundancy (4 chains)
and ``actuation.preload.min_force`` > 0: a fully actuated 3-RRR has no null space (its
inverse dynamics has a single solution), and f_min = 0 makes the minimum-norm torques
optimal, so both arms would be the same run.

A scene without a task body (a driven mechanism such as Flores's slider-crank) has no
preload question; its study compares the mechanism with its clearance joints against its
ideal twin (every joint ideal), driven alike:

- ``with_clearance``: the scene as given;
- ``ideal``: the same scene with every joint ideal, the reference;
- ``refinement``: ``with_clearance`` again at half the step, to show which results have
  converged in the step (kept in ``Study.refinement``, not drawn as an arm).

The simulations write every integrator step (output rate = 1/step), so the contact state
of every step is in the result and loss events can be located in time.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace

import numpy as np

from .dynamics.family import effort_family
from .errors import SceneError
from .mechanism import Model
from .preload import PreloadSolution, solve_preload
from .preload.solve import PreloadWarning
from .scene import MAX_SAMPLES, Scene, argument
from .simulation import Simulation, simulate
from .trajectory import sample_path

__all__ = ["Study", "StudyArm", "run_study", "has_preload_arm", "ARMS", "PRELOAD_ARMS", "DRIVEN_ARMS"]

PRELOAD_ARMS = ("with_preload", "without_preload")   # scenes with a task body
DRIVEN_ARMS = ("with_clearance", "ideal")             # scenes moved by drivers
ARMS = PRELOAD_ARMS + DRIVEN_ARMS


@dataclass(frozen=True)
class StudyArm:
    """One clearance simulation of the study and its wall time [s] (building + stepping)."""
    name: str
    simulation: Simulation
    wall_time: float


@dataclass(frozen=True)
class Study:
    """Result of :func:`run_study`.

    t_path (N,) [s] path samples; tau_min_norm (N, n) [N m] minimum-norm inverse-dynamics
    torques tau_p of the ideal mechanism; preload: the PreloadSolution (None without a
    preload arm); arms: name -> StudyArm, keys from :data:`ARMS`; preload_warning: the
    infeasibility report of the preload ('' if feasible).
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


def has_preload_arm(scene: Scene) -> bool:
    """True if the study of `scene` has a "with preload" arm (actuation redundancy and f_min > 0)."""
    return Model.of(scene.graph).redundancy >= 1 and scene.actuation.preload.min_force > 0


def _min_norm_torques(scene: Scene, t_path: np.ndarray) -> np.ndarray:
    """tau_p (N, n) [N m] of the ideal inverse dynamics at the path samples (zeros without a task)."""
    s = sample_path(scene.path)
    if scene.graph.task is None:
        return np.zeros((len(t_path), len(scene.graph.actuators)))
    return effort_family(scene, s.pose, s.pose_d, s.pose_dd).tau_p


def ideal_twin(scene: Scene) -> Scene:
    """`scene` with every joint ideal."""
    return scene.with_joints(tuple(replace(j, clearance=False) for j in scene.graph.joints))


def run_study(scene: Scene, *, t_end: float | None = None, step: float | None = None,
              integrator: str | None = None, progress: bool = False, log=None) -> Study:
    """Run the study of `scene`.

    t_end [s]: simulated time (default the path duration); step [s]: integrator step
    (default the scene's); integrator: method name (default the scene's); progress: show
    the simulations' progress bars; log: callable taking one line of text per stage.
    """
    say = log or (lambda _msg: None)
    t_end = scene.path.duration if t_end is None else argument("t_end", t_end)
    h = scene.integrator.step if step is None else argument("step", step)
    if t_end / h > MAX_SAMPLES:  # the study keeps every step: refuse before the preload is computed
        raise SceneError(f"t_end: {t_end:g} s is not allowed at step {h:g} s (the study keeps every step: at most "
                         f"{MAX_SAMPLES:g} steps)")
    t_path = sample_path(scene.path).t
    say(f"inverse dynamics of the ideal mechanism at {len(t_path)} path samples")
    tau_min_norm = _min_norm_torques(scene, t_path)

    preload, preload_warning = None, ""
    if has_preload_arm(scene):
        pre = scene.actuation.preload
        say(f"preload: method {pre.method}, f_min = {pre.min_force:g} N")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", PreloadWarning)
            preload = solve_preload(scene, pre.method)
        preload_warning = "\n".join(str(w.message) for w in caught if issubclass(w.category, PreloadWarning))
        if preload_warning:
            say(f"preload is infeasible at {int(np.sum(~preload.feasible))} samples; simulated anyway")

    def arm(name, sc, pl=None, step=h):
        say(f"simulate {name.replace('_', ' ')}: {t_end:g} s, step {step:g} s")
        wall = time.perf_counter()
        sim = simulate(sc, integrator, t_end=t_end, step=step, output_rate=1.0 / step, preload=pl, progress=progress)
        return StudyArm(name, sim, time.perf_counter() - wall)

    arms, refinement = {}, None
    if scene.graph.task is None:
        arms["with_clearance"] = arm("with_clearance", scene)
        arms["ideal"] = arm("ideal", ideal_twin(scene))
        if scene.clearance_joints:
            refinement = arm("with_clearance (half step)", scene, step=h / 2)
    else:
        if preload is not None:
            arms["with_preload"] = arm("with_preload", scene, preload)
        arms["without_preload"] = arm("without_preload", scene)
    return Study(scene=scene, t_path=t_path, tau_min_norm=tau_min_norm, preload=preload,
                 preload_warning=preload_warning, arms=arms, t_end=t_end, step=h, refinement=refinement)
