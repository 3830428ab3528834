"""The one controller (rrr4.control): what the simulation runs is what codegen writes; the
sampled controller, the closed-form QP preload and the clearance compensation."""

import shutil
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from rrr4 import Mechanism, SceneError, build, load_scene, simulate
from rrr4.control import controller_function, seat_gaps
from rrr4.control.compensation import nrrr_slip
from rrr4.preload.qp import qp_preload_function, scalar_qp_preload_function
from rrr4.trajectory import sample_path

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _act(scene, **kw):
    return replace(scene, actuation=replace(scene.actuation, **kw))


def _rms(sim):
    return float(np.sqrt(np.mean(sim.platform_error**2)))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_generated_controller_in_the_loop_reproduces_the_python_controller(paper_scene):
    """The compiled C of the controller step (as codegen writes it, via casadi.external) in
    the loop: the same trajectory as the CasADi controller to 1e-9 m over 0.1 s, no losses."""
    scene = _act(paper_scene, compensation="clearance")
    a = simulate(scene, t_end=0.1, controller="python")
    b = simulate(scene, t_end=0.1, controller="generated")
    assert b.stats["controller"] == "generated" and b.stats["control_rate"] == 1e4
    assert np.max(np.abs(a.pose - b.pose)) < 1e-9
    assert sum(b.contact_loss_events.values()) == 0
    np.testing.assert_allclose(a.tau, b.tau, atol=1e-9)


def test_generated_controller_needs_a_rate_and_the_scenes_own_references(paper_scene):
    with pytest.raises(SceneError, match="control_rate"):
        simulate(_act(paper_scene, control_rate=None), t_end=0.01, controller="generated")
    graph = load_scene(PROBLEMS / "paper_circle_graph.yaml")
    with pytest.raises(SceneError, match="controller: 'generated' is not allowed here \\(references='sampled'"):
        simulate(graph, t_end=0.01, controller="generated", references="sampled")
    with pytest.raises(SceneError, match="controller: unknown value 'c'"):
        simulate(paper_scene, t_end=0.01, controller="c")
    with pytest.raises(SceneError, match="control_rate"):   # not a whole number of periods
        simulate(_act(paper_scene, control_rate=3.0), t_end=0.01)


def test_closed_form_qp_is_the_qp_solvers_optimum(paper_scene):
    """One degree of redundancy: the QP's optimum in closed form equals qrqp's on the path."""
    s = sample_path(paper_scene.path)
    problem = build(paper_scene)
    raw = problem.effort_family(s.pose, s.pose_d, s.pose_dd).raw
    for sign in (1.0, -1.0):
        a, _, feasible, _ = (np.array(v) for v in qp_preload_function(problem, "qrqp", sign).map(len(s.t))(*raw))
        b, _, feasible_b, _ = (np.array(v) for v in scalar_qp_preload_function(problem, sign).map(len(s.t))(*raw))
        ok = feasible.ravel() > 0.5
        assert ok.sum() > len(s.t) // 2
        np.testing.assert_allclose(b.ravel()[ok], a.ravel()[ok], atol=1e-9)
        np.testing.assert_array_equal(feasible_b.ravel(), feasible.ravel())
    # one sign per joint: a list of equal signs is the scalar law; reversing the C joints (the
    # same link's axial force as B's, pulled the other way) is infeasible everywhere, for both
    mixed = [1.0] * 4 + [-1.0] * 4
    _, _, feasible, _ = (np.array(v) for v in qp_preload_function(problem, "qrqp", mixed).map(len(s.t))(*raw))
    _, _, feasible_b, _ = (np.array(v) for v in scalar_qp_preload_function(problem, mixed).map(len(s.t))(*raw))
    assert not feasible.any() and not feasible_b.any()
    same = (np.array(v) for v in scalar_qp_preload_function(problem, [-1.0] * 8).map(len(s.t))(*raw))
    for u, v in zip(same, scalar_qp_preload_function(problem, -1.0).map(len(s.t))(*raw), strict=True):
        np.testing.assert_array_equal(u, np.array(v))


