"""Maximum-velocity curves: the largest path speed s_dot at each s for which some path
acceleration and some null-space effort meet a family of constraints (the limit curves
of the phase plane, TOPP's MVC). One linear program per point in (a, b, alpha), maximising
b = s_dot^2 (scipy's HiGHS)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from ..problem import Problem
from .family import path_family
from .time_law import contact_directions

__all__ = ["limit_curves"]


def limit_curves(problem: Problem, points: int = 200, f_min: float | None = None, sign: int = 1,
                 b_cap: float = 1e6) -> dict[str, np.ndarray]:
    """{'s': (K,), 'actuator limits': (K,), 'actuator limits and contact': (K,)} [1/s]: the
    largest s_dot at each of K = points + 1 values of s with the actuators within their limits
    (alpha free), and with the preload QP's contact condition (sign, f_min default the scene's)
    as well (only with actuation redundancy). b_cap [1/s^2] bounds b where nothing else does;
    a point where no motion at all is feasible gets NaN."""
    s = np.linspace(0.0, 1.0, points + 1)
    fam = path_family(problem, s)
    L = np.asarray(problem.torque_limit, float)
    m = fam.tau_n.shape[2]
    f_min = problem.scene.actuation.preload.min_force if f_min is None else float(f_min)
    d = contact_directions(fam.r_n) if m else None
    out = {"s": s, "actuator limits": np.empty(len(s))}
    families = [("actuator limits", False)]
    if m and f_min > 0:
        families.append(("actuator limits and contact", True))
        out["actuator limits and contact"] = np.empty(len(s))
    for name, contact in families:
        for k in range(len(s)):
            rows = np.column_stack([fam.tau_a[k], fam.tau_b[k], fam.tau_n[k]])   # x = (a, b, alpha)
            A, ub = [rows, -rows], [L - fam.tau_g[k], L + fam.tau_g[k]]
            if contact:
                dk = d[k]
                crow = -sign * np.column_stack([np.einsum("jc,jc->j", dk, fam.r_a[k]),
                                                np.einsum("jc,jc->j", dk, fam.r_b[k]),
                                                np.einsum("jc,jcm->jm", dk, fam.r_n[k])])
                A.append(crow)
                ub.append(sign * np.einsum("jc,jc->j", dk, fam.r_g[k]) - f_min)
            res = linprog(np.r_[0.0, -1.0, np.zeros(m)], A_ub=np.vstack(A), b_ub=np.concatenate(ub),
                          bounds=[(None, None), (0.0, b_cap)] + [(None, None)] * m, method="highs")
            out[name][k] = np.sqrt(res.x[1]) if res.status == 0 else np.nan
    return out
