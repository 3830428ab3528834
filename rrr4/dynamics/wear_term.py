"""The wear term: Archard wear on B-spline profiles (:mod:`rrr4.contact.wear`) at the
clearance joints that wear.

It shapes the gap: the worn clearance in the journal's direction is c0 + w_B(psi_B) +
w_J(psi_J), so the penetration is |e| - c0 - w(psi) and the contact term's normal force acts
along its gradient (``joint.grad``, ``joint.tilt``). Its numbers: ``wear.<joint>.*`` and the
profiles' node depths ``profiles.<joint>.<surface>.*`` (:mod:`rrr4.dynamics.layout`). Its
output ``wear_rate``: the node depth rates [m/s] of every profile (Archard's law), in the
order of ``Equations.worn``, in tree coordinates too.
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca

from ..contact.wear import archard_volume_rate, node_depth_rates, profile_depth, spline_slopes, spline_weights
from .assembly import Assembly, ClearanceJoint, Term
from .layout import WEAR_PARAMETERS, worn_joints

__all__ = ["WearTerm"]


class WearTerm(Term):
    """Wear at the worn clearance joints (see the module docstring)."""

    def start(self, a: Assembly) -> None:
        self.worn = dict(worn_joints(a.model, a.effects))
        self.rates = []
        for on in sorted({w.surfaces for w in self.worn.values()}):
            a.labels.append(f"wear (Archard, {on}) at {' '.join(j for j, w in self.worn.items() if w.surfaces == on)}")

    def shape(self, a: Assembly, c: ClearanceJoint) -> None:
        if c.name not in self.worn:
            return
        kin, q, qd, r_j, r_b = c.kin, a.q, a.qd, c.r_j, c.r_b
        # the direction of e; (1, 0) for a journal within 1e-3 c of the centre, where the depth
        # does not matter and atan2's derivative would be 0/0
        near = ca.dot(kin.eccentricity, kin.eccentricity) < (1e-3 * (r_b - r_j)) ** 2
        angle = ca.atan2(ca.if_else(near, 0.0, kin.normal[1]), ca.if_else(near, 1.0, kin.normal[0]))
        depth, slope, m = ca.SX(0), ca.SX(0), self.worn[c.name].nodes
        grad = ca.SX.zeros(a.model.nq)  # d depth / dq: through each surface's angle psi_s = angle - theta_s
        for surface in self.worn[c.name].worn:
            nodes = a.numbers(f"profiles.{c.name}.{surface}")
            i_s, r_s = (c.i_b, r_b) if surface == "bearing" else (c.i_j, r_j)
            psi = angle - (0 if i_s is None else q[i_s])
            weights = spline_weights(psi, m)
            depth += profile_depth(nodes, weights)
            s = profile_depth(nodes, spline_slopes(psi, m))  # dw_s / dpsi_s [m/rad]
            slope += s
            if i_s is not None:
                grad[i_s] -= s
            c.profiles.append((weights, r_s, m))
        c.tilt = ca.if_else(near, 0.0, slope / (kin.penetration + r_b - r_j))  # d depth / d(e . t), |e| > 0
        c.grad = grad + (c.g_j - c.g_b).T @ (c.tilt * kin.tangent)
        c.kin = replace(kin, penetration=kin.penetration - depth, delta_dot=kin.delta_dot - ca.dot(c.grad, qd))

    def at_joint(self, a: Assembly, c: ClearanceJoint) -> None:
        if not c.profiles:
            return
        k_w, hardness, length = (a.number(f"wear.{c.name}.{k}") for k in WEAR_PARAMETERS)
        volume_rate = archard_volume_rate(k_w, hardness, c.fn, c.kin.v_t)
        self.rates += [node_depth_rates(volume_rate, w, length, r_s, m) for w, r_s, m in c.profiles]

    def finish(self, a: Assembly) -> None:
        if self.worn:
            a.outputs.append(("wear_rate", ca.vertcat(*self.rates)))
            a.tree_outputs.append("wear_rate")
