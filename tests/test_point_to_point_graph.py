"""Point-to-point motions on any graph with a task (rrr4.optimal.optimal_motion): the contact
condition on point-task mechanisms (the five-bar with a third chain, the vertical 3-RRR point
mechanism with a gripper load), checked between the collocation nodes with the mechanism's own
kinematics and a power balance, and time+effort against its closed form."""

from pathlib import Path

import numpy as np
import pytest

import rrr4
from rrr4 import load_scene
from rrr4.errors import SceneError
from rrr4.optimal import optimal_motion

ROOT = Path(__file__).resolve().parents[1]
FIVE_BAR = ROOT / "problems" / "redundant_five_bar.yaml"
VERTICAL = ROOT / "problems" / "rrr3_point_vertical.yaml"
XYT = ROOT / "problems" / "xyt_table.yaml"
MASS_X, FX = 2.0 + 1.0 + 0.5, 50.0   # problems/xyt_table.yaml: the moving mass on x, its limit


@pytest.fixture(scope="module")
def five_bar():
    scene = load_scene(FIVE_BAR)
    return scene, optimal_motion(scene, [0.03, 0.02], nodes=10, sign=-1)


@pytest.fixture(scope="module")
def vertical():
    scene = load_scene(VERTICAL)
    return scene, optimal_motion(scene, [0.04, -0.03], nodes=10, sign=-1)


def _between(motion, per=16):
    """t, pose, pose_d, pose_dd (K, 3) on `per` instants per interval (constant acceleration) and
    the end node, the interval and the fraction of it: written here, not taken from the package."""
    N = len(motion.t) - 1
    h = motion.duration / N
    out = []
    for k in range(N):
        for u in (np.arange(per) / per if k < N - 1 else np.arange(per + 1) / per):
            a = motion.pose_dd[k]
            out.append((motion.t[k] + u * h, motion.pose[k] + u * h * motion.pose_d[k] + 0.5 * (u * h)**2 * a,
                        motion.pose_d[k] + u * h * a, a, k, u))
    t, p, pd, pdd, k, u = (np.array(v) for v in zip(*out, strict=True))
    return t, p, pd, pdd, k, u


def _alpha(tau_n, tau_p, tau):
    return np.array([np.linalg.lstsq(tau_n[i], tau[i] - tau_p[i], rcond=None)[0] for i in range(len(tau))])


@pytest.mark.parametrize("case", ["five_bar", "vertical"])
def test_margins_limits_and_contact_hold_between_the_nodes(case, request):
    # the solution's motion between its collocation nodes (constant task acceleration, the
    # null-space effort linear in time between the nodes' values) evaluated on a fine grid with
    # the mechanism's own kinematics (Newton assembly, its Jacobian) and the effort family's SVD
    scene, r = request.getfixturevalue(case)
    problem = rrr4.build(scene)
    mech = rrr4.Mechanism.from_scene(scene)
    assert r.statistics["success"] and r.contact and r.statistics["formulation"] == "graph"
    np.testing.assert_allclose(r.pose[-1, :2], r.target[:2], atol=1e-9)
    t, pose, pose_d, pose_dd, k, u = _between(r)
    cond = np.array([np.linalg.cond(mech.jacobian(p)) for p in pose])
    assert cond.max() <= scene.path.max_condition_number
    q = np.array([mech.assemble(p[:2]) for p in pose])
    fam = problem.effort_family(pose, pose_d, pose_dd, q=q)
    nodes = np.r_[np.flatnonzero(u == 0.0), len(u) - 1]   # node k at these samples
    acc_before = np.r_[r.pose_dd[:1], r.pose_dd[:-1]]      # the interval before each node's
    before = problem.effort_family(r.pose, r.pose_d, acc_before, q=q[nodes])
    after = _alpha(fam.tau_n[nodes], problem.effort_family(r.pose, r.pose_d, r.pose_dd, q=q[nodes]).tau_p, r.efforts)
    left = _alpha(fam.tau_n[nodes], before.tau_p, r.efforts_before)
    # the node efforts are in the family (the program's equations are the family's)
    np.testing.assert_allclose(before.tau_p + np.einsum("knm,km->kn", fam.tau_n[nodes], left), r.efforts_before,
                               atol=1e-7)
    alpha = after[k] + u[:, None] * (left[k + 1] - after[k])
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, alpha)
    L = np.asarray(problem.torque_limit)
    assert np.max(np.abs(tau) / L) <= 1 + 1e-6
    d = fam.r_n[..., 0] / np.linalg.norm(fam.r_n[..., 0], axis=-1, keepdims=True)
    axial = r.sign * np.einsum("kjc,kjc->kj", d, fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha))
    assert axial.min() >= r.f_min * (1 - 1e-6)
    # and the constraints bind: the motion is the fastest, not a slow one
    assert np.max(np.abs(tau) / L) > 0.99 or axial.min() < 1.01 * r.f_min


