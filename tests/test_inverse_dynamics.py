"""Inverse dynamics of the ideal mechanism: the affine family (tau, reactions) along a motion."""

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from rrr4 import Mechanism, build
from rrr4.dynamics.inverse import actuator_motion_function, inverse_dynamics_function, joint_reactions_function
from rrr4.mechanism import kinematics as kin
from rrr4.scene import parse_scene


def _cross2(a, b):
    """z-component of planar cross products, row-wise for (k, 2) arrays."""
    a, b = np.asarray(a), np.asarray(b)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _random_motions(rng, k=6):
    for _ in range(k):
        pose = np.r_[rng.uniform(-0.04, 0.04, 2), rng.uniform(-0.2, 0.2)]
        yield pose, rng.normal(size=3) * [0.3, 0.3, 1.0], rng.normal(size=3) * [3.0, 3.0, 10.0]


def _three_chain_scene(paper_data):
    paper_data["mechanism"]["chains"] = paper_data["mechanism"]["chains"][:3]
    paper_data["joints"]["clearance"] = "all"
    paper_data["actuation"]["preload"]["weights"] = 1.0
    return parse_scene(paper_data)


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (0.0, -9.81)])
def test_family_satisfies_constrained_equations_of_motion(paper_scene, gravity):
    """M qdd + Phi_q^T lambda = Q_g + B tau with lambda = -r for every member of the family."""
    mech = Mechanism.from_scene(paper_scene)
    f = joint_reactions_function(mech, gravity)
    M, Q = mech.model.mass_matrix(), mech.model.gravity_forces(gravity)
    for pose, pd, pdd in _random_motions(np.random.default_rng(1)):
        tau_p, tau_n, r_p, r_n, _, _ = (np.array(v) for v in f(pose, pd, pdd))
        q, qd, qdd = mech.body_motion(pose, pd, pdd)
        phi_q = np.array(mech.constraints()(q, qd)[1])
        for alpha in (0.0, -3.0, 2.5):
            tau = tau_p.ravel() + alpha * tau_n.ravel()
            lam = -(r_p + alpha * r_n).T.ravel()
            B = np.array(mech.model.actuator_coordinates_function(q)[1]).T  # S^T
            residual = M @ qdd + phi_q.T @ lam - Q - B @ tau
            assert np.max(np.abs(residual)) < 1e-10 * max(1.0, np.max(np.abs(M @ qdd)))


def test_three_chain_mechanism_has_a_unique_solution(paper_data):
    """With n = 3 the family is a single point: tau_n and r_n are empty and the equations hold."""
    scene = _three_chain_scene(paper_data)
    mech = Mechanism.from_scene(scene)
    f = joint_reactions_function(mech)
    pose, pd, pdd = next(_random_motions(np.random.default_rng(2)))
    tau_p, tau_n, r_p, r_n, _, _ = (np.array(v) for v in f(pose, pd, pdd))
    assert tau_n.size == 0 and r_n.size == 0
    q, qd, qdd = mech.body_motion(pose, pd, pdd)
    phi_q = np.array(mech.constraints()(q, qd)[1])
    B = np.array(mech.model.actuator_coordinates_function(q)[1]).T
    residual = mech.model.mass_matrix() @ qdd - phi_q.T @ r_p.T.ravel() - B @ tau_p.ravel()
    assert np.max(np.abs(residual)) < 1e-10


def test_jt_tau_equals_platform_newton_euler_wrench_plus_link_inertia(paper_scene):
    """J^T tau = [m_o (a_o - g); I_o alpha_o] + sum_links J_k^T M_k (qdd_k - g_k).

    How: by virtual power, tau . theta_d = qd . (M qdd - Q_g) for every admissible motion.
    With theta_d = J pose_d and qd = J_q pose_d (J_q = dq/dpose from the closed-form IK,
    built here independently with CasADi), J^T tau = J_q^T (M qdd - Q_g). The platform rows
    of J_q are the identity, so this is the platform's own Newton-Euler wrench plus the
    inertia of the eight links mapped to the platform. It must hold for every alpha.
    """
    mech = Mechanism.from_scene(paper_scene)
    g = (0.3, -9.81)
    f = inverse_dynamics_function(mech, g)
    pose_sx = ca.SX.sym("pose", 3)
    Jq = ca.Function("Jq", [pose_sx], [ca.jacobian(kin.body_coordinates(mech.data, pose_sx, ca.DM(mech.modes)),
                                                    pose_sx)])
    M, Q = mech.model.mass_matrix(), mech.model.gravity_forces(g)
    for pose, pd, pdd in _random_motions(np.random.default_rng(3)):
        tau_p, tau_n = (np.array(v).ravel() for v in f(pose, pd, pdd)[:2])
        _, _, qdd = mech.body_motion(pose, pd, pdd)
        Jq_num = np.array(Jq(pose))
        assert np.allclose(Jq_num[-3:], np.eye(3))
        platform_wrench = Jq_num.T @ (M @ qdd - Q)
        J = mech.jacobian(pose)
        for alpha in (0.0, 4.0):
            assert np.allclose(J.T @ (tau_p + alpha * tau_n), platform_wrench, atol=1e-10, rtol=1e-9)


def test_null_space_torques_are_the_mechanism_null_space_and_minimum_norm_particular(paper_scene):
    """tau_n = Mechanism.null_space(pose) (unit, J^T tau_n = 0) and tau_p is orthogonal to it."""
    mech = Mechanism.from_scene(paper_scene)
    f = build(paper_scene).inverse_dynamics()
    for pose, pd, pdd in _random_motions(np.random.default_rng(4)):
        tau_p, tau_n = (np.array(v).ravel() for v in f(pose, pd, pdd)[:2])
        assert np.allclose(tau_n, mech.null_space(pose), atol=1e-14)
        assert abs(tau_p @ tau_n) < 1e-12 * max(1.0, np.linalg.norm(tau_p))


