"""Metrics of a simulation (one :class:`rrr4.Simulation`): one implementation for the study
(:func:`arm_metrics`, :func:`driven_metrics`), the sweep's CSV columns and the robustness
table (:func:`scalar_metrics`).

Contact state per output sample: a clearance joint is in contact while its penetration
delta > 0 (Flores). With one output sample per integrator step (as the study runs) this is
the state the simulation's own contact-loss counter sees, so loss events can be located in
time. Ideal joints never lose contact; their "contact force" is the pin reaction.

Peaks and minima of the contact forces, the penetration and the efforts are those of the
motion, not of its samples: the simulation tracks them at every integrator step
(``Simulation.extremes``), so a sweep that keeps outputs at 1 kHz and a run that keeps every
step report the same numbers. Ideal joints' reactions and the prescribed mode's efforts are
taken over the output samples.
"""

from __future__ import annotations

import numpy as np

from ..problem import Problem
from ..simulation import Simulation

__all__ = ["scalar_metrics", "SCALAR_METRICS", "arm_metrics", "loss_times", "contact_onsets", "driven_metrics"]

SCALAR_METRICS = ("contact_loss_events", "platform_error_rms_m", "platform_error_max_m", "min_contact_force_N",
                  "peak_contact_force_N", "torque_rms_Nm")


def loss_times(sim: Simulation) -> dict:
    """joint -> (k,) times [s] of contact -> free-flight transitions (empty for ideal joints)."""
    out = {j.name: np.zeros(0) for j in sim.scene.joints}
    contact = sim.penetration > 0
    for k, name in enumerate(sim.clearance_joints):
        lost = contact[:-1, k] & ~contact[1:, k]
        out[name] = sim.t[1:][lost]
    return out


def scalar_metrics(sim: Simulation) -> dict:
    """One number per metric of :data:`SCALAR_METRICS` (units in the names):
    contact_loss_events (all joints, whole run, from the simulation's per-step counter);
    platform_error_rms_m / _max_m (position distance to the commanded path, over the
    samples); min_contact_force_N / peak_contact_force_N (over every clearance joint and
    integrator step; NaN without one); torque_rms_Nm (over time and actuators; 0 without
    actuators)."""
    e, ext = sim.platform_error, sim.extremes
    nc = len(sim.clearance_joints)
    return {"contact_loss_events": int(sum(sim.contact_loss_events.values())),
            "platform_error_rms_m": float(np.sqrt(np.mean(e**2))),
            "platform_error_max_m": float(np.max(e)),
            "min_contact_force_N": float(ext["normal_force_min"].min()) if nc else float("nan"),
            "peak_contact_force_N": float(ext["normal_force_max"].max()) if nc else float("nan"),
            "torque_rms_Nm": float(np.sqrt(np.mean(sim.tau**2))) if sim.tau.size else 0.0}


def arm_metrics(sim: Simulation, wall_time: float) -> dict:
    """JSON-ready metrics of one simulation (units in the key names).

    contact_loss_events: joint -> count from the simulation's per-step counter (whole run);
    last_contact_loss_s (None without losses);
    free_flight_fraction: joint -> share of samples with delta <= 0; max_penetration_m;
    peak_contact_force_N / min_contact_force_N: joint -> max / min normal force over every
    integrator step (ideal joint: |reaction|, over the samples); platform_error_rms_m /
    _max_m (position distance to the commanded path); torque_rms_Nm (over time and
    actuators), torque_peak_Nm (over every step in torque mode);
    energy_audit_residual; wall_time_s; simulated_time_s; integrator, step_s, steps.
    A metric that does not apply is absent: the contact metrics list the clearance and the
    passive ideal revolute joints (a prismatic joint has no journal), the platform error needs
    a task body, the torques actuators.
    """
    model = Problem.from_scene(sim.scene).model
    idx = {j: k for k, j in enumerate(sim.clearance_joints)}
    ideal = {j: k for k, j in enumerate(sim.ideal_passive_joints)}
    names = [j.name for j in sim.scene.joints if j.name in idx or j.name in ideal]
    times = loss_times(sim)

    def per_joint(clearance_value, ideal_value):
        return {j: (clearance_value(idx[j]) if j in idx else ideal_value(ideal[j])) for j in names}

    reaction = np.linalg.norm(sim.reaction, axis=2) if sim.reaction.size else np.zeros((len(sim.t), 0))
    flat, ext = scalar_metrics(sim), sim.extremes
    tau_peak = ext["tau_abs_max"] if "tau_abs_max" in ext else np.abs(sim.tau)
    task = {k: flat[k] for k in ("platform_error_rms_m", "platform_error_max_m")} if model.task is not None else {}
    efforts = ({"torque_rms_Nm": flat["torque_rms_Nm"], "torque_peak_Nm": float(np.max(tau_peak, initial=0.0)),
                **_at_limit(sim)} if model.n_actuators else {})
    return {
        "contact_loss_events": {j: int(sim.contact_loss_events.get(j, 0)) for j in names},
        "last_contact_loss_s": max((float(v[-1]) for v in times.values() if v.size), default=None),
        "free_flight_fraction": per_joint(lambda k: float(np.mean(sim.penetration[:, k] <= 0)), lambda k: 0.0),
        "max_penetration_m": float(np.max(ext["penetration_max"], initial=0.0)),
        "peak_contact_force_N": per_joint(lambda k: float(ext["normal_force_max"][k]),
                                          lambda k: float(np.max(reaction[:, k]))),
        "min_contact_force_N": per_joint(lambda k: float(ext["normal_force_min"][k]),
                                         lambda k: float(np.min(reaction[:, k]))),
        **task,
        **efforts,
        "energy_audit_residual": float(sim.energy_audit_residual),
        "wall_time_s": float(wall_time),
        "simulated_time_s": float(sim.t[-1] - sim.t[0]),
        "integrator": sim.stats["method"],
        "step_s": float(sim.stats["step"]),
        "steps": int(sim.stats["steps"]),
    }