def test_gripper_load_and_gravity_are_in_the_efforts_by_the_power_balance(vertical):
    # at every node: sum tau_i theta_d_i = d/dt kinetic energy - Q_gravity . qd - F_load . v_P, with
    # qd, qdd from the mechanism's velocity and acceleration analysis (ideal joints do no work)
    scene, r = vertical
    mech = rrr4.Mechanism.from_scene(scene)
    model = mech.model
    load = np.array(scene.forces[0].force)
    for i in range(1, len(r.t) - 1):
        q = mech.assemble(r.pose[i, :2])
        qd, qdd, theta_d, _ = (np.ravel(v) for v in mech.motion(q[None], r.pose_d[i, :2][None],
                                                                 r.pose_dd[i, :2][None]))
        power_in = r.efforts[i] @ theta_d
        kinetic = qd @ (model.mass_diagonal * qdd)
        gravity = model.gravity_forces(scene.effects.gravity) @ qd
        assert power_in == pytest.approx(kinetic - gravity - load @ r.pose_d[i, :2], rel=1e-6, abs=1e-9)


def test_time_plus_effort_matches_its_closed_form():
    # rest to rest over L on x: for a duration T the least effort is 12 m^2 L^2 / T^3 (N^2 / (N^2 - 1)
    # times it with constant accelerations per interval), so T + w E is least at
    # T^4 = 36 w m^2 L^2 N^2 / (N^2 - 1) (the force 6 m L / T^2 stays below the limit here)
    L, w, N = 0.2, 0.0035, 20
    r = optimal_motion(load_scene(XYT), [L, 0.0, 0.0], "time+effort", effort_weight=w, nodes=N, contact=False)
    exact = (36 * w * MASS_X**2 * L**2 * N**2 / (N**2 - 1)) ** 0.25
    assert r.duration == pytest.approx(exact, rel=1e-5)
    assert np.max(np.abs(r.efforts[:, 0])) < FX


def test_point_task_target_bad_input_is_one_line():
    scene = load_scene(FIVE_BAR)
    with pytest.raises(SceneError, match=r"target: .* is not allowed \(a task point \[x, y\]"):
        optimal_motion(scene, [0.03, 0.02, 0.0, 1.0], nodes=4)
    with pytest.raises(SceneError, match=r"effort_weight"):
        optimal_motion(scene, [0.03, 0.02], "time+effort", effort_weight=-1.0, nodes=4)


@pytest.mark.slow
def test_five_bar_replay_keeps_every_joint_in_contact(tmp_path):
    # the done-when of the point-to-point loop: optimize --to on the five-bar, replayed with the
    # clearance dynamics and the scene's preloading controller, loses no contact
    from rrr4.studies.optimize import optimize
    opt = optimize(load_scene(FIVE_BAR), target=[0.03, 0.02], nodes=20)
    arm = opt.replay.arms["with_preload"]
    assert sum(arm.simulation.contact_loss_events.values()) == 0
    assert opt.statistics["replay_time_law"]["duration_ratio_to_motion"] < 1.05
