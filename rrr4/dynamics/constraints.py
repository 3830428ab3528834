"""The constraints term: ideal joints, drivers and driving constraints, Baumgarte-stabilised,
and the index-1 solve for the accelerations and multipliers (see :mod:`rrr4.dynamics.builder`).

Phi holds every joint without clearance (2 rows each, ``Model.constrained_joints`` order),
one row per driver s_d(q) - (initial + speed t) = 0, and in the prescribed mode the driving
constraints s(q) - theta_ref(t) = 0; gamma_s = gamma - 2 omega_b Phi_dot - omega_b^2 Phi
(Baumgarte 1972). The outputs lambda, tau (-lambda of the driving constraints when
prescribed), reaction of the ideal passive revolute joints, power_in (actuators, drivers and
the force elements' loads) and driver_effort.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from .assembly import Assembly

__all__ = ["Actuation", "Constraints", "constraints", "solved"]


@dataclass(frozen=True)
class Actuation:
    """The actuator coordinates s(q) (n,), S = ds/dq, s_dot = S qd, the mode, the efforts tau
    (None until solved when prescribed) and the reference symbols theta_ref, theta_d_ref,
    theta_dd_ref (n,)."""
    mode: str
    theta: ca.SX
    S: ca.SX
    theta_d: ca.SX
    tau: ca.SX | None
    refs: tuple


@dataclass(frozen=True)
class Constraints:
    """Phi (m,), Phi_q (m, nq), gamma_s (m,) [stabilised]; the rows: 2 per ideal joint, then
    the drivers', then the driving constraints."""
    phi: ca.SX
    phi_q: ca.SX
    gamma_s: ca.SX
    ideal: tuple
    n_drivers: int

    @property
    def driver_rows(self) -> slice:
        return slice(2 * len(self.ideal), 2 * len(self.ideal) + self.n_drivers)


def constraints(a: Assembly, act: Actuation, omega: float) -> Constraints:
    """The constraint rows of the scene at the symbols of `a` (labels of drivers and driving
    constraints added to ``a.labels``)."""
    model, q, qd, graph = a.model, a.q, a.qd, a.model.graph
    ideal, nd = model.constrained_joints, len(graph.drivers)
    phi, phi_q, gamma = model.constraint_terms(q, qd, ideal, bool(nd), a.G)
    phi_dot = phi_q @ qd
    if nd:
        value, rate, acc_d = model.driver_values(a.t)
        off = ca.vertcat(ca.SX.zeros(2 * len(ideal)), value)
        phi, phi_dot = phi - off, phi_dot - ca.vertcat(ca.SX.zeros(2 * len(ideal)), rate)
        gamma = gamma + ca.vertcat(ca.SX.zeros(2 * len(ideal)), acc_d)
        a.labels.append("drivers " + " ".join(f"{d.name} ({d.joint})" for d in graph.drivers))
    if act.mode == "prescribed":
        th_ref, thd_ref, thdd_ref = act.refs
        phi = ca.vertcat(phi, act.theta - th_ref)
        phi_q = ca.vertcat(phi_q, act.S)
        gamma = ca.vertcat(gamma, thdd_ref - ca.jtimes(act.theta_d, q, qd))
        phi_dot = ca.vertcat(phi_dot, act.theta_d - thd_ref)
        a.labels.append("prescribed actuator coordinates (driving constraints)")
    return Constraints(phi, phi_q, gamma - 2 * omega * phi_dot - omega**2 * phi, ideal, nd)


def solved(a: Assembly, act: Actuation, con: Constraints, m_diag) -> dict:
    """The index-1 solve: qdd, lambda, tau, reaction (2, k), power_in, driver_effort, and the
    reacting joints (the ideal passive revolute joints)."""
    model, n, ideal = a.model, act.theta.shape[0], con.ideal
    m_inv = 1.0 / m_diag
    phi_q = con.phi_q
    lam = ca.solve(phi_q @ ca.diag(m_inv) @ phi_q.T, phi_q @ (m_inv * a.Q) - con.gamma_s)
    qdd = m_inv * (a.Q - phi_q.T @ lam)
    tau = -lam[con.phi.shape[0] - n:] if act.mode == "prescribed" else act.tau
    reacting = tuple(j for j in model.ideal_passive_joints if model.graph.joint(j).type == "revolute")
    rows = [2 * ideal.index(j) + c for j in reacting for c in (0, 1)]
    reaction = ca.reshape(-lam[rows], 2, len(reacting)) if reacting else ca.SX(2, 0)
    power_in = ca.SX(0) if act.mode == "free" else ca.dot(tau, act.theta_d)
    # drivers: effort -lambda_d on their coordinate [N m or N]; power -lambda_d . (S_d qd)
    driver_effort = -(lam[con.driver_rows] if con.n_drivers else ca.SX(0, 1))
    if con.n_drivers:
        power_in = power_in + ca.dot(driver_effort, phi_q[con.driver_rows, :] @ a.qd)
    if a.power_load is not None:
        power_in = power_in + a.power_load
    return dict(qdd=qdd, lam=lam, tau=tau, reaction=reaction, power_in=power_in, driver_effort=driver_effort,
                reacting=reacting)