def test_null_space_reactions_are_axial_forces_in_the_following_links(paper_scene):
    """The preload family only adds equal axial forces at B_i and C_i along B_i -> C_i."""
    mech = Mechanism.from_scene(paper_scene)
    f = build(paper_scene).inverse_dynamics()
    for pose, pd, pdd in _random_motions(np.random.default_rng(5)):
        r_n = np.array(f(pose, pd, pdd)[3])
        q = mech.body_motion(pose)[0]
        inboard, outboard = (np.array(v) for v in mech.joint_point_function(q))
        for i in range(4):
            e = outboard[:, 8 + i] - inboard[:, 4 + i]  # C_i - B_i
            assert np.allclose(r_n[:, i], r_n[:, 4 + i], atol=1e-12)
            assert abs(_cross2(e, r_n[:, i])) < 1e-12 * np.linalg.norm(r_n[:, i])


def test_quasi_static_massless_links_match_hand_calculation(paper_scene):
    """Massless links (1e-9 of their mass): every following link is a two-force member, so
    r_B = r_C along B_i -> C_i; the axial forces s_i balance the platform's inertia
    (sum s_i e_i = m_o a_o, sum (C_i - o) x s_i e_i = I_o alpha_o) and the torque is the
    moment of r_B about A_i. Solved by hand with numpy at a pose at rest (pose_d = 0)."""
    def light(link):
        return replace(link, mass=link.mass * 1e-9, inertia=link.inertia * 1e-9)
    chains = tuple(replace(c, driving=light(c.driving), following=light(c.following))
                   for c in paper_scene.mechanism.chains)
    mech = Mechanism.from_scene(replace(paper_scene.mechanism, chains=chains))
    f = inverse_dynamics_function(mech)
    pose, pdd = np.array([0.01, -0.005, 0.05]), np.array([2.0, -1.0, 8.0])
    tau_p, tau_n, r_p, r_n = (np.array(v) for v in f(pose, np.zeros(3), pdd))
    q = mech.body_motion(pose)[0]
    inb, outb = (np.array(v) for v in mech.joint_point_function(q))
    A, B, C = outb[:, 0:4], outb[:, 4:8], outb[:, 8:12]
    E = (C - B) / np.linalg.norm(C - B, axis=0)
    W = np.vstack([E, _cross2((C - pose[:2, None]).T, E.T)])
    p = mech.data.platform
    wrench = np.r_[p.mass * pdd[:2], p.inertia * pdd[2]]
    for alpha in (0.0, 3.0):
        tau = tau_p.ravel() + alpha * tau_n.ravel()
        r = r_p + alpha * r_n
        s = np.einsum("ki,ki->i", E, r[:, 4:])  # axial force at C_i
        assert np.allclose(r[:, :4], r[:, 4:], atol=1e-6)                       # r_B = r_C
        assert np.allclose(_cross2(E.T, r[:, 4:].T), 0.0, atol=1e-6)           # along the link
        assert np.allclose(W @ s, wrench, atol=1e-6)                            # platform Newton-Euler
        assert np.allclose(tau, _cross2((B - A).T, r[:, :4].T), atol=1e-6)     # moment about A_i


def test_ideal_forward_dynamics_driven_by_the_family_reproduces_the_motion(paper_data):
    """Closing the loop with the equation builder: an all-ideal scene driven by
    tau = tau_p + alpha tau_n (no tracking error, so PD adds nothing) accelerates exactly as
    the path prescribes, and its ideal passive reactions equal r_p + alpha r_n."""
    paper_data["joints"]["clearance"] = "none"
    paper_data["effects"]["gravity"] = [0.0, -9.81]
    scene = parse_scene(paper_data)
    acc = build(scene).equations().acceleration
    mech = Mechanism.from_scene(scene)
    f = joint_reactions_function(mech, scene.effects.gravity)
    for pose, pd, pdd in _random_motions(np.random.default_rng(6), k=3):
        tau_p, tau_n, r_p, r_n, _, _ = (np.array(v) for v in f(pose, pd, pdd))
        q, qd, qdd = mech.body_motion(pose, pd, pdd)
        alpha = 2.0
        out = acc(q=q, qd=qd, effort=tau_p.ravel() + alpha * tau_n.ravel(), theta_ref=q[2:24:6],
                  theta_d_ref=qd[2:24:6], theta_dd_ref=qdd[2:24:6])
        assert np.allclose(np.array(out["qdd"]).ravel(), qdd, atol=1e-9)
        assert np.allclose(np.array(out["reaction"]), (r_p + alpha * r_n)[:, 4:], atol=1e-9)


def test_actuator_motion_matches_the_ik_and_jacobian(paper_scene):
    """driving_direction = [cos, sin](ik(pose)) and theta_d = J(pose) pose_d on random motions."""
    mech = Mechanism.from_scene(paper_scene)
    f = actuator_motion_function(mech)
    for pose, pd, _ in _random_motions(np.random.default_rng(8)):
        u, theta_d = (np.array(v) for v in f(pose, pd, np.zeros((2, 4))))
        theta = mech.ik(pose)
        np.testing.assert_allclose(u, np.vstack([np.cos(theta), np.sin(theta)]), atol=1e-13)
        np.testing.assert_allclose(theta_d.ravel(), mech.jacobian(pose) @ pd, rtol=1e-12, atol=1e-12)
