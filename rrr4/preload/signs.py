"""The sign policy of the pointwise preloads: which branch of the exact law, or which
fixed sign of the axial forces in the QP, a problem's controller and ``solve_preload``
use along the path.

One uniform sign (+1 or -1) for every joint: the one feasible at more path samples, ties
-> less effort (sum of squared efforts). With the exact law the sign is its branch
(alpha >= 0 or <= 0); with the QP the fixed sign of each joint's axial force relative to
the positive null-space preload.
"""

from __future__ import annotations

import numpy as np

from ..problem import Problem
from ..trajectory import sample_path
from .exact import exact_preload_function
from .qp import qp_preloads

__all__ = ["choose_signs", "preload_sign"]


def choose_signs(problem: Problem, raw, solver: str, exact: bool = False):
    """(sign, alpha, feasible) of the uniform fixed sign feasible at more samples of the
    effort family `raw` (``EffortFamily.raw``); ties -> less effort. exact: the branch of
    the exact law instead of the QP's axial-force sign."""
    best = None
    for s in (1.0, -1.0):
        if exact:
            f = exact_preload_function(problem, branch=int(s))
            alpha, tau, feas, _ = (np.array(v) for v in f.map(raw[0].shape[1])(*raw))
        else:
            alpha, tau, feas, _ = qp_preloads(problem, solver, s, raw)
        effort = np.nansum(tau**2)
        key = (-np.nansum(feas), effort)
        if best is None or key < best[0]:
            best = (key, s, alpha, feas)
    return best[1], best[2], best[3]


def preload_sign(problem: Problem) -> int:
    """The controller's fixed preload sign on the problem's path: +1 / -1 (the exact branch or
    the QP's axial-force sign that :func:`rrr4.solve_preload` picks), 0 without a preload.
    Computed once per preload structure (``Problem.preload_key``): problems that differ only
    in contact numbers, gains or the integrator share it."""
    if not problem.has_preload:
        return 0
    structure = problem.structure("preload")

    def choose():
        s = sample_path(structure.path)
        raw = structure.effort_family(s.pose, s.pose_d, s.pose_dd).raw
        p = structure.scene.actuation.preload
        return int(choose_signs(structure, raw, p.qp_solver, exact=p.method == "exact")[0])
    return structure.memo("preload_sign", choose)
