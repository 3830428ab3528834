"""Energy bookkeeping of a simulation.

E = T + V with kinetic T = qd^T M qd / 2 and potential V = sum_j K_j delta_j^(n+1)/(n+1)
(contact, the integral of the elastic force K delta^n) + gravity. Along a solution

    W_in(t) - (E(t) - E(0)) - D(t) = 0,

where W_in = int tau . theta_d dt is the actuator work and D = int (P_damping +
P_friction) dt the dissipation: P_damping = (F_N - K delta^n) delta_dot (the
hysteresis/dashpot part of the normal force) and P_friction = -f_t v_t. The powers are
outputs of the builder's ``acceleration`` Function and are integrated by the same
integrator as the motion. Ideal constraints do no work (up to constraint drift).
"""

from __future__ import annotations

import numpy as np

__all__ = ["energy_terms", "energy_audit", "energy_audit_residual"]


def energy_terms(energy_function, q, qd, work_in, dissipated_damping, dissipated_friction) -> dict:
    """Dict of (N,) arrays [J]: kinetic, potential, total, work_in, dissipated,
    dissipated_damping, dissipated_friction. q, qd (N, nq); the integrals (N,)."""
    f = energy_function.map(q.shape[0])
    kinetic, potential = (np.array(v).ravel() for v in f(q.T, qd.T))
    dissipated = np.asarray(dissipated_damping) + np.asarray(dissipated_friction)
    return {"kinetic": kinetic, "potential": potential, "total": kinetic + potential,
            "work_in": np.asarray(work_in, float), "dissipated": dissipated,
            "dissipated_damping": np.asarray(dissipated_damping, float),
            "dissipated_friction": np.asarray(dissipated_friction, float)}


def energy_audit(energy: dict) -> tuple[float, float]:
    """(largest imbalance max_t |W_in - (E - E(0)) - D| [J], the energy the run exchanges [J]:
    the largest |energy term| over the run, of kinetic, potential, total, work_in, dissipated)."""
    total = energy["total"]
    imbalance = energy["work_in"] - (total - total[0]) - energy["dissipated"]
    scale = max(float(np.max(np.abs(energy[k]))) for k in ("kinetic", "potential", "work_in", "dissipated", "total"))
    return float(np.max(np.abs(imbalance))), scale


def energy_audit_residual(energy: dict) -> float:
    """max_t |W_in - (E - E(0)) - D| / (largest |energy term| over the run); 0 if all terms vanish."""
    imbalance, scale = energy_audit(energy)
    return imbalance / scale if scale > 0 else 0.0
