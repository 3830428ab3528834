"""Force elements (``forces:`` of a scene, :mod:`rrr4.scene.forces`) as generalised forces.

Each spring-damper acts along a scalar coordinate s(q) of the mechanism: the distance
|p_b - p_a| between its two points (translational) or the angle theta_b - theta_a
(rotational; on a revolute joint, its joint angle). Its force along s is

    f = -(k (s - s0) + F0 + c s_dot),    Q = f (ds/dq)^T,

with stiffness k, damping c, free length (angle) s0 and preload F0 (positive is tension: it
pulls the points together, or turns b clockwise against a, as a free length shorter by
F0 / k would; Exudyn's SpringDamper ``force`` has the same sign). The spring's energy is
V = k (s - s0)^2 / 2 + F0 (s - s0) (the preload is a constant force, so conservative), the
damper dissipates P = c s_dot^2 >= 0. A load is a force F (N, in the ground frame or rotated
with the body) at a point of a body, and a torque tz [N m]: Q = J_p^T F + tz e_theta, with
power Q . qd (work done on the mechanism). A tabulated load interpolates its rows (t, fx,
fy, tz) linearly and holds the first and last rows outside them (t clamped), with CasADi's
'linear' interpolant, which generated C evaluates too.

The distance is guarded: s = sqrt(|d|^2 + EPS^2) with EPS = 1e-9 m, so a spring whose two
points meet keeps a finite force (its direction is then 0, not a division by zero).

The numbers k, c, s0, F0 of a spring and fx, fy, tz of a constant load are inputs
(:data:`rrr4.scene.forces.FORCE_PARAMETERS`, 4 per element, ``Problem.force_parameters``),
so that sweeps over them share compiled code; a load's table is structure.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..mechanism.model import Model, rotation
from ..scene.forces import FORCE_PARAMETERS, ForceElement
from ..scene.vocabulary import FORCE_ELEMENTS, registry
from .assembly import Assembly, Term

__all__ = ["ForceTerms", "force_terms", "element_coordinate", "element_forces_function", "N_PARAMETERS", "EPS",
           "ELEMENT_TERMS", "ForceElementTerm"]

N_PARAMETERS = len(FORCE_PARAMETERS["spring_damper"])  # per element (every type has as many)
EPS = 1e-9        # [m] guard of a spring's length


@dataclass(frozen=True)
class ForceTerms:
    """Generalised force Q (nq,) of all elements, their potential [J], the dampers' power
    (dissipated, >= 0) [W] and the loads' power (work done on the mechanism) [W]."""
    Q: ca.SX
    potential: ca.SX
    power_damping: ca.SX
    power_load: ca.SX


def element_coordinate(model: Model, element: ForceElement, q) -> ca.SX:
    """s(q) of a (rotational) spring-damper: length [m] or angle [rad]."""
    a, b = element.bodies
    if element.type == "rotational_spring_damper":
        return model.body_pose(q, b)[1] - model.body_pose(q, a)[1]
    d = model.point(q, b, element.points[1]) - model.point(q, a, element.points[0])
    return ca.sqrt(ca.dot(d, d) + EPS**2)


def _spring(model, element, q, qd, t, p):
    k, c, s0, f0 = (p[i] for i in range(N_PARAMETERS))
    s = element_coordinate(model, element, q)
    ds = ca.jacobian(s, q)
    s_dot = ds @ qd
    f = -(k * (s - s0) + f0 + c * s_dot)
    return f * ds.T, 0.5 * k * (s - s0) ** 2 + f0 * (s - s0), c * s_dot**2, ca.SX(0)


def _load(model, element, q, qd, t, p):
    body = element.bodies[0]
    if element.table:
        rows = np.array(element.table, float)
        grid = [rows[:, 0].tolist()]
        tc = ca.fmin(ca.fmax(t, rows[0, 0]), rows[-1, 0])
        fx, fy, tz = (ca.interpolant(f"{element.name}_{c}", "linear", grid, rows[:, i + 1].tolist())(tc)
                      for i, c in enumerate(("fx", "fy", "tz")))
    else:
        fx, fy, tz = p[0], p[1], p[2]
    force = ca.vertcat(fx, fy)
    _, th = model.body_pose(q, body)
    if element.frame == "body":
        force = rotation(th) @ force
    J = ca.jacobian(model.point(q, body, element.points[0]), q)
    Q = J.T @ force
    Q[model.rotation_index(body)] += tz
    return Q, ca.SX(0), ca.SX(0), ca.dot(Q, qd)


ELEMENT_TERMS = registry(FORCE_ELEMENTS, {"spring_damper": _spring, "rotational_spring_damper": _spring,
                                          "load": _load})


def force_terms(model: Model, forces: tuple[ForceElement, ...], q, qd, t, parameters) -> ForceTerms:
    """The :class:`ForceTerms` of `forces` at symbols q, qd (nq,), t; `parameters` (4 per
    element, :data:`N_PARAMETERS`) the elements' numbers."""
    Q, V, pd, pl = ca.SX.zeros(model.nq), ca.SX(0), ca.SX(0), ca.SX(0)
    for i, e in enumerate(forces):
        p = parameters[N_PARAMETERS * i:N_PARAMETERS * (i + 1)]
        dQ, dV, dpd, dpl = ELEMENT_TERMS[e.type](model, e, q, qd, t, p)
        Q, V, pd, pl = Q + dQ, V + dV, pd + dpd, pl + dpl
    return ForceTerms(Q, V, pd, pl)


class ForceElementTerm(Term):
    """The scene's force elements as a term of the equations: their generalised forces join Q,
    their springs' energy the potential, their dampers' power ``power_damping`` and their
    loads' power ``power_load``; their numbers are ``forces.<element>.*`` of the layout."""

    def start(self, a: Assembly) -> None:
        if a.forces:
            a.labels.append("force elements " + " ".join(f"{e.name} ({e.type})" for e in a.forces))

    def finish(self, a: Assembly) -> None:
        if not a.forces:
            return
        elements = force_terms(a.model, a.forces, a.q, a.qd, a.t, a.numbers("forces"))
        a.Q = a.Q + elements.Q
        a.potential += elements.potential
        a.power_damping += elements.power_damping
        a.power_load = elements.power_load


def element_forces_function(model: Model, forces: tuple[ForceElement, ...], parameters) -> ca.Function:
    """SX Function 'force_elements': q, qd (nq,), t [s] -> Q (nq,) [N, N m], the generalised
    force of `forces` with their numbers `parameters` (as ``Problem.force_parameters``) folded in."""
    q, qd, t = ca.SX.sym("q", model.nq), ca.SX.sym("qd", model.nq), ca.SX.sym("t")
    Q = force_terms(model, forces, q, qd, t, ca.SX(ca.DM(np.asarray(parameters, float)))).Q
    return ca.Function("force_elements", [q, qd, t], [Q], ["q", "qd", "t"], ["Q"])
