"""Wear of the clearance joints over many cycles, by cycle jumping (``rrr4 wear``).

One cycle is the scene's path (a task scene) or one revolution of its first driver (a driven
scene). The start transient runs once (:func:`settle`): cycle 0 from the scene's initial
state, then cycles each from the end of the last until one ends where it started (the
periodic steady state), each wearing once. Each step of the study then simulates one cycle
on the current wear profiles, starting where the last simulated cycle ended
(:func:`rrr4.simulate` with ``wear=`` and ``start=``: contact uses the worn clearance, and
each loaded journal moves until the deeper profile carries the force it ended with), takes the wear that cycle
adds (Archard's law integrated at every integrator step, :mod:`rrr4.contact.wear`), and
scales it by the number of cycles n for which the deepest change stays within
``max_change`` times the joint's radial clearance:

    w <- w + n dw,   n = max(1, floor(max_change c0 / max dw)),   capped at what is left of N

(Flores 2009, Mech. Mach. Theory 44; Mukras et al. 2010, Wear 268: the wear of a cycle is
extrapolated while the profile changes little). This is explicit Euler in the cycle count:
its error is first order in the jump, and :func:`wear_study` reports it against a run with
half the jumps (from the same end of the same start transient), naming a smaller
``max_change`` when it exceeds :data:`JUMP_TOLERANCE`. The last step simulates the cycle at
N on the final profiles, so every history ends at N.

Arms (task scene): ``with_preload`` and ``without_preload`` (:func:`rrr4.studies.study.arm_scene`;
only ``without_preload`` when the controller does not preload); a driven scene: ``with_clearance``.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..checks import argument
from ..contact.conformal import foundation_modulus, layer_exponent
from ..contact.lubrication import min_film_thickness
from ..contact.wear import node_depths, profile_volume
from ..errors import SceneError
from ..problem import Problem
from ..results.wear import PERIODIC, WearArm, WearStudy, jump_line
from ..scene import Scene
from ..simulation import simulate
from .study import arm_scene

__all__ = ["jump_cycles", "wear_study", "cycle_duration", "DEFAULT_MAX_CHANGE", "MAX_CYCLES", "settle", "periodicity",
           "suggested_max_change", "JUMP_TOLERANCE", "MAX_TRANSIENT", "MAX_REFINEMENT"]

DEFAULT_MAX_CHANGE = 0.02  # the deepest change of a profile per jump, in radial clearances
MAX_TRANSIENT = 5  # cycles the start transient may take before the jumps begin
JUMP_TOLERANCE = 0.02  # the jump error (of the deepest depth) beyond which the study names a smaller max_change
MAX_REFINEMENT = 8  # the default study adapts its max_change down to DEFAULT_MAX_CHANGE / MAX_REFINEMENT at most
MAX_CYCLES = 1e12


def jump_cycles(cycle, clearance: dict, cycles: int, max_change: float, progress: str = "", profiles=None,
                done: int = 0):
    """Cycle jumping to `cycles` cycles. cycle(profiles) -> (wear of one cycle on `profiles`:
    joint -> surface -> node depths (M,) [m], a record of the cycle); profiles None at the
    start (unworn). clearance: joint -> radial clearance c0 [m]. Returns (profiles after
    `cycles` cycles, the cycle counts where a cycle was simulated (K + 1,), the jumps (K,),
    the records (K + 1)): the last cycle simulated is the one at `cycles`. progress: the
    label of a progress bar over the cycles ('' for none). profiles, done: where an earlier
    stage left off (the start transient, :func:`settle`)."""
    at, jumps, records = [], [], []
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=cycles, initial=done, desc=progress, unit="cycle", leave=False)
    while True:
        wear, record = cycle(profiles)
        at.append(done)
        records.append(record)
        if done >= cycles:
            if bar is not None:
                bar.close()
            return profiles, np.array(at), np.array(jumps, int), records
        rate = max((float(np.max(d)) / clearance[j] for j, by in wear.items() for d in by.values()), default=0.0)
        n = cycles - done if rate <= 0 else int(min(cycles - done, max(1, math.floor(max_change / rate))))
        profiles = {j: {s: (0.0 if profiles is None else profiles[j][s]) + n * d for s, d in by.items()}
                    for j, by in wear.items()}
        done += n
        jumps.append(n)
        if bar is not None:
            bar.update(n)


def cycle_duration(problem: Problem) -> float:
    """One cycle [s]: the path's duration (a task scene), or one revolution of the first
    driver (a driven scene); raises SceneError for a driver that does not turn."""
    scene = problem.scene
    if problem.model.task is not None:
        return scene.path.duration
    drivers = scene.graph.drivers
    if not drivers or scene.graph.joint(drivers[0].joint).type != "revolute" or drivers[0].speed == 0:
        raise SceneError("mechanism.drivers: rrr4 wear needs a task path or a first driver that turns a revolute "
                         "joint at a non-zero speed (one cycle is one revolution)")
    if drivers[0].time_law != "constant":
        raise SceneError(f"mechanism.drivers[0].time_law: {drivers[0].time_law!r} is not allowed with rrr4 wear (one "
                         "cycle is one revolution at a constant speed, each starting where the last one ended: "
                         "choose constant)")
    return 2.0 * math.pi / abs(drivers[0].speed)


def _arms(problem: Problem) -> dict:
    if problem.model.task is None:
        return {"with_clearance": problem.scene}
    names = ("with_preload", "without_preload") if problem.has_preload else ("without_preload",)
    return {name: arm_scene(problem, name) for name in names}


class _Cycle:
    """cycle(profiles) of :func:`jump_cycles` for `scene` (an arm of `problem`): one simulated
    cycle on the profiles, starting where the last one it simulated ended (the first from the
    scene's initial state), and its record (per joint in the order of ``WearArm.joints``)."""

    def __init__(self, problem: Problem, scene: Scene, t_end: float):
        self.problem, self.scene, self.t_end, self.last = problem, scene, t_end, None
        self.joints = _joints(problem)
        self.modulus = _layer_moduli(problem, self.joints)

    def __call__(self, profiles):
        problem, joints = self.problem, self.joints
        wall = time.perf_counter()
        sim = simulate(self.scene, t_end=self.t_end, wear=profiles, start=self.last)
        self.last = sim
        e, volume = sim.platform_error, _volumes(problem, profiles)
        k = [sim.clearance_joints.index(j) for j in joints]
        film = np.linalg.norm(sim.film_force, axis=2)
        total = np.linalg.norm(sim.contact_force, axis=2)
        h_min = min_film_thickness(sim.eccentricity, [problem.joint(j).radial_clearance for j in sim.clearance_joints])
        record = {"platform_error_rms_m": float(np.sqrt(np.mean(e**2))), "platform_error_max_m": float(np.max(e)),
                  "contact_loss_events": int(sum(sim.contact_loss_events[j] for j in sim.clearance_joints)),
                  "dissipated_friction_J": float(sim.energy["dissipated_friction"][-1]),
                  "peak_contact_force_N": [float(sim.extremes["normal_force_max"][i]) for i in k],
                  "peak_layer_pressure_Pa": [self.modulus[j] * max(float(sim.extremes["penetration_max"][i]), 0.0) ** m
                                             for j, i in zip(joints, k, strict=True)
                                             for m in [layer_exponent(problem.scene.effects.contact.exponent)]],
                  "peak_film_force_N": [float(np.max(film[:, i])) for i in k],
                  "peak_total_force_N": [float(np.max(total[:, i])) for i in k],
                  "min_film_thickness_m": [float(np.min(h_min[:, i])) for i in k],
                  "periodicity": periodicity(sim),
                  "load_direction_deg": [_load_direction(problem, sim, j, total[:, i]) for j, i in zip(joints, k,
                                                                                                        strict=True)],
                  "volume_m3": [volume.get(j, 0.0) for j in joints],
                  "deepest_m": [max((float(np.max(node_depths(d))) for d in (profiles or {}).get(j, {}).values()),
                                    default=0.0) for j in joints],
                  "wear_per_cycle_m": [max(float(np.max(d)) for d in sim.wear[j].values()) for j in joints],
                  "wall_time_s": time.perf_counter() - wall}
        return sim.wear, record


def _layer_moduli(problem: Problem, joints) -> dict:
    """joint -> the conformal layer's modulus K_w [Pa / m^m] (:func:`rrr4.contact.conformal.foundation_modulus`)."""
    eqs, n = problem.equations(), problem.scene.effects.contact.exponent
    out = {}
    for j in joints:
        spec = problem.joint(j)
        out[j] = float(foundation_modulus(eqs.stiffness[eqs.clearance_joints.index(j)], n,
                                          problem.scene.effects.wear_of(spec).length, spec.bearing_radius,
                                          spec.radial_clearance))
    return out


def _load_direction(problem: Problem, sim, joint: str, force: np.ndarray) -> float | None:
    """Where the journal presses the bore over the cycle [deg, in the bearing body's frame]:
    the direction of the eccentricity averaged with the joint's total force as weight; None
    when the joint carried nothing."""
    k = sim.clearance_joints.index(joint)
    e = sim.eccentricity[:, k]
    i = problem.model.rotation_index(problem.joint(joint).bearing_body)
    angle = np.arctan2(e[:, 1], e[:, 0]) - (0.0 if i is None else sim.q[:, i])
    mean = np.sum(force * np.exp(1j * angle))
    return float(np.degrees(np.angle(mean))) if abs(mean) > 0 else None


def periodicity(sim) -> float:
    """How far a cycle is from the periodic steady state: the largest change of a journal's
    eccentricity from the cycle's start to its end, over the joint's radial clearance."""
    if not sim.clearance_joints:
        return 0.0
    c = np.array([sim.scene.joint(j).radial_clearance for j in sim.clearance_joints])
    return float(np.max(np.linalg.norm(sim.eccentricity[-1] - sim.eccentricity[0], axis=1) / c))


def settle(cycle: _Cycle, cycles: int, tolerance: float = PERIODIC, most: int = MAX_TRANSIENT):
    """The start transient: cycle 0 from the scene's initial state, then cycles each from the
    end of the last, until one ends within `tolerance` radial clearances of where it started
    (:func:`periodicity`), at most `most` cycles and `cycles`. Each of them wears once (no
    jump). Returns (profiles after them (None: none wore), their records)."""
    profiles, records = None, []
    while len(records) < min(most, cycles):
        wear, record = cycle(profiles)
        records.append(record)
        profiles = {j: {s: (0.0 if profiles is None else profiles[j][s]) + d for s, d in by.items()}
                    for j, by in wear.items()} if wear else profiles
        if len(records) > 1 and record["periodicity"] <= tolerance:
            break
    return profiles, records


def _joints(problem: Problem) -> tuple[str, ...]:
    """The clearance joints that wear, graph order."""
    return tuple(dict.fromkeys(j for j, _, _ in problem.equations().worn))


def wear_study(scene: Scene | Problem, cycles: float, max_change: float | None = None,
               check: bool = True, progress: bool = False, log=None) -> WearStudy:
    """The wear of every clearance joint of `scene` (which must ask for wear: ``effects.wear``
    or a joint's ``wear``) after `cycles` cycles, in each arm (see the module docstring).
    max_change in (0, 1]: the deepest change of a profile per jump, in radial clearances;
    None (the default): :data:`DEFAULT_MAX_CHANGE`, and where the check finds its error above
    :data:`JUMP_TOLERANCE`, the whole study again with the max_change the check suggests (at
    most :data:`MAX_REFINEMENT` times finer; ``WearStudy.adapted_from`` keeps the first
    check). check: also run the first arm with half the jumps and report the difference (the
    jump's error). progress: a progress bar over the cycles; log: callable taking one line per
    stage."""
    say = log or (lambda _m: None)
    problem = Problem.from_scene(scene)
    cycles = argument("cycles", cycles)
    if cycles != int(cycles) or cycles > MAX_CYCLES:
        raise SceneError(f"cycles: {cycles:g} is not allowed (a whole number from 1 to {MAX_CYCLES:g})")
    cycles = int(cycles)
    adaptive = max_change is None
    max_change = DEFAULT_MAX_CHANGE if adaptive else argument("max_change", max_change)
    if max_change > 1:
        raise SceneError(f"max_change: {max_change:g} is not allowed (a fraction of the radial clearance in (0, 1])")
    worn = problem.equations().worn
    if not worn:
        raise SceneError("effects.wear: 'none' is not allowed for rrr4 wear (no clearance joint wears: give "
                         "effects.wear with surfaces, coefficient, hardness and length)")
    study = _study(problem, cycles, max_change, check, progress, say)
    error = study.jump_error
    if adaptive and error is not None and error["suggested_max_change"] is not None:
        finer = _rounded_down(max(error["suggested_max_change"], max_change / MAX_REFINEMENT))
        say(f"the default jumps are too coarse: the study again with jumps of at most {finer:g} c")
        study = replace(_study(problem, cycles, finer, check, progress, say), adapted_from=error)
    return study


def _rounded_down(x: float) -> float:
    """x rounded down to two significant digits."""
    unit = 10.0 ** (math.floor(math.log10(x)) - 1)
    return float(f"{math.floor(x / unit + 1e-9) * unit:.2g}")  # printed as two digits, not 0.0045000000000000005


def _study(problem: Problem, cycles: int, max_change: float, check: bool, progress: bool, say) -> WearStudy:
    """The study of :func:`wear_study` with jumps of at most `max_change`."""
    worn = problem.equations().worn
    t_cycle = cycle_duration(problem)
    clearance = {j: problem.joint(j).radial_clearance for j, _, _ in worn}
    arms, settled = {}, {}
    for name, sc in _arms(problem).items():
        say(f"{name.replace('_', ' ')}: {cycles:g} cycles of {t_cycle:g} s, jumps of at most {max_change:g} c")
        wall = time.perf_counter()
        cycle = _Cycle(problem, sc, t_cycle)
        start, transient = settle(cycle, cycles)
        settled[name] = (start, cycle.last)
        say(f"{name.replace('_', ' ')}: start transient of {len(transient)} cycles, the last ending "
            f"{transient[-1]['periodicity']:.2g} c from its start")
        profiles, at, jumps, records = jump_cycles(cycle, clearance, cycles, max_change, profiles=start,
                                                   done=len(transient),
                                                   progress=name.replace("_", " ") if progress else "")
        arms[name] = WearArm(name=name, joints=_joints(problem), cycles=at, jumps=jumps, profiles=profiles,
                             volume=_volumes(problem, profiles), records=records, transient=transient,
                             wall_time=time.perf_counter() - wall)
    jump_error = None
    if check:
        first = next(iter(arms))
        say(f"{first.replace('_', ' ')}: again with half the jumps (max change {max_change / 2:g} c), for the "
            "jump's error")
        start, cycle = settled[first][0], _Cycle(problem, _arms(problem)[first], t_cycle)
        cycle.last = settled[first][1]  # from the same end of the same start transient
        profiles, *_ = jump_cycles(cycle, clearance, cycles, max_change / 2, profiles=start,
                                   done=len(arms[first].transient), progress="half jumps" if progress else "")
        jump_error = _jump_error(problem, arms[first], profiles, max_change)
        if jump_error["suggested_max_change"] is not None:
            say(jump_line(jump_error))
    return WearStudy(scene=problem.scene, cycles=cycles, max_change=max_change, cycle_time=t_cycle, arms=arms,
                     jump_error=jump_error)


def suggested_max_change(max_change: float, difference: float, tolerance: float | None = None) -> float | None:
    """The max_change that keeps the jump error within `tolerance` (of the deepest depth),
    from the `difference` measured between jumps of max_change and of half of it; None when
    that difference is already within it. Cycle jumping is first order: the error of jumps
    F is about twice that difference and shrinks in proportion to F, so F tol / (2 d) would
    just meet it; a margin of 2 more covers coarse jumps, where the error is not yet first
    order."""
    tolerance = JUMP_TOLERANCE if tolerance is None else tolerance
    return max_change * tolerance / (4 * difference) if difference > tolerance else None


def _volumes(problem: Problem, profiles) -> dict:
    """joint -> worn volume [m^3] of its profiles (0 for None: unworn)."""
    out = {}
    for joint, by in (profiles or {}).items():
        spec, w = problem.joint(joint), problem.scene.effects.wear_of(problem.joint(joint))
        radius = {"bearing": spec.bearing_radius, "journal": spec.journal_radius}
        out[joint] = sum(profile_volume(d, w.length, radius[s]) for s, d in by.items())
    return out


def _jump_error(problem: Problem, arm: WearArm, finer: dict, max_change: float) -> dict:
    """The difference of `arm` (jumps of max_change c) from the run with half its jumps:
    the largest profile difference over the largest depth, and per joint the worn volume's."""
    diff = max(float(np.max(np.abs(node_depths(arm.profiles[j][s] - finer[j][s])))) for j in finer for s in finer[j])
    deepest = max(float(np.max(node_depths(finer[j][s]))) for j in finer for s in finer[j])
    fine_volume = _volumes(problem, finer)
    error = diff / deepest if deepest > 0 else 0.0
    return {"arm": arm.name, "max_change": max_change, "finer_max_change": max_change / 2, "profile_error": error,
            "volume_error": {j: abs(arm.volume[j] - v) / v if v > 0 else 0.0 for j, v in fine_volume.items()},
            "tolerance": JUMP_TOLERANCE, "suggested_max_change": suggested_max_change(max_change, error)}
