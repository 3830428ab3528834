"""The contact term: one journal-bearing contact per clearance joint, with its friction.

Per clearance joint the scene's normal law F_n(delta, delta_dot, delta_dot0) (Flores &
Ambrosio 2004) and, unless the friction law is 'none', the friction force f_t(v_t, F_n),
acting on the journal and the bearing body (:func:`rrr4.contact.contact_generalized_forces`).
At a worn joint (a shaping term has left the quadrature of its arc, ``joint.arc``) the
contact is conformal instead: the elastic foundation of :mod:`rrr4.contact.conformal`, each
point's pressure, damping and friction with its own overlap and slip, the stiffness matched
to the scene's law (:func:`rrr4.contact.conformal.foundation_modulus`); the joint's
normal_force output is the resultant's component along the line of centres, its
friction_force the points' sum. Its numbers: the joint's ``joints.<joint>.*`` and
``contact.*`` (:mod:`rrr4.dynamics.layout`). Potential: the elastic energy
K delta^(n+1)/(n+1) (the layer's integral at a worn joint); power_damping:
(F_n - K delta^n) delta_dot (none for the purely elastic 'hertz'); power_friction:
-f_t v_t (dissipated); all summed over the points at a worn joint. The common outputs
contact_force, normal_force, friction_force, penetration, delta_dot, eccentricity, and the
discrete ``contact_update`` (see :mod:`rrr4.dynamics.builder`).
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from ..contact import clearance_kinematics, contact_generalized_forces, elastic_force, friction_force, normal_force
from ..contact.conformal import ARC_NUMBERS, FRICTION_NUMBERS, arc_energy, arc_function, arc_points, foundation_modulus
from ..contact.normal import hysteresis_factor, power
from ..errors import SceneError
from .assembly import Assembly, ClearanceJoint, Term
from .layout import EFFECT_PARAMETERS, JOINT_PARAMETERS, worn_joints

__all__ = ["ContactTerm", "clearance_joint", "contact_update", "CONTACT_OUTPUTS"]

# the common outputs of ``acceleration`` that the contact term fills ((2, nc) or (nc,))
CONTACT_OUTPUTS = ("contact_force", "normal_force", "friction_force", "penetration", "delta_dot", "eccentricity")


def clearance_joint(a: Assembly, index: int, name: str) -> ClearanceJoint:
    """The geometry and kinematics of clearance joint `name` (the `index`-th) at the symbols of `a`."""
    model, q, qd = a.model, a.q, a.qd
    spec = model.graph.joint(name)
    pts = model.joint_points(q, spec, a.G)
    p_j, p_b = pts[spec.journal], pts[1 - spec.journal]
    g_j, g_b = ca.jacobian(p_j, q), ca.jacobian(p_b, q)
    i_b, i_j = model.rotation_index(spec.bearing_body), model.rotation_index(spec.journal_body)
    K, r_j, r_b = (a.number(f"joints.{name}.{k}") for k in JOINT_PARAMETERS)
    e_dot = (g_j - g_b) @ qd
    w_b, w_j = 0 if i_b is None else qd[i_b], 0 if i_j is None else qd[i_j]
    kin = clearance_kinematics(p_j - p_b, e_dot, w_b, w_j, r_j, r_b)
    return ClearanceJoint(index, name, spec, g_j, g_b, i_b, i_j, r_j, r_b, K, e_dot, w_b, w_j, kin)


class ContactTerm(Term):
    """Contact and friction at every clearance joint (see the module docstring)."""

    def start(self, a: Assembly) -> None:
        self.law, self.friction = a.effects.contact, a.effects.friction
        if not a.model.clearance_joints:
            return
        numbers = dict(zip(EFFECT_PARAMETERS, ca.vertsplit(a.numbers("contact")), strict=True))
        self.restitution, self.damping = numbers["restitution"], numbers["damping"]
        self.friction = replace(self.friction, coefficient=numbers["friction_coefficient"],
                                static_coefficient=numbers["static_coefficient"], v0=numbers["v0"],
                                v1=numbers["v1"], stribeck_velocity=numbers["stribeck_velocity"])
        if self.law.law == "kelvin-voigt" and worn_joints(a.model, a.effects):
            raise SceneError("effects.contact.law: 'kelvin-voigt' is not allowed with effects.wear (the conformal "
                             "contact over the worn arc damps by hysteresis: hertz, hunt-crossley, "
                             "lankarani-nikravesh, flores or gonthier)")
        a.labels.append(f"contact ({self.law.law}) at {' '.join(a.model.clearance_joints)}")
        if self.friction.law != "none":
            a.labels.append(f"friction ({self.friction.law})")

    def at_joint(self, a: Assembly, c: ClearanceJoint) -> None:
        ce, fe, kin, K = self.law, self.friction, c.kin, c.stiffness
        dd0_eff = ca.if_else(a.inc[c.index] > 0.5, a.dd0[c.index], ca.fmax(kin.delta_dot, a.v_min))
        if c.arc is not None:
            self._conformal(a, c, dd0_eff)
            return
        c.fn = normal_force(ce.law, kin.penetration, kin.delta_dot, dd0_eff, K, ce.exponent, self.restitution,
                            self.damping, a.v_min)
        f_el = elastic_force(kin.penetration, K, ce.exponent)
        c.ft = friction_force(fe, kin.v_t, c.fn) if fe.law != "none" else ca.SX(0)
        Qc, c.f = contact_generalized_forces(kin, c.fn, c.ft, c.g_b, c.g_j, c.i_b, c.i_j, c.r_j, c.r_b, a.model.nq)
        a.Q = a.Q + Qc
        a.potential += K * power(ca.fmax(kin.penetration, 0.0), ce.exponent + 1) / (ce.exponent + 1)
        if ce.law != "hertz":
            a.power_damping += (c.fn - f_el) * kin.delta_dot
        if fe.law != "none":
            a.power_friction += -c.ft * kin.v_t

    def _conformal(self, a: Assembly, c: ClearanceJoint, dd0_eff) -> None:
        """The distributed contact over the arc of a worn joint (see the module docstring)."""
        ce, fe, arc = self.law, self.friction, c.arc
        length = a.number(f"wear.{c.name}.length")
        modulus = foundation_modulus(c.stiffness, ce.exponent, length, c.r_b, c.r_b - c.r_j)
        numbers = {"clearance": c.r_b - c.r_j, "modulus": modulus,
                   "area": length * c.r_b * 2.0 * np.pi / len(arc_points(arc.nodes)),
                   "damping_rate": hysteresis_factor(ce.law, self.restitution) / ca.fmax(dd0_eff, a.v_min),
                   "slip_offset": c.r_j * c.w_j - c.r_b * c.w_b}
        friction = [getattr(fe, k) for k in FRICTION_NUMBERS]
        f = arc_function(arc.nodes, arc.turn_gradient is not None,
                         float(ce.exponent), fe.law)
        arc.out = f.call({**arc.inputs, "numbers": ca.vertcat(*[numbers[k] for k in ARC_NUMBERS], *friction)})
        a.Q = a.Q + arc.generalized(arc.out["normal"], arc.out["turn_load"])
        c.f = arc.turn @ arc.out["normal"]
        c.fn = -ca.dot(c.f, c.kin.normal)
        c.kin = replace(c.kin, penetration=arc.out["deepest"])
        energy = arc_energy(arc.nodes, arc.turn_gradient is not None, float(ce.exponent))
        a.potential += energy(arc.inputs["e"], arc.inputs["turn"], arc.inputs["first"], arc.inputs["other"],
                              ca.vertcat(*[numbers[k] for k in ("clearance", "modulus", "area")]))
        if ce.law != "hertz":
            a.power_damping += arc.out["power_damping"]
        if fe.law == "none":
            c.ft = ca.SX(0)
            return
        f_t = arc.turn @ arc.out["friction"]
        c.ft = arc.out["friction_sum"]
        arm = ca.SX.zeros(a.model.nq)
        if c.i_j is not None:
            arm[c.i_j] += c.r_j
        if c.i_b is not None:
            arm[c.i_b] -= c.r_b
        a.Q = a.Q + (c.g_j - c.g_b).T @ f_t + arm * c.ft
        c.f = c.f + f_t
        a.power_friction += arc.out["power_friction"]

    def finish(self, a: Assembly) -> None:
        js = a.joints
        if js:
            a.columns = dict(zip(CONTACT_OUTPUTS, (
                ca.horzcat(*[c.f for c in js]), ca.vertcat(*[c.fn for c in js]), ca.vertcat(*[c.ft for c in js]),
                ca.vertcat(*[c.kin.penetration for c in js]), ca.vertcat(*[c.kin.delta_dot for c in js]),
                ca.horzcat(*[c.kin.eccentricity for c in js])), strict=True))
        else:
            a.columns = {k: ca.SX(2, 0) if k in ("contact_force", "eccentricity") else ca.SX(0, 1)
                         for k in CONTACT_OUTPUTS}


def contact_update(a: Assembly) -> ca.Function:
    """'contact_update': q, qd, delta_dot0, in_contact, parameters -> delta_dot0_next,
    in_contact_next, loss (the rule in :mod:`rrr4.dynamics.builder`)."""
    nc, dd0, inc, v_min = len(a.joints), a.dd0, a.inc, a.v_min
    now = ca.vertcat(*[c.kin.penetration > 0 for c in a.joints]) if nc else ca.SX(0, 1)
    prev = inc > 0.5
    onset = ca.logic_and(now, ca.logic_not(prev))
    dd0_next = ca.if_else(onset, ca.fmax(a.columns["delta_dot"], v_min), ca.if_else(now, dd0, v_min)) \
        if nc else ca.SX(0, 1)
    loss = ca.logic_and(prev, ca.logic_not(now)) if nc else ca.SX(0, 1)
    return ca.Function("contact_update", [a.q, a.qd, dd0, inc, a.P], [dd0_next, now, loss],
                       ["q", "qd", "delta_dot0", "in_contact", "parameters"],
                       ["delta_dot0_next", "in_contact_next", "loss"])