def test_compensated_ik_puts_the_platform_on_the_commanded_pose(paper_scene):
    """Kinematics only: with every journal at its predicted seat (the gaps the controller
    closes its IK around), Newton on the graph's joint equations assembles the mechanism with
    the platform on the commanded pose and the actuators at the compensated references."""
    scene = _act(paper_scene, compensation="clearance")
    mech = Mechanism.from_scene(scene)
    f = controller_function(build(scene))
    inv = build(scene).inverse_dynamics()
    p, pd = ca.SX.sym("p", 3), ca.SX.sym("pd", 3)
    slip_f = ca.Function("slip", [p, pd], [nrrr_slip(build(scene), p, pd)])
    s = sample_path(scene.path, 20.0)
    names = list(mech.model.preload_joints)
    clear = [names.index(j) for j in mech.model.clearance_joints]
    for k in range(1, len(s.t) - 1):
        motion = (s.pose[k], s.pose_d[k], s.pose_dd[k])
        _, _, theta_ref, _, alpha, _ = (np.array(v) for v in f(*motion, np.zeros(4), np.zeros(4)))
        _, _, r_p, r_n = (np.array(v) for v in inv(*motion))
        gaps = seat_gaps(build(scene), r_p + alpha.item() * r_n, np.array(slip_f(*motion[:2])).ravel())
        assert np.all(np.linalg.norm(gaps, axis=0) > 0.99e-4)  # every journal on its wall
        q = mech.assemble(s.pose[k], gaps.T[clear], guess=mech.body_motion(s.pose[k])[0])
        np.testing.assert_allclose(mech.model.task_pose_function(q), s.pose[k][:, None], atol=1e-12)
        theta = mech.actuator_coordinates(q)
        np.testing.assert_allclose(np.angle(np.exp(1j * (theta - theta_ref.ravel()))), 0.0, atol=1e-12)


def test_compensation_lowers_the_error_and_changes_nothing_without_clearance(paper_scene):
    """Reference scene: compensated RMS below uncompensated, both without contact loss;
    friction off, the compensation removes the steady offset almost entirely. An all-ideal
    scene: bit for bit the same motion."""
    plain = simulate(paper_scene, t_end=0.2)
    comp = simulate(_act(paper_scene, compensation="clearance"), t_end=0.2)
    assert sum(plain.contact_loss_events.values()) == sum(comp.contact_loss_events.values()) == 0
    assert _rms(comp) < 0.6 * _rms(plain)
    dry = replace(paper_scene, effects=replace(paper_scene.effects, friction=replace(paper_scene.effects.friction,
                                                                                      law="none")))
    assert _rms(simulate(_act(dry, compensation="clearance"), t_end=0.2)) < 0.05 * _rms(simulate(dry, t_end=0.2))
    ideal = load_scene(PROBLEMS / "ideal_circle.yaml")
    a = simulate(ideal, t_end=0.05)
    b = simulate(_act(ideal, compensation="clearance"), t_end=0.05)
    np.testing.assert_array_equal(a.q, b.q)


def test_sampled_controller_converges_to_the_continuous_one(paper_scene):
    """Zero-order hold at 1 kHz and 10 kHz against the continuous controller: the difference
    in platform motion shrinks with the rate (first order in the period)."""
    cont = simulate(_act(paper_scene, control_rate=None), t_end=0.1, output_rate=1000)
    errs = []
    for rate in (1e3, 1e4):
        held = simulate(_act(paper_scene, control_rate=rate), t_end=0.1, output_rate=1000)
        assert held.stats["references"] == "held" and len(held.t) == len(cont.t)
        errs.append(np.max(np.abs(held.pose[:, :2] - cont.pose[:, :2])))
    assert errs[1] < 0.3 * errs[0]


