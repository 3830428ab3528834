"""The same equations in tree coordinates p (:mod:`rrr4.mechanism.tree`): the velocity
transformation q = q(p), qd = J pd gives J^T M J pdd + Phi_p^T lambda = J^T (Q - M Jdot pd),
with the rows of the loop-closing ideal joints, the drivers and the driving constraints,
Baumgarte-stabilised as in q (see :mod:`rrr4.dynamics.builder`)."""

from __future__ import annotations

import casadi as ca

from ..mechanism.tree import tree_map
from .assembly import Assembly
from .constraints import Actuation, Constraints

__all__ = ["tree_functions"]


def tree_functions(a: Assembly, act: Actuation, con: Constraints, m_diag, refs: list, ref_names: list,
                   outputs: dict) -> tuple:
    """(tree_acceleration, tree_state, tree_coordinates), or three None where no ideal joint
    forms a tree. refs, ref_names: the inputs after qd; outputs: the expressions in q, qd of
    power_damping, power_friction and of the terms' ``tree_outputs``."""
    q, qd, ideal, n = a.q, a.qd, con.ideal, act.theta.shape[0]
    tree = tree_map(a.model, a.G)
    if not tree.tree_joints:
        return None, None, None
    p, pd = tree.p, ca.SX.sym("pd", tree.p.shape[0])
    J = ca.jacobian(tree.q, p)
    jd = ca.jtimes(J @ pd, p, pd)  # dJ/dt pd

    def on_tree(e):
        return ca.substitute(e, ca.vertcat(q, qd), ca.densify(ca.vertcat(tree.q, J @ pd)))

    n_con = con.phi.shape[0]
    rows = [2 * ideal.index(j) + c for j in tree.closures for c in (0, 1)] + list(range(2 * len(ideal), n_con))
    M_t = J.T @ (m_diag * J)
    rhs = J.T @ (on_tree(a.Q) - m_diag * jd)
    lam_t = ca.SX(0, 1)
    if rows:  # loop closures, drivers and driving constraints stay constraints
        phi_p = on_tree(con.phi_q[rows, :]) @ J
        gamma_p = on_tree(con.gamma_s[rows]) - on_tree(con.phi_q[rows, :]) @ jd
        m_phi = ca.solve(M_t, phi_p.T)
        lam_t = ca.solve(phi_p @ m_phi, phi_p @ ca.solve(M_t, rhs) - gamma_p)
        rhs = rhs - phi_p.T @ lam_t
    pdd = ca.solve(M_t, rhs)
    tau_t = -lam_t[lam_t.shape[0] - n:] if act.mode == "prescribed" else act.tau
    power_t = ca.SX(0) if act.mode == "free" or n == 0 else ca.dot(tau_t, on_tree(act.theta_d))
    if con.n_drivers:
        k = 2 * len(tree.closures)
        power_t += ca.dot(-lam_t[k:k + con.n_drivers], on_tree(con.phi_q[con.driver_rows, :] @ qd))
    if a.power_load is not None:
        power_t += on_tree(a.power_load)
    coordinate = ca.substitute(tree.coordinate, tree.q_symbols, q)
    names = ["power_damping", "power_friction", *a.tree_outputs]
    return (
        ca.Function("tree_acceleration", [p, pd, *refs, a.P],
                    ca.cse([pdd, power_t, *(on_tree(outputs[k]) for k in names)]),
                    ["p", "pd", *ref_names, "parameters"], ["pdd", "power_in", *names]),
        ca.Function("tree_state", [p, pd, a.P], [tree.q, J @ pd], ["p", "pd", "parameters"], ["q", "qd"]),
        ca.Function("tree_coordinates", [q, qd, a.P], [coordinate, ca.jtimes(coordinate, q, qd)],
                    ["q", "qd", "parameters"], ["p", "pd"]))
