"""`summary.json` of a study: per-arm metrics, the preload and the target checks."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..mechanism import Model
from ..study import Study
from .metrics import arm_metrics, driven_metrics

__all__ = ["study_summary", "target_checks"]


def _preload(study: Study) -> dict:
    pre = study.scene.actuation.preload
    if study.preload is None:
        redundant = Model.of(study.scene.graph).redundancy >= 1
        why = ("min_force = 0 N: the minimum-norm torques are optimal" if redundant
               else "no actuation redundancy: the inverse dynamics has a single solution")
        return {"method": None, "reason": why}
    sol = study.preload
    alpha = np.asarray(sol.alpha)
    return {"method": sol.method, "f_min_N": sol.f_min, "feasible": sol.all_feasible,
            "infeasible_samples": int(np.sum(~sol.feasible)), "samples": len(sol.t),
            "alpha_min_Nm": float(alpha.min()), "alpha_max_Nm": float(alpha.max()),
            "smallest_margin_N": float(np.min(sol.margin)), "torque_peak_Nm": float(np.max(np.abs(sol.tau))),
            "torque_limit_Nm": list(sol.torque_limit), "weights": list(pre.weights),
            "wall_time_s": float(sol.statistics.get("wall_time", 0.0)), "report": study.preload_warning or None}


def target_checks(summary: dict) -> dict:
    """The issue's targets, evaluated: zero losses with preload over the whole run and RMS
    platform error with preload <= half of that without."""
    w, wo = summary.get("with_preload"), summary.get("without_preload")
    if w is None or wo is None:
        return {}
    ratio = w["platform_error_rms_m"] / wo["platform_error_rms_m"] if wo["platform_error_rms_m"] > 0 else None
    return {"zero_losses_with_preload": sum(w["contact_loss_events"].values()) == 0,
            "rms_error_ratio_with_to_without": ratio,
            "rms_error_at_most_half": ratio is not None and ratio <= 0.5}


def study_summary(study: Study) -> dict:
    """JSON-ready summary of a study (see the README's "What the main job prints")."""
    sc = study.scene
    out = {"scene": sc.name, "description": sc.description, "scene_file": Path(sc.source).name if sc.source else None,
           "chains": sc.mechanism.n_chains if sc.mechanism is not None else None,
           "bodies": list(Model.of(sc.graph).body_names), "actuators": list(Model.of(sc.graph).actuator_names),
           "clearance_joints": list(sc.clearance_joints),
           "contact_law": sc.effects.contact.law if sc.clearance_joints else None,
           "friction_law": sc.effects.friction.law if sc.clearance_joints else None,
           "gains": {"kp_Nm_per_rad": sc.actuation.kp, "kd_Nms_per_rad": sc.actuation.kd},
           "initial_journals": sc.initial.journals,
           "preload": _preload(study),
           "with_preload": None, "without_preload": None}
    for name, arm in study.arms.items():
        out[name] = arm_metrics(arm.simulation, arm.wall_time)
    if "ideal" in study.arms:
        out.pop("with_preload"), out.pop("without_preload")
        out.update(_driven(study, out))
    out["targets"] = target_checks(out)
    return out


def _driven(study: Study, out: dict) -> dict:
    """Driven scene: the clearance arm (and its half-step rerun) against the ideal twin, after
    the first driver revolution (the start transient from centred journals)."""
    ideal = study.arms["ideal"].simulation
    speed = abs(study.scene.graph.drivers[0].speed) if study.scene.graph.drivers else 0.0
    revolution = 2 * np.pi / speed if speed > 0 else study.t_end
    t_from = revolution if revolution < 0.75 * study.t_end else 0.0
    res = {"revolution_s": revolution}
    for name in ("with_clearance", "ideal"):
        res[name] = {**out[name], **driven_metrics(study.arms[name].simulation, ideal, t_from, revolution)}
    if study.refinement is not None:
        ref = study.refinement
        fine = {**arm_metrics(ref.simulation, ref.wall_time),
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
            "steps_s": [coarse["step_s"], fine["step_s"]]}
    return res


def _ideal_at(sim, ideal):
    """The (smooth) ideal run at the instants of `sim`, a finer run: qdd interpolated linearly."""
    qdd = np.column_stack([np.interp(sim.t, ideal.t, ideal.qdd[:, k]) for k in range(ideal.qdd.shape[1])])
    return replace(ideal, t=sim.t, qdd=qdd)