def test_unpreloaded_controller_is_the_minimum_norm_one(paper_scene):
    """method none or min_force 0: alpha = 0, the feed-forward is tau_p."""
    for scene in (replace(paper_scene, actuation=replace(paper_scene.actuation, preload=replace(
            paper_scene.actuation.preload, method="none"))),
                  replace(paper_scene, actuation=replace(paper_scene.actuation, preload=replace(
                      paper_scene.actuation.preload, min_force=0.0)))):
        f = controller_function(build(scene))
        s = sample_path(scene.path, 10.0)
        tau_p = np.array(build(scene).inverse_dynamics()(s.pose[3], s.pose_d[3], s.pose_dd[3])[0]).ravel()
        out = f(s.pose[3], s.pose_d[3], s.pose_dd[3], np.zeros(4), np.zeros(4))
        np.testing.assert_allclose(np.array(out[1]).ravel(), tau_p, atol=1e-12)
        assert float(out[4]) == 0.0


def test_robustness_cases_change_one_parameter_and_the_model_stays_nominal(paper_scene):
    """Each case changes what it names; simulate(model=nominal) runs the nominal controller on
    the changed mechanism (a 50 um longer link moves the platform), and a bad model is refused."""
    from rrr4.studies.robustness import CASES, perturbed
    nominal_k = build(paper_scene).joint_stiffness("B1")
    checks = {
        "clearance +20 %": lambda s: s.joint("C2").radial_clearance == pytest.approx(1.2e-4),
        "stiffness x0.3": lambda s: s.effects.contact.stiffness == pytest.approx(0.3 * nominal_k),
        "friction 0.2": lambda s: s.effects.friction.coefficient == 0.2,
        "link A1B1 +50 um": lambda s: s.mechanism.chains[0].driving.length == pytest.approx(0.25005)
        and s.mechanism.chains[1].driving.length == 0.25,
    }
    for case, ok in checks.items():
        assert ok(perturbed(build(paper_scene), case)), case
    assert set(checks) < set(CASES)
    plant = perturbed(build(paper_scene), "link A1B1 +50 um")
    a = simulate(paper_scene, t_end=0.02)
    b = simulate(plant, t_end=0.02, model=paper_scene)
    assert 5e-7 < np.max(np.abs(b.pose[-1, :2] - a.pose[-1, :2])) < 1e-4
    with pytest.raises(SceneError, match="model: .* is not allowed"):
        simulate(paper_scene, t_end=0.01, model="nominal")
    with pytest.raises(SceneError, match="case: 'x' is not allowed"):
        perturbed(build(paper_scene), "x")


@pytest.mark.parametrize("key, value, match", [
    ("actuation.control_rate", -5, "actuation.control_rate: -5 is not allowed"),
    ("actuation.control_rate", "fast", "actuation.control_rate: 'fast' is not a number"),
    ("actuation.compensation", "clearence", "did you mean 'clearance'"),
    ("actuation.preload.method", "nonee", "did you mean 'none'"),
    ("actuation.seat_model", "roling", "did you mean 'rolling'"),
])
def test_bad_controller_keys_are_one_line(paper_data, key, value, match):
    from rrr4.scene import parse_scene, set_key
    set_key(paper_data, key, value)
    with pytest.raises(SceneError, match=match) as e:
        parse_scene(paper_data)
    assert "\n" not in str(e.value)


def test_graph_compensation_by_newton_equals_the_nrrr_closed_form(paper_scene):
    """The general graph's compensated references (Newton around the seats, friction torques
    by virtual power) equal the n-RRR closed form: angles to 1e-12 rad, feed-forward to
    1e-9 N m (the rates differ by the seats' drift, which the closed form holds fixed)."""
    from rrr4.control import tabulated
    a = _act(paper_scene, compensation="clearance")
    b = _act(load_scene(PROBLEMS / "paper_circle_graph.yaml"), compensation="clearance")
    t = np.linspace(0.0, 1.0, 21)
    ra, rb = tabulated(build(a), t, None), tabulated(build(b), t, None)
    assert np.max(np.abs(np.angle(np.exp(1j * (ra.theta_ref - rb.theta_ref))))) < 1e-12
    np.testing.assert_allclose(rb.tau_ff, ra.tau_ff, atol=1e-9)
    assert np.max(np.abs(ra.theta_d_ref - rb.theta_d_ref)) < 1e-3 * np.max(np.abs(ra.theta_d_ref))


