"""How robust is the clearance compensation? The controller keeps the scene's nominal model
while the simulated mechanism differs from it (DESIGN section 7; issue: clearance +-20 %,
contact stiffness x0.3 to x3, friction coefficient 0 to 0.2, one link 50 um long).

For each case :func:`robustness` simulates the preloaded controller with and without
compensation (both built from the nominal scene, ``simulate(..., model=nominal)``) on the
perturbed mechanism and reports the platform RMS and peak error and the contact losses.
With ``identified=True`` it closes the loop of identification (issue 33): the uncompensated
run of each perturbed mechanism is its measurement (task pose, actuator angles, efforts);
:func:`rrr4.identify` fits :data:`IDENTIFIED` to it from the nominal scene, and the
compensated controller runs once with the identified scene as its model ('model:
identified') and once with the true perturbed scene ('model: true').
:func:`write_robustness` (``rrr4 robustness SCENE``) writes them and their figure
(:func:`rrr4.results.figures.plot_robustness`).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from ..errors import SceneError
from ..files import write_atomic
from ..problem import Problem
from ..results.metrics import scalar_metrics
from ..scene import Scene
from ..simulation import simulate
from .study import arm_scene

__all__ = ["CASES", "ARMS", "IDENTIFIED", "robustness", "perturbed", "write_robustness"]

# name -> (scene key path, how the nominal value changes): a factor on a number, a value, or
# a length added [m] to the first chain's driving link
CASES = {
    "nominal": None,
    "clearance -20 %": ("joints.radial_clearance", "factor", 0.8),
    "clearance +20 %": ("joints.radial_clearance", "factor", 1.2),
    "stiffness x0.3": ("effects.contact.stiffness", "factor", 0.3),
    "stiffness x3": ("effects.contact.stiffness", "factor", 3.0),
    "friction 0": ("effects.friction.coefficient", "value", 0.0),
    "friction 0.2": ("effects.friction.coefficient", "value", 0.2),
    "link A1B1 +50 um": ("mechanism.chains[0].driving_link.length", "add", 50e-6),
}
ARMS = ("with_preload", "with_preload_compensated")
# what identification fits in every case (it is not told which parameter changed)
IDENTIFIED = ("joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness",
              *(f"mechanism.chains[{i}].driving_link.length" for i in range(4)))
METRICS = ("platform_error_rms_m", "platform_error_max_m", "contact_loss_events")  # of scalar_metrics, per row


def perturbed(problem: Problem | Scene, case: str) -> Scene:
    """The mechanism of robustness case `case` (a key of :data:`CASES`): the scene (of the
    problem) with one parameter changed at its dotted key (n-RRR scenes), through
    :meth:`rrr4.scene.Scene.with_values`, so a scene changed in memory or built in Python is
    varied as it is."""
    scene = problem if isinstance(problem, Scene) else problem.scene
    problem = Problem.from_scene(scene)
    if case not in CASES:
        raise SceneError(f"case: {case!r} is not allowed (choose one of: {', '.join(CASES)})")
    if CASES[case] is None:
        return scene
    if not problem.closed_form:
        raise SceneError("mechanism.kind: robustness cases are defined for n-RRR scenes")
    key, how, v = CASES[case]
    first, link = scene.clearance_joints[0], scene.mechanism.chains[0].driving
    nominal = {"joints.radial_clearance": scene.joint(first).radial_clearance,
               "effects.contact.stiffness": problem.joint_stiffness(first),
               "mechanism.chains[0].driving_link.length": link.length}.get(key)
    values = {key: nominal * v if how == "factor" else nominal + v if how == "add" else v}
    if key.startswith("mechanism.chains[0].driving_link"):  # the link's mass and inertia stay nominal
        values.update({"mechanism.chains[0].driving_link.mass": link.mass,
                       "mechanism.chains[0].driving_link.inertia": link.inertia})
    return scene.with_values(values, name=f"{scene.name}, {case}")


def robustness(scene: Scene | Problem, t_end: float | None = None, progress: bool = False, log=None,
               identified: bool = False) -> list[dict]:
    """Rows {case, arm, model, platform_error_rms_m, platform_error_max_m, contact_loss_events,
    wall_time_s}: the scene's preloaded controller, uncompensated and compensated, built
    from the nominal scene (model 'nominal'), on each perturbed mechanism of :data:`CASES`;
    with `identified`, the compensated controller also with the true perturbed scene
    (model 'true') and with the scene identified from the uncompensated run (model
    'identified', the row also holding the estimates)."""
    say = log or (lambda _m: None)
    problem = Problem.from_scene(scene)
    scene = scene if isinstance(scene, Scene) else problem.scene  # the one given is the one varied
    if not problem.closed_form or not problem.clearance_joints:
        raise SceneError("mechanism: robustness cases are defined for n-RRR scenes with clearance joints "
                         f"(scene {scene.name!r} has {'none' if problem.closed_form else 'a graph'})")
    scene.with_values({})  # refuse a scene without its YAML data before simulating anything
    models = {arm: arm_scene(problem, arm) for arm in ARMS}
    rows = []
    for case in CASES:
        plant = Problem.from_scene(perturbed(scene, case))
        runs = {}
        for arm, model in models.items():
            say(f"{case}: {arm.replace('_', ' ')}")
            wall = time.perf_counter()
            runs[arm] = sim = simulate(arm_scene(plant, arm), t_end=t_end, model=model, progress=progress)
            rows.append(_row(case, arm, "nominal", sim, wall))
        if identified:
            rows += _closed_loop(problem, plant, case, runs["with_preload"], t_end, progress, say)
    return rows


def _row(case: str, arm: str, model: str, sim, wall: float, **extra) -> dict:
    m = scalar_metrics(sim)
    return {"case": case, "arm": arm, "model": model, **{k: m[k] for k in METRICS},
            "wall_time_s": time.perf_counter() - wall, **extra}


def _closed_loop(problem: Problem, plant: Problem, case: str, measured, t_end, progress, say) -> list[dict]:
    """The compensated controller on `plant` with the true model and with the model identified
    from the uncompensated run `measured`."""
    from ..identify import identify, measurements_from_simulation
    arm = "with_preload_compensated"
    say(f"{case}: identify from the uncompensated run")
    wall = time.perf_counter()
    ident = identify(problem, measurements_from_simulation(measured), list(IDENTIFIED), method="seated")
    estimates = {k: ident.value(k) for k in ident.keys}
    sim = simulate(arm_scene(plant, arm), t_end=t_end, model=arm_scene(Problem.from_scene(ident.identified), arm),
                   progress=progress)
    out = [_row(case, arm, "identified", sim, wall, estimates=estimates,
                identifiable=bool(ident.verdict["identifiable"]))]
    say(f"{case}: compensated with the true model")
    wall = time.perf_counter()
    out.append(_row(case, arm, "true", simulate(arm_scene(plant, arm), t_end=t_end, progress=progress), wall))
    return out


def write_robustness(scene: Scene, out: Path, t_end: float | None = None, progress: bool = False,
                     log=None, identified: bool = False) -> list[Path]:
    """Run :func:`robustness` and write ``robustness.json`` and ``robustness.png`` into out."""
    from ..results.figures import plot_robustness
    rows = robustness(scene, t_end=t_end, progress=progress, log=log, identified=identified)
    out.mkdir(parents=True, exist_ok=True)
    meta = {"scene": scene.name, "t_end_s": t_end or scene.path.duration, "cases": {
        k: (None if v is None else {"key": v[0], "change": v[1], "value": v[2]}) for k, v in CASES.items()},
            "identified_parameters": list(IDENTIFIED) if identified else [], "rows": rows}
    js = out / "robustness.json"
    write_atomic(js, json.dumps(meta, indent=1) + "\n")
    models = "the nominal model; compensated also with the identified and the true model" if identified else \
        "the nominal model"
    png = plot_robustness(rows, out / "robustness.png", f"{scene.name}: controller with {models}, "
                                                          f"{meta['t_end_s']:g} s")
    return [js, png]
