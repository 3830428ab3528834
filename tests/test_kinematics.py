"""Kinematics against the closed form, written here independently of rrr4."""

import dataclasses

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rrr4 import KinematicsError, Mechanism

poses = st.tuples(st.floats(-0.08, 0.08), st.floats(-0.08, 0.08), st.floats(-0.4, 0.4)).map(np.array)
modes = st.lists(st.sampled_from([-1, 1]), min_size=4, max_size=4).map(np.array)


def circle_intersection_angles(scene, pose, modes):
    """B_i = circle(A_i, l1) & circle(C_i, l2); mode +1 is the intersection to the left of A->C."""
    out = []
    x, y, th = pose
    for c, s in zip(scene.mechanism.chains, modes, strict=True):
        A = np.array(c.base)
        C = np.array([x, y]) + c.attachment_radius * np.array([np.cos(th + c.attachment_angle),
                                                                np.sin(th + c.attachment_angle)])
        l1, l2 = c.driving.length, c.following.length
        d = np.linalg.norm(C - A)
        a = (l1**2 - l2**2 + d**2) / (2 * d)
        h2 = l1**2 - a**2
        if h2 <= 0:
            return None
        u = (C - A) / d
        B = A + a * u + s * np.sqrt(h2) * np.array([-u[1], u[0]])
        out.append(np.arctan2(B[1] - A[1], B[0] - A[0]))
    return np.array(out)


def angle_diff(a, b):
    return np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))


def mechanism_with_modes(scene, m):
    chains = tuple(dataclasses.replace(c, working_mode=int(s)) for c, s in zip(scene.mechanism.chains, m, strict=True))
    return Mechanism.from_scene(dataclasses.replace(scene.mechanism, chains=chains))


@settings(max_examples=200, deadline=None)
@given(pose=poses, m=modes)
def test_ik_matches_closed_form_on_random_poses(paper_scene, pose, m):
    ref = circle_intersection_angles(paper_scene, pose, m)
    assume(ref is not None)
    mech = Mechanism.from_scene(paper_scene)
    theta = mech.ik(pose, modes=m)
    assert np.max(np.abs(angle_diff(theta, ref))) < 1e-12


@settings(max_examples=100, deadline=None)
@given(pose=poses, m=modes)
def test_constraints_vanish_at_ik_configuration_on_both_branches(paper_scene, pose, m):
    assume(circle_intersection_angles(paper_scene, pose, m) is not None)
    mech = mechanism_with_modes(paper_scene, m)
    q, qd, _ = mech.body_motion(pose, [0.1, -0.2, 0.3])
    phi, phi_q, _ = mech.constraints()(q, qd)
    assert np.max(np.abs(np.array(phi))) < 1e-12
    # velocities from the same model satisfy Phi_q qd = 0
    assert np.max(np.abs(np.array(phi_q) @ qd)) < 1e-12


def test_acceleration_rhs_matches_body_accelerations(paper_scene):
    """Phi_q qdd = gamma along a platform motion (gamma from the symbolic derivative)."""
    mech = Mechanism.from_scene(paper_scene)
    rng = np.random.default_rng(1)
    for _ in range(20):
        pose = rng.uniform([-0.05, -0.05, -0.2], [0.05, 0.05, 0.2])
        q, qd, qdd = mech.body_motion(pose, rng.normal(size=3), rng.normal(size=3))
        _, phi_q, gamma = mech.constraints()(q, qd)
        assert np.allclose(np.array(phi_q) @ qdd, np.array(gamma).ravel(), atol=1e-11)


@settings(max_examples=100, deadline=None)
@given(pose=poses)
def test_fk_inverts_ik(paper_scene, pose):
    mech = Mechanism.from_scene(paper_scene)
    try:
        theta = mech.ik(pose)
    except KinematicsError:
        assume(False)
    back = mech.fk(theta, guess=pose + np.array([0.01, -0.01, 0.05]))
    assert np.linalg.norm(back[:2] - pose[:2]) < 1e-10
    assert abs(angle_diff(back[2], pose[2])) < 1e-10


def test_assembly_modes_contain_the_pose(paper_scene):
    mech = Mechanism.from_scene(paper_scene)
    pose = np.array([0.01, -0.02, 0.1])
    found = mech.assembly_modes(mech.ik(pose))
    assert len(found) >= 1
    assert min(np.linalg.norm(f - pose) for f in found) < 1e-9
    for f in found:  # every listed mode closes all four chains
        assert np.max(np.abs(np.array(mech.loop_residual_function(f, mech.ik(pose))))) < 1e-9


@settings(max_examples=100, deadline=None)
@given(pose=poses)
def test_jacobian_matches_central_differences_of_ik(paper_scene, pose):
    mech = Mechanism.from_scene(paper_scene)
    try:
        mech.ik(pose)
        J = mech.jacobian(pose)
        h = 1e-6
        fd = np.column_stack([(mech.ik(pose + h * e) - mech.ik(pose - h * e)) / (2 * h) for e in np.eye(3)])
    except KinematicsError:
        assume(False)
    assert np.max(np.abs(J - fd)) <= 1e-7 * np.max(np.abs(J))


@settings(max_examples=100, deadline=None)
@given(pose=poses)
def test_null_space_is_unit_and_annihilated_by_jacobian_transpose(paper_scene, pose):
    mech = Mechanism.from_scene(paper_scene)
    try:
        mech.ik(pose)
    except KinematicsError:
        assume(False)
    n = mech.null_space(pose)
    J = mech.jacobian(pose)
    assert abs(np.linalg.norm(n) - 1) < 1e-12
    assert np.max(np.abs(J.T @ n)) < 1e-12 * max(1.0, np.abs(J).max())


def test_home_pose_is_symmetric_under_quarter_turn(paper_scene):
    """Rotating the mechanism by 90 deg maps chain i onto chain i+1."""
    mech = Mechanism.from_scene(paper_scene)
    theta = mech.ik(np.zeros(3))
    assert np.max(np.abs(angle_diff(np.roll(theta, -1), theta + np.pi / 2))) < 1e-12
    J = mech.jacobian(np.zeros(3))
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    # theta_{i+1}(R pose) = theta_i(pose) + pi/2  =>  J_{i+1} R = J_i
    assert np.allclose(np.roll(J, -1, axis=0) @ R, J, atol=1e-12)
    n = mech.null_space(np.zeros(3))
    assert np.allclose(np.abs(n), 0.5, atol=1e-12)  # alternating preload +-(1, -1, 1, -1)/2
    assert np.allclose(np.roll(n, 1), -n, atol=1e-12)


def test_ik_reports_unreachable_pose(paper_scene):
    mech = Mechanism.from_scene(paper_scene)
    with pytest.raises(KinematicsError, match="chain"):
        mech.ik([0.5, 0.5, 0.0])