def test_rolling_seat_friction_rolls_through_the_friction_angle_over_its_slip_distance(paper_scene):
    """The rolled fraction under a slip that starts, holds and reverses: from 0 it reaches 1
    after the slip distance and holds; after the reversal it crosses 0 after another distance
    and reaches -1 after two. On the reference scene the friction coefficient is that
    fraction of mu, opposes the planned slip once rolled, and does not depend on the grid it
    is asked on (integrated from the path's start); 0 without friction."""
    from rrr4.control.compensation import planned_slip, rolled_fraction, rolling_friction
    v, distance = 1e-3, 1e-5  # m/s, m
    t = np.linspace(0.0, 0.2, 20001)
    lam = rolled_fraction(t, np.where(t < 0.1, v, -v), distance)
    one = distance / v  # s to roll through one friction angle
    np.testing.assert_allclose(np.interp(0.5 * one, t, lam), 0.5, rtol=1e-9)
    np.testing.assert_array_equal(lam[(t > one + 1e-4) & (t < 0.1)], 1.0)
    crossing = t[np.argmax((t > 0.1) & (lam <= 0))]
    assert abs(crossing - (0.1 + one)) < 2e-5
    np.testing.assert_array_equal(lam[t > 0.1 + 2 * one + 1e-4], -1.0)
    problem = build(paper_scene)
    mu = paper_scene.effects.friction.coefficient
    fine = np.linspace(0.0, 1.0, 1001)
    m = rolling_friction(problem, fine)
    assert np.max(np.abs(m)) == pytest.approx(mu)
    slip = planned_slip(problem, fine)
    rolled = (np.abs(m) == mu) & (np.abs(slip) > 1e-4)  # not the instant the slip reverses
    assert rolled.mean() > 0.5 and np.all(np.sign(m[rolled]) == -np.sign(slip[rolled]))
    v0 = paper_scene.effects.friction.v0  # below it Ambrosio's law has no friction: no rolling
    for j in range(slip.shape[1]):
        first = np.argmax(np.abs(slip[:, j]) > v0)
        assert first > 0 and not m[:first, j].any()
    late = np.linspace(0.3, 1.0, 15)  # a coarse grid that starts late: the same values
    np.testing.assert_allclose(rolling_friction(problem, late), m[np.searchsorted(fine, late)], atol=1e-15)
    dry = replace(paper_scene, effects=replace(paper_scene.effects, friction=replace(paper_scene.effects.friction,
                                                                                      law="none")))
    assert not rolling_friction(build(dry), fine).any()


def test_rolling_seats_halve_the_compensated_error_of_the_reference_scene(paper_scene):
    """The compensated reference scene (1 s), quasi-static against rolling seats: no contact
    loss in either, and the rolling seats' feed-forward follows the friction the journals
    really have at the slip reversals (measured: 4.28 against 1.76 um RMS)."""
    comp = _act(paper_scene, compensation="clearance")
    quasi = simulate(comp)
    rolling = simulate(_act(comp, seat_model="rolling"))
    assert sum(quasi.contact_loss_events.values()) == sum(rolling.contact_loss_events.values()) == 0
    assert _rms(rolling) < 0.6 * _rms(quasi)


def test_robustness_cli_refuses_what_it_cannot_vary_in_one_line(capsys, tmp_path):
    from rrr4.cli import main as cli_main
    assert cli_main(["robustness", str(PROBLEMS / "paper_circle_graph.yaml"), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "n-RRR scenes with clearance joints" in err
    assert not (tmp_path / "r").exists()
