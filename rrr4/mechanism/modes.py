"""Assembly modes of a graph: the signed bend and stretch at a revolute joint, and the loops'
knees where a scene names no mode (see :class:`rrr4.scene.AssemblyMode` and
``mechanism.assembly`` in docs/scenes.md)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..scene import GROUND, AssemblyMode
from .model import Model

__all__ = ["mode_values", "mode_function", "knee_conditions"]


def mode_values(model: Model, q, conditions) -> ca.SX:
    """The normalised cross (bend) or dot (stretch) product of u = joint - a's reference and
    v = b's reference - joint at each condition's joint (see :class:`rrr4.scene.AssemblyMode`)."""
    out = []
    for m in conditions:
        j = model.graph.joint(m.joint)
        a, b = j.bodies
        joint = model.point(q, a, j.points[0])
        u = joint - model.point(q, a, m.points[0])
        v = model.point(q, b, m.points[1]) - joint
        num = u[0] * v[1] - u[1] * v[0] if m.measure == "bend" else u[0] * v[0] + u[1] * v[1]
        out.append(num / ca.sqrt(ca.sumsqr(u) * ca.sumsqr(v) + 1e-300))
    return ca.vertcat(*out) if out else ca.SX(0, 1)


def mode_function(model: Model, conditions) -> ca.Function:
    q = ca.SX.sym("q", model.nq)
    return ca.Function("branch", [q], [mode_values(model, q, conditions)])


def knee_conditions(model: Model) -> tuple:
    """bend at every revolute joint between two bodies that each have one other joint (the
    knees of the loops: a four-bar's coupler-rocker joint, an RRR chain's elbow)."""
    joints = model.graph.joints
    out = []
    for j in joints:
        if j.type != "revolute" or GROUND in j.bodies:
            continue
        refs = []
        for k, body in enumerate(j.bodies):
            other = [o for o in joints if o.name != j.name and body in o.bodies]
            if len(other) == 1 and np.hypot(*np.subtract(other[0].points[other[0].bodies.index(body)],
                                                          j.points[k])) > 1e-12:
                refs.append(tuple(other[0].points[other[0].bodies.index(body)]))
        if len(refs) == 2:
            out.append(AssemblyMode(j.name, "bend", 1, (refs[0], refs[1])))
    return tuple(out)
