"""The wear term: Archard wear on B-spline profiles (:mod:`rrr4.contact.wear`) at the
clearance joints that wear, with the conformal contact over the worn arc
(:mod:`rrr4.contact.conformal`).

It shapes the gap: at each quadrature point psi_k of the arc (following the line of centres,
in the first wearing surface's frame) the overlap d_k = e . u_k - c0 - w_B(psi_k - theta_B) - w_J(psi_k - theta_J), its
rate and what turns point loads into generalised forces (``joint.arc``, :class:`Arc`); the
contact term turns them into the distributed normal force, damping and friction and leaves
each point's load dF_k [N] and slip v_k [m/s]. The joint's penetration output is the deepest
overlap max_k d_k (its delta_dot stays e_dot . n, the approach speed that the hysteresis
laws capture at onset). Archard at each point: the depth rate
k p_k |v_k| / H, projected on each profile's coefficients with its basis at the point
(:func:`rrr4.contact.wear.point_depth_rates`), so the worn volume grows at
k sum_k dF_k |v_k| / H (k F |v| / H for a uniform slip). Its numbers: ``wear.<joint>.*``
and the profiles' node depths ``profiles.<joint>.<surface>.*`` (:mod:`rrr4.dynamics.layout`).
Its output ``wear_rate``: the node depth rates [m/s] of every profile, in the order of
``Equations.worn``, in tree coordinates too.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ..contact.wear import point_depth_rates
from .assembly import Assembly, ClearanceJoint, Term
from .layout import WEAR_PARAMETERS, worn_joints

__all__ = ["WearTerm", "Arc"]


@dataclass
class Arc:
    """One worn joint's contact arc as :func:`rrr4.contact.conformal.arc_function` takes it:
    its inputs (``inputs``: e, e_rate, e_dot in the frame of the first wearing surface, where
    the points are placed, the other surface's angle under them and its rate, the profiles' coefficients), the
    frame's rotation to the world (2, 2), the Jacobian of e in the frame (2, nq), the gradient
    of the other surface's angle (nq,) (None unless both wear), the profiles (surface, radius
    [m], turned) and, after the contact term, the Function's outputs by name."""
    inputs: dict
    turn: ca.SX
    e_jacobian: ca.SX
    turn_gradient: ca.SX | None
    nodes: int
    profiles: list
    out: dict | None = None

    def generalized(self, normal, turn_load):
        """The generalised force (nq,) -sum_k dF_k d d_k / dq of the normal force on the journal
        (2,) in the frame and of sum_k dF_k d w_other / d angle [N m] (d_k falls by the other
        surface's depth, read at the points' angle in its frame)."""
        out = self.e_jacobian.T @ normal
        return out if self.turn_gradient is None else out + turn_load * self.turn_gradient


def _rotation(angle):
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))


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
        m, surfaces = self.worn[c.name].nodes, self.worn[c.name].worn
        index = {"bearing": c.i_b, "journal": c.i_j}
        angle = {s: 0 if index[s] is None else a.q[index[s]] for s in surfaces}
        rate = {s: 0 if index[s] is None else a.qd[index[s]] for s in surfaces}
        first = surfaces[0]  # the points are placed in its frame
        turn = _rotation(angle[first])
        e = c.kin.eccentricity
        e_local = turn.T @ e
        turned = len(surfaces) > 1
        other = surfaces[-1]
        turn_by = angle[first] - angle[other]
        c.arc = Arc(
            {"e": e_local,
             "e_rate": turn.T @ (c.e_dot - rate[first] * ca.vertcat(-e[1], e[0])),  # R^T (e_dot - theta_dot E e)
             "e_dot": turn.T @ c.e_dot,
             "turn": ca.vertcat(turn_by, rate[first] - rate[other]) if turned else ca.SX.zeros(2),
             "first": a.numbers(f"profiles.{c.name}.{first}"),
             "other": a.numbers(f"profiles.{c.name}.{other}") if turned else ca.SX.zeros(m)},
            turn, ca.jacobian(e_local, a.q), ca.jacobian(turn_by, a.q).T if turned else None, m,
            [(s, c.r_b if s == "bearing" else c.r_j, s != first) for s in surfaces])

    def at_joint(self, a: Assembly, c: ClearanceJoint) -> None:
        if c.arc is None:
            return
        k_w, hardness, length = (a.number(f"wear.{c.name}.{k}") for k in WEAR_PARAMETERS)
        for _, r_s, turned in c.arc.profiles:
            worn = c.arc.out["wear_other" if turned else "wear_first"]
            self.rates.append(point_depth_rates(k_w, hardness, worn, length, r_s, c.arc.nodes))

    def finish(self, a: Assembly) -> None:
        if self.worn:
            a.outputs.append(("wear_rate", ca.vertcat(*self.rates)))
            a.tree_outputs.append("wear_rate")
