"""The oil-film term (:mod:`rrr4.contact.lubrication`) at the clearance joints whose
lubrication law is not 'none'.

The film's force w(eps) F(min(eps, threshold), eps_dot, whirl) acts at the joint centres
(its pressure passes through them), handed over to the dry laws between the threshold and
eps = 1. Its numbers: ``lubrication.<joint>.*`` (:mod:`rrr4.dynamics.layout`). It joins the
journal's ``contact_force``; its power -F_film . e_dot joins ``power_damping``. The film's
shear torque (Petroff / Ocvirk, :func:`rrr4.contact.lubrication.film_torque`) turns the
journal against its rotation relative to the bearing, and the bearing the other way; its
dissipation -T w joins ``power_friction``. Outputs ``film_force`` (2, nc) [N] (0 at dry
joints), ``power_film`` [W] and ``film_torque`` (1, nc) [N m] on the journal.
"""

from __future__ import annotations

import casadi as ca

from ..contact.lubrication import film_force, film_rates, film_torque, film_weight
from .assembly import Assembly, ClearanceJoint, Term
from .layout import LUBRICATION_PARAMETERS, lubricated_joints

__all__ = ["FilmTerm"]


class FilmTerm(Term):
    """The oil film at the lubricated clearance joints (see the module docstring)."""

    def start(self, a: Assembly) -> None:
        self.films = dict(lubricated_joints(a.model, a.effects))
        self.power = ca.SX(0)
        self.torques = {}
        for law in sorted({f.law for f in self.films.values()}):
            a.labels.append(f"lubrication ({law}) at {' '.join(j for j, f in self.films.items() if f.law == law)}")

    def at_joint(self, a: Assembly, c: ClearanceJoint) -> None:
        c.film = ca.SX.zeros(2)
        if c.name not in self.films:
            return
        kin = c.kin
        mu_oil, length, eps_t = (a.number(f"lubrication.{c.name}.{k}") for k in LUBRICATION_PARAMETERS)
        gap = c.r_b - c.r_j
        eps = (kin.penetration + gap) / gap
        A, B = film_rates(eps, kin.delta_dot, ca.dot(c.e_dot, kin.tangent), c.w_j, c.w_b, gap)
        f_r, f_s = film_force(self.films[c.name].law, ca.fmin(eps, eps_t), A, B, c.r_j, length, mu_oil, gap)
        weight = film_weight(eps, eps_t)
        c.film = weight * (f_r * kin.normal + f_s * kin.tangent)
        a.Q = a.Q + (c.g_j - c.g_b).T @ c.film
        c.f = c.f + c.film
        self.power += -ca.dot(c.film, c.e_dot)
        # the shear torque on the journal, the opposite on the bearing; it dissipates -T w
        spin = c.w_j - c.w_b
        torque = weight * film_torque(ca.fmin(eps, eps_t), spin, c.r_j, length, mu_oil, gap)
        for i, sign in ((c.i_j, 1.0), (c.i_b, -1.0)):
            if i is not None:
                a.Q[i] += sign * torque
        a.power_friction += -torque * spin
        self.torques[c.name] = torque

    def finish(self, a: Assembly) -> None:
        a.power_damping += self.power
        if self.films:
            a.outputs += [("film_force", ca.horzcat(*[c.film for c in a.joints])), ("power_film", self.power),
                          ("film_torque", ca.horzcat(*[self.torques.get(c.name, ca.SX(0)) for c in a.joints]))]
