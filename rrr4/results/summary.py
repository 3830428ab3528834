"""Summaries: of a scene (what `rrr4 check` prints: bodies, joints, effects, equations,
path quality) and of a study (`summary.json`: per-arm metrics, the preload and the target
checks)."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..contact import V_MIN, hysteresis_factor
from ..contact.lubrication import min_film_thickness
from ..dynamics.builder import lubricated_joints, worn_joints
from ..functions import graph_size
from ..mechanism import wrap_angle
from ..mechanism.workspace import path_kinematics
from ..preload import PreloadSolution, PreloadWarning, solve_preload
from ..problem import Problem
from ..scene import Scene
from ..scene.vocabulary import CONTACT_LAW_KEYS, FRICTION_LAW_KEYS
from ..simulation import halving_check, remedy
from ..simulation.foresight import foresight_lines
from ..simulation.verdict import HALVING_WINDOW
from ..trajectory import sample_path
from .metrics import SETTLING_MARGIN, SETTLING_TAIL, WHOLE_RUN, WINDOWED, arm_metrics, driven_metrics, driven_window
from .study import PRELOAD_ARMS, Study

__all__ = ["scene_summary", "scene_check", "study_summary", "target_checks", "contact_numbers", "preload_lines",
           "CLIPPED", "unconverged", "verdict_line"]

# what the simulation does with efforts beyond the limits (one sentence for check, run, summary.json)
CLIPPED = ("the controller clips every effort at its limit, so there the journals are not held with f_min")

STIFFNESS_FROM_MATERIALS = "materials and radii (Lankarani-Nikravesh / Flores, internal cylinders)"
_FRICTION_UNITS = {"coefficient": "", "static_coefficient": "", "v0": "_m_s", "v1": "_m_s",
                   "stribeck_velocity": "_m_s"}


def contact_numbers(problem: Problem, v_min: float = V_MIN) -> dict | None:
    """Every number the scene's contact and friction laws use, the derived ones included
    (JSON-ready, units in the keys; None without a clearance joint): the law and its keys,
    the hysteresis factor chi(c_r) and the floor v_min [m/s] of the approach velocity (laws
    with hysteresis damping), the stiffness K [N/m^n] of every clearance joint and where it
    comes from, and the friction law with the keys it uses."""
    joints = problem.clearance_joints
    if not joints:
        return None
    c, f = problem.scene.effects.contact, problem.scene.effects.friction
    uses = CONTACT_LAW_KEYS[c.law]
    out: dict = {"law": c.law, "exponent": c.exponent}
    if "restitution" in uses:
        out.update(restitution=c.restitution, hysteresis_factor=hysteresis_factor(c.law, c.restitution),
                   v_min_m_s=v_min)
    if "damping" in uses:
        out["damping_Ns_per_m"] = c.damping
    out["stiffness_from"] = "scene" if c.stiffness is not None else STIFFNESS_FROM_MATERIALS
    out["stiffness_N_per_m^n"] = {j: problem.joint_stiffness(j) for j in joints}
    out["friction"] = {"law": f.law, **{k + _FRICTION_UNITS[k]: getattr(f, k) for k in FRICTION_LAW_KEYS[f.law]}}
    films = lubricated_joints(problem.model, problem.scene.effects)
    if films:  # only scenes with an oil film say so
        out["lubrication"] = {j: {"law": m.law, "viscosity_Pa_s": m.viscosity, "length_m": m.length,
                                  "threshold": m.threshold} for j, m in films}
    worn = worn_joints(problem.model, problem.scene.effects)
    if worn:  # only scenes with wear say so
        out["wear"] = {j: {"surfaces": w.surfaces, "coefficient": w.coefficient, "hardness_Pa": w.hardness,
                           "length_m": w.length, "nodes": w.nodes} for j, w in worn}
    return out


def contact_lines(numbers: dict | None) -> list[str]:
    """The lines of :func:`contact_numbers` that `rrr4 check` prints and report.md shows."""
    if numbers is None:
        return ["contact: none (all joints ideal, no contact or friction terms)"]
    n = numbers
    law = [f"contact: {n['law']}, exponent {n['exponent']:g}"]
    if "restitution" in n:
        law.append(f"c_r = {n['restitution']:g} (hysteresis factor chi = {n['hysteresis_factor']:.4g}), approach "
                   f"velocity floored at v_min = {n['v_min_m_s']:g} m/s")
    if "damping_Ns_per_m" in n:
        law.append(f"damping {n['damping_Ns_per_m']:g} N s/m")
    groups: dict[float, list[str]] = {}
    for j, k in n["stiffness_N_per_m^n"].items():
        groups.setdefault(k, []).append(j)
    stiff = "; ".join(f"{' '.join(js)}: {k:.4g} N/m^{n['exponent']:g}" for k, js in groups.items())
    fr = n["friction"]
    units = {"v0_m_s": ("v0", "m/s"), "v1_m_s": ("v1", "m/s"), "stribeck_velocity_m_s": ("v_s", "m/s"),
             "coefficient": ("mu", ""), "static_coefficient": ("mu_s", "")}
    terms = [f"{units[k][0]} = {v:g}{' ' + units[k][1] if units[k][1] else ''}" for k, v in fr.items() if k != "law"]
    friction = (f"friction: {fr['law']}, " + ", ".join(terms)) if terms else "friction: none (no friction terms)"
    films = [f"lubrication at {j}: {m['law']}, viscosity {m['viscosity_Pa_s']:g} Pa s, length {m['length_m']:g} m, "
             f"dry laws take over from eps = {m['threshold']:g} to 1" for j, m in n.get("lubrication", {}).items()]
    wear = [f"wear at {j}: Archard on {m['surfaces']}, k = {m['coefficient']:g}, H = {m['hardness_Pa']:g} Pa, "
            f"length {m['length_m']:g} m, {m['nodes']} profile coefficients" for j, m in n.get("wear", {}).items()]
    return [", ".join(law), f"  stiffness from {n['stiffness_from']}: {stiff}", friction, *films, *wear]


def _preload(study: Study) -> dict:
    pre = study.scene.actuation.preload
    if study.preload is None:
        redundant = study.problem.redundancy >= 1
        why = ("no task body: the drivers set the motion" if study.problem.model.task is None
               else "min_force = 0 N: the minimum-norm torques are optimal" if redundant
               else "no actuation redundancy: the inverse dynamics has a single solution")
        return {"method": None, "reason": why}
    sol = study.preload
    alpha = np.asarray(sol.alpha)
    over = [{"actuator": e.actuator, "unit": e.unit, "limit": e.limit, "peak": e.peak,
             "t_peak_s": e.t_peak, "excess": e.excess, "spans_s": [list(v) for v in e.spans], "samples": e.samples}
            for e in sol.effort_excess]
    return {"method": sol.method, "f_min_N": sol.f_min, "feasible": sol.all_feasible,
            "effort_over_limit": over, "efforts_in_simulation": CLIPPED if over else "within the limits",
            "infeasible_samples": int(np.sum(~sol.feasible)), "samples": len(sol.t),
            "alpha_min_Nm": float(alpha.min()), "alpha_max_Nm": float(alpha.max()),
            "smallest_margin_N": float(np.min(sol.margin)), "torque_peak_Nm": float(np.max(np.abs(sol.tau))),
            "torque_limit_Nm": list(sol.torque_limit), "weights": list(pre.weights),
            "wall_time_s": float(sol.statistics.get("wall_time", 0.0)), "report": study.preload_warning or None}


COMPENSATED_RMS_TARGET = 1e-6  # [m] platform RMS error the compensated arm aims at


def target_checks(summary: dict) -> dict:
    """The targets, evaluated: zero losses with preload over the whole run, RMS platform error
    with preload <= half of that without; with compensation, zero losses and RMS <= 1 um.
    No target is claimed on an arm that has not converged (its energy audit,
    :mod:`rrr4.simulation.verdict`): then ``not_claimed`` says which arm, and the targets that
    need it are absent."""
    w, wo, c = summary.get("with_preload"), summary.get("without_preload"), summary.get("with_preload_compensated")
    if w is None or wo is None:
        return {}
    off = [name for name, m in (("with_preload", w), ("without_preload", wo), ("with_preload_compensated", c))
           if m is not None and not m.get("converged", True)]
    out: dict = {"not_claimed": f"not converged: {', '.join(off)}; no target is claimed on an unconverged arm"} \
        if off else {}
    if not {"with_preload", "without_preload"} & set(off):
        ratio = w["platform_error_rms_m"] / wo["platform_error_rms_m"] if wo["platform_error_rms_m"] > 0 else None
        out.update({"zero_losses_with_preload": sum(w["contact_loss_events"].values()) == 0,
                    "rms_error_ratio_with_to_without": ratio,
                    "rms_error_at_most_half": ratio is not None and ratio <= 0.5})
    if c is not None and "with_preload_compensated" not in off:
        out.update({"zero_losses_compensated": sum(c["contact_loss_events"].values()) == 0,
                    "compensated_rms_at_most_1um": c["platform_error_rms_m"] <= COMPENSATED_RMS_TARGET})
    return out


def unconverged(summary: dict) -> dict:
    """arm -> its metrics, for every arm of a study summary (the driven scene's half-step rerun
    included) whose energy audit says it has not converged."""
    return {k: m for k, m in summary.items() if isinstance(m, dict) and m.get("converged") is False}


def verdict_line(summary: dict) -> str | None:
    """The one line that says which arms of a study have not converged, by how much, and what
    would converge them (None when every arm has converged)."""
    off = unconverged(summary)
    if not off:
        return None
    arms = ", ".join(f"{k} ({_why(m)})" for k, m in off.items())
    step = min(m["step_s"] for m in off.values())
    return f"not converged: {arms}; numbers of these arms are not to be trusted: try {remedy(step)}"


def _why(m: dict) -> str:
    """Why an arm has not converged: its energy audit, else its step-halving check."""
    if m["energy_audit_residual"] > m["energy_audit_tolerance"] or "step_halving" not in m:
        return f"energy audit residual {m['energy_audit_residual']:.3g} > {m['energy_audit_tolerance']:g}"
    h = m["step_halving"]
    return (f"at half the step it moves by {h['difference_m']:.3g} m > {h['tolerance_m']:.3g} m over the first "
            f"{h['window_s']:g} s")


def force_element_summary(e) -> dict:
    """A scene's force element for summary.json: its name, type, bodies and numbers with units
    in the keys (a tabulated load: its rows' count and time span)."""
    out = {"name": e.name, "type": e.type, "bodies": list(e.bodies)}
    if e.type == "load":
        out["frame"], out["known"] = e.frame, e.known
        if e.table:
            out.update(table_rows=len(e.table), table_span_s=[e.table[0][0], e.table[-1][0]])
        else:
            out.update(force_N=list(e.force), torque_Nm=e.torque)
        return out
    unit = "m" if e.type == "spring_damper" else "rad"
    spring = "N_per_m" if e.type == "spring_damper" else "Nm_per_rad"
    out.update({f"stiffness_{spring}": e.stiffness, f"damping_{spring}_s": e.damping,
                f"free_{'length' if unit == 'm' else 'angle'}_{unit}": e.free_length,
                f"preload_{'N' if unit == 'm' else 'Nm'}": e.preload})
    return out


def study_summary(study: Study) -> dict:
    """JSON-ready summary of a study (see the README's "What the main job prints")."""
    problem = study.problem
    sc, model = problem.scene, problem.model
    out = {"scene": sc.name, "description": sc.description, "scene_file": Path(sc.source).name if sc.source else None,
           **({"chains": sc.mechanism.n_chains} if problem.closed_form else {}),
           "bodies": list(model.body_names), "actuators": list(model.actuator_names),
           "clearance_joints": list(sc.clearance_joints),
           "contact": contact_numbers(problem, _v_min(study)),
           "initial_journals": sc.initial.journals,
           **({"forces": [force_element_summary(e) for e in sc.forces]} if sc.forces else {}),
           "preload": _preload(study)}
    if sc.actuation.mode == "torque" and model.n_actuators:  # a controller ran: its gains, and how each arm ran it
        out.update(gains={"kp_Nm_per_rad": sc.actuation.kp, "kd_Nms_per_rad": sc.actuation.kd},
                   controller=_controller(study))
    out["overrides"] = dict(study.overrides)  # what the command line set instead of the scene
    out["before_the_run"] = list(study.foresight)  # a law outside its range, a step too coarse (one line each)
    out["metrics_window"] = {
        "skip_s": study.skip, "over_window": list(WINDOWED), "over_whole_run": list(WHOLE_RUN),
        "settling_time": f"the first instant from which on the platform error stays within its range over the last "
                         f"{SETTLING_TAIL:.0%} of the run, widened by {SETTLING_MARGIN:.0%} of its largest value "
                         "there; near 75 % of the run it has not settled: run longer",
        "note": "a seated start puts the platform on the path at t = 0 and its offset builds over 0.1 to 0.5 s: "
                "short runs mislead; skip the settling time (rrr4 run --skip, a sweep spec's skip:)"}
    out["compile_time_s"] = float(sum(a.compile_time for a in study.arms.values())
                                  + (study.refinement.compile_time if study.refinement is not None else 0.0))
    out.update({k: None for k in PRELOAD_ARMS})
    for name, arm in study.arms.items():
        out[name] = arm_metrics(arm.simulation, arm.wall_time, study.skip, arm.compile_time)
        if films := film_metrics(problem, arm.simulation):  # a lubricated joint: its film, beside the dry force
            out[name]["film"] = films
        if arm.convergence is not None:  # rrr4 run --converge: the steps tried until the verdict passed
            out[name]["step_refinement"] = arm.convergence
    if "ideal" in study.arms:
        for k in PRELOAD_ARMS:
            out.pop(k)
        out.update(_driven(study, out))
    out["targets"] = target_checks(out)
    return out


def film_joints(problem: Problem, sim) -> list[tuple[int, str]]:
    """(index in ``sim.clearance_joints``, name) of the lubricated clearance joints of a run."""
    films = dict(lubricated_joints(problem.model, problem.scene.effects))
    return [(k, j) for k, j in enumerate(sim.clearance_joints) if j in films]


def film_metrics(problem: Problem, sim) -> dict:
    """Per lubricated joint, over the run's outputs: the peak film force, the peak total force
    on the journal (dry + film) [N] and the minimum film thickness h_min = c (1 - eps) [m]
    (0: the journal touched its bore); {} without a film."""
    out = {}
    for k, j in film_joints(problem, sim):
        h = min_film_thickness(sim.eccentricity[:, k], problem.joint(j).radial_clearance)
        out[j] = {"peak_film_force_N": float(np.max(np.linalg.norm(sim.film_force[:, k], axis=1))),
                  "peak_total_force_N": float(np.max(np.linalg.norm(sim.contact_force[:, k], axis=1))),
                  "min_film_thickness_m": float(np.min(h))}
    return out


def _v_min(study: Study) -> float:
    """The approach-velocity floor [m/s] the study's simulations used."""
    return next((a.simulation.stats.get("v_min", V_MIN) for a in study.arms.values()), V_MIN)


def _controller(study: Study) -> dict:
    """How each arm's controller ran: in CasADi or its generated C, continuous or sampled; the
    seat model of a compensated arm where it is not the default quasi-static one."""
    keys = ("controller", "control_rate", "preload", "compensation")
    return {name: {**{k: arm.simulation.stats.get(k) for k in keys},
                   **({"seat_model": s} if (s := arm.simulation.stats.get("seat_model", "none")) not in
                      ("none", "quasi_static") else {})}
            for name, arm in study.arms.items()}


def _driven(study: Study, out: dict) -> dict:
    """Driven scene: the clearance arm (and its half-step rerun) against the ideal twin, after
    the first driver revolution (the start transient from centred journals), or after the
    study's skip when one is given."""
    ideal = study.arms["ideal"].simulation
    t_from, revolution = driven_window(study.scene, study.t_end, study.skip)
    res = {"revolution_s": revolution}
    for name in ("with_clearance", "ideal"):
        res[name] = {**out[name], **driven_metrics(study.arms[name].simulation, ideal, t_from, revolution)}
    if study.refinement is not None:
        ref = study.refinement
        fine = {**arm_metrics(ref.simulation, ref.wall_time, study.skip, ref.compile_time),
                **driven_metrics(ref.simulation, _ideal_at(ref.simulation, ideal), t_from, revolution)}
        res["half_step"] = fine
        coarse = res["with_clearance"]
        res["step_convergence"] = {
            "impacts_per_revolution": {j: [coarse["impacts_per_revolution"][j], fine["impacts_per_revolution"][j]]
                                       for j in coarse["impacts_per_revolution"]},
            "peak_contact_force_N": {j: [coarse["peak_contact_force_N"][j], fine["peak_contact_force_N"][j]]
                                     for j in study.scene.clearance_joints},
            "acceleration_deviation_rms_m_s2": {
                b: [coarse["acceleration_deviation_rms_m_s2"][b], fine["acceleration_deviation_rms_m_s2"][b]]
                for b in coarse["acceleration_deviation_rms_m_s2"]},
            "steps_s": [coarse["step_s"], fine["step_s"]],
            "trajectory_difference_m": _trajectory_difference(study.arms["with_clearance"].simulation,
                                                              ref.simulation)}
        res["with_clearance"].update(_halving(study, res["step_convergence"]["trajectory_difference_m"]))
    return res


def _halving(study: Study, differences: dict) -> dict:
    """The clearance arm's step-halving check (:func:`rrr4.simulation.halving_check`) over the
    first millisecond (the whole run when shorter), and its verdict: converged only if both the
    energy audit and the check pass."""
    key = f"first_{HALVING_WINDOW * 1e3:g}_ms"
    window = HALVING_WINDOW if key in differences else study.t_end
    clearance = min(study.scene.joint(j).radial_clearance for j in study.scene.clearance_joints)
    check = halving_check(differences.get(key, differences["whole_run"]), window, clearance)
    arm = study.arms["with_clearance"].simulation
    return {"step_halving": check, "converged": arm.verdict.converged and check["passes"]}


def _trajectory_difference(coarse, fine) -> dict:
    """Largest centre-of-mass distance [m] of any body between a run and its half-step rerun,
    over growing windows from t = 0: where the runs agree the motion has converged in the
    step; a rattling journal's impacts then amplify any difference (the motion is chaotic)."""
    n = coarse.q.shape[1] // 3
    fine_q = np.column_stack([np.interp(coarse.t, fine.t, fine.q[:, k]) for k in range(fine.q.shape[1])])
    d = np.linalg.norm((coarse.q - fine_q).reshape(len(coarse.t), n, 3)[:, :, :2], axis=2).max(axis=1)
    out = {}
    for w in (1e-3, 3e-3, 1e-2):
        if coarse.t[-1] >= w:
            out[f"first_{w * 1e3:g}_ms"] = float(d[coarse.t <= w].max())
    out["whole_run"] = float(d.max())
    return out


def _ideal_at(sim, ideal):
    """The (smooth) ideal run at the instants of `sim`, a finer run: qdd interpolated linearly."""
    qdd = np.column_stack([np.interp(sim.t, ideal.t, ideal.qdd[:, k]) for k in range(ideal.qdd.shape[1])])
    return replace(ideal, t=sim.t, qdd=qdd)


def preload_lines(sol: PreloadSolution, problem: Problem) -> list[str]:
    """Whether the preload holds along the path, and where and by how much it fails: each
    actuator's peak need against its limit (:attr:`PreloadSolution.effort_excess`), the other
    failures, what the simulation does there, and the map that shows where it would hold."""
    head = f"preload along the path: {sol.method}, f_min = {sol.f_min:g} N, {len(sol.t)} samples: "
    if sol.all_feasible:
        k, i = np.unravel_index(int(np.argmax(np.abs(sol.tau))), sol.tau.shape)
        unit = problem.effort_units[i]
        return [head + f"holds at every sample; peak effort {abs(sol.tau[k, i]):.4g} {unit} at actuator "
                f"{problem.model.actuator_names[i]}, t = {sol.t[k]:.4g} s (limit {sol.torque_limit[i]:g} {unit})"]
    lines = [head + f"CANNOT HOLD at {int(np.sum(~sol.feasible))} of {len(sol.t)} samples"]
    lines += [f"  {e.describe()}" for e in sol.effort_excess]
    lines += [f"  {line.strip()}" for line in sol.report(max_lines=8, actuators=False).splitlines()[2:]]
    where = f"rrr4 map {problem.scene.source}" if problem.scene.source else "rrr4 map SCENE"
    lines.append(f"  {CLIPPED}: lower actuation.preload.min_force, raise the limits or slow the path; `{where}` "
                 "shows where in the workspace the preload holds and at what torque")
    return lines


def scene_check(scene: Scene | Problem) -> tuple[str, PreloadSolution | None]:
    """What `rrr4 check` prints (:func:`scene_summary`), and the scene's preload evaluated
    along the whole path with its method (None when the controller does not preload)."""
    problem = Problem.from_scene(scene)
    sol = None
    if problem.has_preload and problem.scene.actuation.mode == "torque":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PreloadWarning)  # reported below, in full
            sol = solve_preload(problem, branch="auto")  # the study's call: exact on the controller's branch
    text = _scene_text(problem)
    if sol is not None:
        text += "\n" + "\n".join(preload_lines(sol, problem))
    warn = foresight_lines(problem, preload=sol)
    if warn:
        text += "\n" + "\n".join(warn)
    return text, sol


