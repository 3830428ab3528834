"""Point-to-point motions (rrr4.optimal.optimal_motion): closed forms on the X-Y-theta table,
the reference 4-RRR with the contact condition, and bad input in one line."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import rrr4
from rrr4 import load_scene
from rrr4.errors import InfeasibleError, KinematicsError, SceneError, SolverError
from rrr4.optimal import optimal_motion, optimal_time_law, point_to_point

ROOT = Path(__file__).resolve().parents[1]
XYT = ROOT / "problems" / "xyt_table.yaml"
GRAPH = ROOT / "problems" / "paper_circle_graph.yaml"

# problems/xyt_table.yaml: moving mass on the x axis, the table's inertia, the limits
MASS_X, INERTIA, FX, TR = 2.0 + 1.0 + 0.5, 0.004, 50.0, 0.5


@pytest.fixture(scope="module")
def xyt():
    return load_scene(XYT)


def _bang_bang(inertia, distance, limit):
    return 2.0 * np.sqrt(inertia * distance / limit)


def test_xyt_move_along_x_takes_the_bang_bang_time(xyt):
    # the path is free, the axes are decoupled: the fastest move is bang-bang along x, T = 2 sqrt(m L / F).
    # The acceleration is constant per interval: with N even the switch is a node and the optimum is
    # exact; with N odd the error is below 1 / N^2 (relative) and shrinks with N.
    exact = _bang_bang(MASS_X, 0.2, FX)
    even = optimal_motion(xyt, [0.2, 0.0, 0.0], nodes=10, contact=False)
    assert even.duration == pytest.approx(exact, rel=1e-7)
    errors = []
    for N in (5, 11):
        r = optimal_motion(xyt, [0.2, 0.0, 0.0], nodes=N, contact=False)
        errors.append(r.duration / exact - 1.0)
        assert 0.0 <= errors[-1] <= 1.0 / N**2
    assert errors[1] < errors[0] / 3
    assert even.statistics["success"] and even.statistics["iterations"] > 0
    # FX is the binding constraint at every node; the motion is rest to rest and ends at the target
    assert even.binding_counts() == {"actuator FX": 11}
    assert np.allclose(np.abs(even.efforts[:, 0]), FX, rtol=1e-6)
    np.testing.assert_allclose(even.pose[-1], [0.2, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(even.pose_d[[0, -1]], 0.0, atol=1e-12)


def test_xyt_pure_turn_takes_the_bang_bang_time(xyt):
    exact = _bang_bang(INERTIA, 1.0, TR)
    r = optimal_motion(xyt, [0.0, 0.0, 1.0], nodes=10, contact=False, start=[0.0, 0.0, 0.0])
    assert r.duration == pytest.approx(exact, rel=1e-7)
    r11 = optimal_motion(xyt, [0.0, 0.0, 1.0], nodes=11, contact=False, start=[0.0, 0.0, 0.0])
    assert 0.0 <= r11.duration / exact - 1.0 <= 1.0 / 11**2
    assert set(r.binding_counts()) == {"actuator TR"}


def test_xyt_least_effort_move_matches_the_cubic_closed_form(xyt):
    # min integral of F^2 over a rest-to-rest move of L in T: F linear in t, effort 12 m^2 L^2 / T^3;
    # with constant accelerations per interval the discrete optimum is N^2 / (N^2 - 1) times it
    exact = 12.0 * MASS_X**2 * 0.2**2 / 0.5**3
    errs = []
    for N in (10, 20):
        r = optimal_motion(xyt, [0.2, 0.0, 0.0], "effort", duration=0.5, nodes=N, contact=False)
        assert r.duration == 0.5
        errs.append(r.statistics["objective_value"] / exact - 1.0)
        assert errs[-1] == pytest.approx(1.0 / (N**2 - 1), rel=1e-4)
    assert errs[1] < errs[0] / 3


@pytest.fixture(scope="module")
def reference_motion(paper_scene):
    return optimal_motion(paper_scene, [0.02, 0.0, 0.0], nodes=20)


def test_reference_motion_keeps_every_joint_in_contact_within_the_limits(reference_motion, paper_scene):
    r = reference_motion
    L, f_min = 5.0, 10.0
    assert r.statistics["success"] and r.contact and r.sign in (1, -1)
    assert np.max(np.abs(r.efforts)) <= L * (1 + 1e-7)
    assert r.axial.shape == (21, 8) and r.axial.min() >= f_min * (1 - 1e-7)
    # the fastest motion rides on its limits: an actuator or a contact condition binds somewhere
    assert any(k.startswith("actuator") for k in r.binding_counts())
    assert any(k.startswith("contact") for k in r.binding_counts())
    # away from the singularity margins of the scene
    assert r.condition.max() < paper_scene.path.max_condition_number
    assert r.transmission.min() > paper_scene.path.min_transmission
    # both signs were solved and the faster kept
    by_sign = r.statistics["objective_by_sign"]
    assert set(by_sign) == {"+1", "-1"} and r.duration == pytest.approx(min(v for v in by_sign.values() if v))


def test_reference_motion_efforts_are_the_inverse_dynamics_of_its_motion(reference_motion, paper_scene):
    r = reference_motion
    problem = rrr4.build(paper_scene)
    # the states follow the exact integration of the interval accelerations
    h = r.duration / (len(r.t) - 1)
    acc = r.pose_dd[:-1]
    np.testing.assert_allclose(r.pose[1:], r.pose[:-1] + h * r.pose_d[:-1] + h**2 / 2 * acc, atol=1e-9)
    np.testing.assert_allclose(r.pose_d[1:], r.pose_d[:-1] + h * acc, atol=1e-7)
    np.testing.assert_allclose(r.pose[-1], [0.02, 0.0, 0.0], atol=1e-9)
    fam = problem.effort_family(r.pose, r.pose_d, r.pose_dd)
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, r.alpha)
    np.testing.assert_allclose(r.efforts, tau, rtol=1e-9, atol=1e-9 * 5.0)
    reactions = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, r.alpha)
    np.testing.assert_allclose(r.reactions, reactions, rtol=1e-9, atol=1e-9 * 10.0)


def test_reference_motion_is_no_slower_than_the_straight_line_optimum(reference_motion, paper_scene):
    # the straight line with its optimal time law is one of the motions part 2 may choose: the free
    # path can only be faster (the line's law on a finer grid: its duration converges from below)
    line = replace(paper_scene, path=replace(paper_scene.path, type="line", start=(0.0, 0.0, 0.0),
                                             end=(0.02, 0.0, 0.0)))
    law = optimal_time_law(line, points=100)
    assert reference_motion.duration <= law.duration
    assert reference_motion.statistics["line_duration_s"] >= reference_motion.duration


def test_reference_least_effort_motion_keeps_contact_at_the_given_duration(paper_scene, reference_motion):
    r = optimal_motion(paper_scene, [0.02, 0.0, 0.0], "effort", duration=0.2, nodes=10)
    assert r.statistics["success"] and r.duration == 0.2 and r.t[-1] == pytest.approx(0.2)
    assert r.axial.min() >= 10.0 * (1 - 1e-7) and np.max(np.abs(r.efforts)) <= 5.0 * (1 + 1e-7)
    # slower than the fastest motion, so no actuator is at its limit: the contact condition binds
    assert r.duration > reference_motion.duration
    assert all(k.startswith("contact") for k in r.binding_counts()) and r.binding_counts()


def test_transmission_margin_holds_at_every_node_and_binds(paper_scene):
    # a turning move whose unconstrained optimum dips to |sin| 0.847 in chain 3: with the scene's
    # margin raised to 0.85 every node keeps it, the margin binds, and the motion gets slower
    start, target = [0.04, 0.071, 0.677], [0.085, 0.048, -0.471]
    free = optimal_motion(paper_scene, target, start=start, nodes=20, contact=False)
    assert free.transmission.min() < 0.85
    strict = replace(paper_scene, path=replace(paper_scene.path, min_transmission=0.85))
    r = optimal_motion(strict, target, start=start, nodes=20, contact=False)
    assert r.transmission.min() >= 0.85 * (1 - 1e-8)
    assert any(k.startswith("transmission") for k in r.binding_counts())
    # between the nodes too: the free motion dips below 0.85 there, the strict one keeps it
    assert free.statistics["along"]["min_transmission"] < 0.85
    assert r.statistics["along"]["min_transmission"] >= 0.85 * (1 - 1e-6)


def test_solver_failure_names_the_worst_constraint_and_node(paper_scene, monkeypatch):
    monkeypatch.setitem(point_to_point.IPOPT_OPTIONS, "ipopt.max_iter", 3)
    with pytest.raises(SolverError, match=r"solver stopped with Maximum_Iterations_Exceeded \(largest violation "
                                              r"[0-9.e+-]+, [a-z_ ()A-Z0-9]+ at (node|interval|end) \d+\)$") as e:
        optimal_motion(paper_scene, [0.02, 0.0, 0.0], nodes=10, sign=1)
    assert "\n" not in str(e.value)


def test_unreachable_target_is_one_line_naming_the_chain(paper_scene):
    with pytest.raises(KinematicsError, match=r"target: pose \[0\.22, 0\.0, 0\.0\] is out of reach of chain 1") as e:
        optimal_motion(paper_scene, [0.22, 0.0, 0.0], nodes=10)
    assert "\n" not in str(e.value)


def test_target_beyond_the_singularity_margin_is_one_line(paper_scene):
    with pytest.raises(InfeasibleError, match=r"target pose \[0\.215, 0\.0, 0\.0\] is beyond the singularity "
                                              r"margin: chain 1's transmission .*path\.min_transmission = 0\.05"
                       ) as e:
        optimal_motion(paper_scene, [0.215, 0.0, 0.0], nodes=10)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("kwargs, match", [
    (dict(target=[0.02, 0.0]), r"target: .* 3 finite numbers"),
    (dict(target=[0.02, 0.0, 0.0], objective="energy"), r"objective: unknown value 'energy'"),
    (dict(target=[0.02, 0.0, 0.0], objective="effort"), r"duration: missing"),
    (dict(target=[0.02, 0.0, 0.0], nodes=1), r"nodes: 1 is not allowed"),
    (dict(target=[0.0, 0.0, 0.0]), r"target: .* \(the same pose as the start\)"),
    (dict(target=[0.02, 0.0, 0.0], sign=2), r"sign: 2 is not allowed"),
])
def test_bad_arguments_are_one_line(paper_scene, kwargs, match):
    with pytest.raises(SceneError, match=match) as e:
        optimal_motion(paper_scene, **kwargs)
    assert "\n" not in str(e.value)


def test_contact_condition_needs_redundancy(xyt):
    with pytest.raises(SceneError, match=r"contact: True is not allowed for this scene .*pass contact=False"):
        optimal_motion(xyt, [0.2, 0.0, 0.0], nodes=10)


@pytest.mark.slow
def test_reference_motion_duration_decreases_with_nodes(paper_scene):
    # constraints hold at the nodes: more nodes, more freedom of the acceleration profile
    d = [optimal_motion(paper_scene, [0.02, 0.0, 0.0], nodes=N).duration for N in (20, 40, 80)]
    assert d[0] > d[1] > d[2] > 0.9 * d[0]


@pytest.mark.slow
def test_graph_form_gives_a_motion_the_closed_form_accepts(paper_scene):
    # the reference 4-RRR written as a graph (body coordinates, multipliers and efforts as unknowns):
    # its optimal motion without the contact condition is realisable by the closed-form n-RRR within
    # the limits (the efforts are in the closed form's family), at least as fast as the closed form's
    g = optimal_motion(load_scene(GRAPH), [0.02, 0.0, 0.0], nodes=20, contact=False)
    n = optimal_motion(paper_scene, [0.02, 0.0, 0.0], nodes=20, contact=False)
    fam = rrr4.build(paper_scene).effort_family(g.pose, g.pose_d, g.pose_dd)
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, g.alpha)
    np.testing.assert_allclose(tau, g.efforts, atol=1e-8)
    assert np.max(np.abs(g.efforts)) <= 5.0 * (1 + 1e-7)
    assert g.duration == pytest.approx(n.duration, rel=0.02)
