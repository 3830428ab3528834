"""Metrics of one arm of the study (one :class:`rrr4.Simulation`).

Contact state per output sample: a clearance joint is in contact while its penetration
delta > 0 (Flores). With one output sample per integrator step (as the study runs) this is
the state the simulation's own contact-loss counter sees, so loss events can be located in
time. Ideal joints never lose contact; their "contact force" is the pin reaction.
"""

from __future__ import annotations

import numpy as np

from ..simulation import Simulation

__all__ = ["arm_metrics", "loss_times"]


def loss_times(sim: Simulation) -> dict:
    """joint -> (k,) times [s] of contact -> free-flight transitions (empty for ideal joints)."""
    out = {j.name: np.zeros(0) for j in sim.scene.joints}
    contact = sim.penetration > 0
    for k, name in enumerate(sim.clearance_joints):
        lost = contact[:-1, k] & ~contact[1:, k]
        out[name] = sim.t[1:][lost]
    return out


def arm_metrics(sim: Simulation, wall_time: float) -> dict:
    """JSON-ready metrics of one simulation (units in the key names).

    contact_loss_events: joint -> count from the simulation's per-step counter (whole run);
    last_contact_loss_s (None without losses);
    free_flight_fraction: joint -> share of samples with delta <= 0; max_penetration_m;
    peak_contact_force_N / min_contact_force_N: joint -> max / min normal force (ideal
    joint: |reaction|); platform_error_rms_m / _max_m (position distance to
    the commanded path); torque_rms_Nm (over time and actuators), torque_peak_Nm;
    energy_audit_residual; wall_time_s; simulated_time_s; integrator, step_s, steps.
    """
    names = [j.name for j in sim.scene.joints]
    idx = {j: k for k, j in enumerate(sim.clearance_joints)}
    ideal = {j: k for k, j in enumerate(sim.ideal_passive_joints)}
    times = loss_times(sim)

    def per_joint(clearance_value, ideal_value):
        return {j: (clearance_value(idx[j]) if j in idx else ideal_value(ideal[j]) if j in ideal else 0.0)
                for j in names}

    reaction = np.linalg.norm(sim.reaction, axis=2) if sim.reaction.size else np.zeros((len(sim.t), 0))
    return {
        "contact_loss_events": {j: int(sim.contact_loss_events.get(j, 0)) for j in names},
        "last_contact_loss_s": max((float(v[-1]) for v in times.values() if v.size), default=None),
        "free_flight_fraction": per_joint(lambda k: float(np.mean(sim.penetration[:, k] <= 0)), lambda k: 0.0),
        "max_penetration_m": float(np.max(sim.penetration, initial=0.0)),
        "peak_contact_force_N": per_joint(lambda k: float(np.max(sim.normal_force[:, k])),
                                          lambda k: float(np.max(reaction[:, k]))),
        "min_contact_force_N": per_joint(lambda k: float(np.min(sim.normal_force[:, k])),
                                         lambda k: float(np.min(reaction[:, k]))),
        "platform_error_rms_m": float(np.sqrt(np.mean(sim.platform_error**2))),
        "platform_error_max_m": float(np.max(sim.platform_error)),
        "torque_rms_Nm": float(np.sqrt(np.mean(sim.tau**2))),
        "torque_peak_Nm": float(np.max(np.abs(sim.tau))),
        "energy_audit_residual": float(sim.energy_audit_residual),
        "wall_time_s": float(wall_time),
        "simulated_time_s": float(sim.t[-1] - sim.t[0]),
        "integrator": sim.stats["method"],
        "step_s": float(sim.stats["step"]),
        "steps": int(sim.stats["steps"]),
    }