def scene_summary(scene: Scene | Problem) -> str:
    """What `rrr4 check` prints: the bodies, joints, effects, equations and path of a scene,
    and whether its preload holds along the path."""
    return scene_check(scene)[0]


def _assembly_lines(problem: Problem) -> list[str]:
    """The assembled pose of every body at t = 0 (the path's start, or the drivers' initial
    values) and the branch the assembly chose (the named mechanism.assembly, or which one)."""
    q = problem.start_coordinates
    branch = problem.assembly_branch
    lines = ["assembled at t = 0 (x, y in mm, theta in deg, wrapped to (-180, 180]):"]
    for k, b in enumerate(problem.model.body_names):
        x, y, th = q[3 * k:3 * k + 3]
        lines.append(f"  {b}: ({x * 1e3:+.3f}, {y * 1e3:+.3f}) mm, {math.degrees(wrap_angle(th)):+.3f} deg")
    lines.append(f"  branch: {branch}")
    hint = problem.branch_hint
    if hint:
        lines.append(f"  {hint}")
    return lines


def _scene_text(problem: Problem) -> str:
    """The bodies, joints, effects, equations and path of a problem's scene."""
    scene, model = problem.scene, problem.model
    lines = [f"scene {scene.name}: {scene.description}".rstrip(": "), ""]
    lines.append(f"bodies ({len(model.body_names)}, {model.nq} coordinates):")
    if problem.closed_form:
        m = scene.mechanism
        for c in m.chains:
            lines.append(f"  chain {c.name}: base ({c.base[0]:+.3f}, {c.base[1]:+.3f}) m, "
                         f"driving {c.driving.length:.3f} m / {c.driving.mass:.3f} kg, "
                         f"following {c.following.length:.3f} m / {c.following.mass:.3f} kg, "
                         f"working mode {'+' if c.working_mode > 0 else '-'}acos")
        lines.append(f"  platform: {m.platform.mass:.3f} kg, {m.platform.inertia:.4g} kg m^2")
    else:
        for b in scene.graph.bodies:
            pts = ", ".join(p for p, _ in b.points)
            lines.append(f"  {b.name}: {b.mass:.4g} kg, {b.inertia:.4g} kg m^2; points {pts or 'none'}")
    acts = [f"{a.name} on {a.joint}" for a in scene.graph.actuators]
    task = ("no task body" if model.task is None else f"task body {model.task}" if model.task_dof == 3
            else f"task point of {model.task} (2 DOF)")
    lines.append(f"actuators ({len(acts)}): {', '.join(acts) or 'none'}; {task} "
                 f"(degree of redundancy {model.redundancy})")
    for d in scene.graph.drivers:
        rev = scene.graph.joint(d.joint).type == "revolute"
        what = (f"{math.degrees(d.initial):g} deg at {d.speed * 30 / math.pi:g} rpm" if rev
                else f"{d.initial:g} m at {d.speed:g} m/s")
        if d.time_law != "constant":  # a motion law: its travel over its duration, then at rest
            what = (f"{math.degrees(d.initial):g} deg, {d.time_law} law: {math.degrees(d.travel):g} deg in "
                    f"{d.duration:g} s (mean {d.speed * 30 / math.pi:g} rpm), then at rest" if rev else
                    f"{d.initial:g} m, {d.time_law} law: {d.travel:g} m in {d.duration:g} s (mean {d.speed:g} m/s), "
                    "then at rest")
        lines.append(f"driver {d.name}: joint {d.joint} from {what}")
    lines += _assembly_lines(problem)
    lines.append("")
    ideal = [j for j in model.joint_names if j not in model.clearance_joints]
    lines.append(f"ideal joints ({len(ideal)}): {' '.join(ideal)}")
    cl = [scene.joint(j) for j in scene.clearance_joints]
    if cl:
        lines.append(f"clearance joints ({len(cl)}):")
        for j in cl:
            lines.append(f"  {j.name}: journal radius {j.journal_radius * 1e3:.3g} mm, radial clearance "
                         f"{j.radial_clearance * 1e6:.4g} um, {j.journal_material.name}/{j.bearing_material.name}")
    else:
        lines.append("clearance joints: none")
    lines.append("")
    lines.append("effects simulated:")
    e = scene.effects
    lines += [f"  {line}" for line in contact_lines(contact_numbers(problem))]
    g = e.gravity
    lines.append(f"  gravity: {'none' if g == (0.0, 0.0) else f'({g[0]:g}, {g[1]:g}) m/s^2'}")
    a = scene.actuation
    if a.mode == "torque":
        pre = (f"{a.preload.method} preload (f_min = {a.preload.min_force:g} N)" if problem.has_preload
               else "no preload")
        comp = ", clearance compensation" if a.compensation == "clearance" else ""
        comp += " (rolling seats)" if a.compensation == "clearance" and a.seat_model == "rolling" else ""
        rate = f"sampled at {a.control_rate:g} Hz" if a.control_rate else "continuous"
        effort = problem.effort_unit
        kp, kd = (" or ".join(dict.fromkeys(pair[u == "N"] for u in problem.effort_units)) or pair[0]
                  for pair in (("N m/rad", "N/m"), ("N m s/rad", "N s/m")))
        lines.append(f"  actuation: controller = feed-forward + {pre}{comp} + PD (kp = {a.kp:g} {kp}, kd = "
                     f"{a.kd:g} {kd}), |effort| <= {max(scene.torque_limit):g} {effort}, {rate}")
    elif not model.n_actuators:
        lines.append("  actuation: none (no actuators" + ("; the drivers set the motion)" if scene.graph.drivers
                                                          else ")"))
    elif a.mode == "free":
        lines.append("  actuation: free (zero actuator torque)")
    else:
        lines.append("  actuation: prescribed actuator angles (driving constraints)")
    lines.append("")
    lines += _graph_lines(problem)
    lines.append("")
    s = sample_path(scene.path)
    pk = path_kinematics(problem.mechanism, s)
    if model.task is None:
        lines.append(f"path: none; the drivers set the motion for {scene.path.duration:g} s")
        integ = scene.integrator
        lines.append(f"integrator: {integ.method}, step {integ.step:g} s")
        return "\n".join(lines)
    lo, hi = s.pose.min(axis=0), s.pose.max(axis=0)
    speed = np.linalg.norm(s.pose_d[:, :2], axis=1).max()
    lines.append(f"path: {scene.path.type}, {scene.path.duration:g} s, {scene.path.time_law} time law, "
                 f"{len(s.t)} samples")
    turn = (f"theta_o in [{np.degrees(lo[2]):.2f}, {np.degrees(hi[2]):.2f}] deg" if model.task_dof == 3
            else f"task point of {model.task} (its angle is free)")
    lines.append(f"  x in [{lo[0] * 1e3:.2f}, {hi[0] * 1e3:.2f}] mm, y in [{lo[1] * 1e3:.2f}, {hi[1] * 1e3:.2f}] mm, "
                 f"{turn}; peak speed {speed:.4g} m/s")
    cond, t = pk.worst_condition
    lines.append(f"  worst Jacobian condition number {cond:.4g} at t = {t:.4g} s "
                 f"(allowed <= {scene.path.max_condition_number:g})")
    if pk.sin_transmission is not None:
        lines.append(f"  smallest transmission |sin| {np.abs(pk.sin_transmission).min():.3f} "
                     f"(allowed >= {scene.path.min_transmission:g})")
    integ = scene.integrator
    lines.append(f"integrator: {integ.method}, step {integ.step:g} s")
    return "\n".join(lines)


def _graph_lines(problem: Problem) -> list[str]:
    """Terms in the generated equations and the size of each CasADi graph."""
    eqs = problem.equations()
    lines = [f"equations: {eqs.nq} coordinates, {eqs.n_constraints} constraint rows; terms: "
             + "; ".join(eqs.terms)]
    for f in (eqs.acceleration, eqs.residual, eqs.contact_update, eqs.energy, eqs.tree_acceleration):
        if f is not None:
            g = graph_size(f)
            lines.append(f"  graph {f.name()}: {g['instructions']} SX instructions, {g['nodes']} nodes")
    c = problem.scene.integrator.coordinates
    if eqs.tree_acceleration is not None and c != "reference-point":
        lines.append(f"  stepped in {eqs.tree_acceleration.size1_in(0)} tree coordinates (integrator.coordinates: {c})")
    else:
        lines.append(f"  stepped in the {eqs.nq} reference-point coordinates (integrator.coordinates: {c})")
    return lines