def _at_limit(sim: Simulation) -> dict:
    """effort_at_limit_fraction: actuator -> share of output samples where the controller's
    effort sits at its limit (clipped), for a torque-driven simulation with actuators."""
    model = Problem.from_scene(sim.scene).model
    if sim.scene.actuation.mode != "torque":
        return {}
    limits = np.asarray(sim.scene.torque_limit, float)
    at = np.abs(sim.tau) >= limits * (1 - 1e-9)
    return {"effort_at_limit_fraction": {a: float(np.mean(at[:, i])) for i, a in enumerate(model.actuator_names)}}


def contact_onsets(sim: Simulation) -> dict:
    """clearance joint -> (k,) times [s] of free-flight -> contact transitions (impacts)."""
    contact = sim.penetration > 0
    return {j: sim.t[1:][~contact[:-1, k] & contact[1:, k]] for k, j in enumerate(sim.clearance_joints)}


def driven_metrics(sim: Simulation, ideal: Simulation, t_from: float, revolution: float) -> dict:
    """Metrics of a driven mechanism against its ideal twin (same driver), over t >= t_from
    (after the start transient). revolution [s]: period of the first driver.

    impacts_per_revolution: joint -> contact onsets per driver revolution;
    body_acceleration_peak_m_s2: body -> max |a| of the centre of mass;
    acceleration_deviation_rms_m_s2 / _max_: body -> RMS / max |a - a_ideal|;
    driver_effort_peak_Nm / _rms_Nm: revolute driver -> max / RMS |effort| [N m], and
    driver_effort_peak_N / _rms_N for prismatic drivers [N] (each only where such drivers exist)."""
    model = Problem.from_scene(sim.scene).model
    keep = sim.t >= t_from
    span = max(float(sim.t[keep][-1] - sim.t[keep][0]), 1e-300) if keep.sum() > 1 else 1e-300
    onsets = contact_onsets(sim)
    acc = {b: sim.qdd[:, model.coordinates(b)][:, :2] for b in model.body_names}
    acc_ideal = {b: ideal.qdd[:, model.coordinates(b)][:, :2] for b in model.body_names}
    dev = {b: np.linalg.norm(acc[b] - acc_ideal[b], axis=1)[keep] for b in model.body_names}
    efforts: dict = {}
    for k, d in enumerate(sim.scene.graph.drivers):
        unit = "Nm" if sim.scene.graph.joint(d.joint).type == "revolute" else "N"
        e = sim.driver_effort[keep, k]
        efforts.setdefault(f"driver_effort_peak_{unit}", {})[d.name] = float(np.max(np.abs(e)))
        efforts.setdefault(f"driver_effort_rms_{unit}", {})[d.name] = float(np.sqrt(np.mean(e**2)))
    return {
        "after_s": float(t_from),
        "impacts_per_revolution": {j: float(np.sum(v >= t_from) * revolution / span) for j, v in onsets.items()},
        "body_acceleration_peak_m_s2": {b: float(np.max(np.linalg.norm(a[keep], axis=1))) for b, a in acc.items()},
        "acceleration_deviation_rms_m_s2": {b: float(np.sqrt(np.mean(v**2))) for b, v in dev.items()},
        "acceleration_deviation_max_m_s2": {b: float(np.max(v)) for b, v in dev.items()},
        **efforts,
    }
