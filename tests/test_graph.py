"""The body/joint graph: Flores's slider-crank against its closed form, the graph form of the
reference 4-RRR against the n-RRR form, Jacobians against finite differences, and bad graphs."""

import copy
import dataclasses
import subprocess
import sys
import warnings

import numpy as np
import pytest
import yaml

import rrr4
from rrr4 import Mechanism, Model, SceneError, build, check_scene, simulate, solve_preload
from rrr4.scene import parse_scene
from tests.conftest import ROOT

SLIDER = ROOT / "problems" / "flores_slider_crank.yaml"
IDEAL_SLIDER = ROOT / "problems" / "flores_slider_crank_ideal.yaml"
PAPER_GRAPH = ROOT / "problems" / "paper_circle_graph.yaml"
R, L = 0.05, 0.12                      # crank and connecting-rod lengths [m]
OMEGA = 5000.0 * 2 * np.pi / 60        # crank speed [rad/s]


def _slider_closed_form(theta):
    """x, dx/dt, d2x/dt2 of the slider pin for the crank angle theta at constant OMEGA:
    x = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta))."""
    s, c = np.sin(theta), np.cos(theta)
    D = np.sqrt(L**2 - R**2 * s**2)
    x = R * c + D
    x1 = -R * s - R**2 * s * c / D
    x2 = -R * c - R**2 * (c**2 - s**2) / D - R**4 * s**2 * c**2 / D**3
    return x, x1 * OMEGA, x2 * OMEGA**2


def _assert_same_angles(actual, desired, atol):
    """actual == desired up to whole turns (the graph's assembly wraps angles to (-pi, pi],
    the n-RRR closed form does not)."""
    d = np.asarray(actual) - np.asarray(desired)
    np.testing.assert_allclose(np.pi - np.mod(np.pi - d, 2 * np.pi), 0.0, atol=atol)


def _assert_same_coordinates(actual, desired, atol):
    """Body coordinates [x, y, theta] per body equal, theta up to whole turns."""
    a, b = np.asarray(actual), np.asarray(desired)
    np.testing.assert_allclose(np.delete(a, np.s_[2::3], axis=-1), np.delete(b, np.s_[2::3], axis=-1), atol=atol)
    _assert_same_angles(a[..., 2::3], b[..., 2::3], atol)


@pytest.fixture(scope="module")
def slider_data():
    return yaml.safe_load(SLIDER.read_text())


def test_ideal_slider_crank_kinematics_equal_the_closed_form():
    """Position analysis (rootfinder), velocity and acceleration analysis of the graph over one
    crank revolution: slider x, x_dot, x_ddot to 1e-9 relative."""
    scene = rrr4.load_scene(IDEAL_SLIDER)
    mech = Mechanism.from_scene(scene)
    t = np.linspace(0.0, 2 * np.pi / OMEGA, 181)
    q = mech.path_coordinates(mech.driver_targets(t))
    qd, qdd, _, _ = mech.motion(q, np.full((len(t), 1), OMEGA), np.zeros((len(t), 1)))
    k = mech.model.coordinates("slider").start
    x, xd, xdd = _slider_closed_form(OMEGA * t)
    for got, want in ((q[:, k], x), (qd[:, k], xd), (qdd[:, k], xdd)):
        assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))
    np.testing.assert_allclose(q[:, mech.model.coordinates("slider")][:, 1:], 0.0, atol=1e-12)


def test_ideal_slider_crank_simulation_follows_the_closed_form():
    """The driven simulation (driver row in the constraints, Baumgarte) keeps the slider on
    the closed form to 1e-9 relative, and the energy balance closes with the driver's work."""
    sim = simulate(rrr4.load_scene(IDEAL_SLIDER), step=1e-5, t_end=2 * np.pi / OMEGA)
    crank, slider = sim.body("crank"), sim.body("slider")
    np.testing.assert_allclose(np.unwrap(2 * crank[:, 2]) / 2, OMEGA * sim.t, atol=1e-9)
    x, _, _ = _slider_closed_form(OMEGA * sim.t)
    assert np.max(np.abs(slider[:, 0] - x)) <= 1e-9 * np.max(np.abs(x))
    assert sim.energy_audit_residual < 1e-8
    assert sim.driver_effort.shape == (len(sim.t), 1) and np.ptp(sim.driver_effort) > 1.0


def test_conservative_slider_crank_with_clearance_keeps_its_energy(slider_data):
    """Purely elastic contact (Hertz), no friction: work of the crank driver = change of
    kinetic + contact energy, nothing dissipated, the residual shrinking with the step (RK4)."""
    d = copy.deepcopy(slider_data)
    d["effects"]["contact"] = {"law": "hertz", "exponent": 1.5}
    scene = check_scene(parse_scene(d))
    res = []
    for h in (2e-6, 1e-6):
        sim = simulate(scene, step=h, t_end=0.006)
        assert sum(sim.contact_loss_events.values()) > 0            # the journal does fly and hit
        assert np.max(np.abs(sim.energy["dissipated_damping"])) == 0.0
        res.append(sim.energy_audit_residual)
    assert res[1] < 1e-6 and res[1] < res[0] / 4


def test_slider_crank_with_clearance_rattles_and_names_its_joints():
    sim = simulate(rrr4.load_scene(SLIDER), step=1e-6, t_end=0.006)
    assert sim.clearance_joints == ("B",) and set(sim.contact_loss_events) == {"A", "B", "P"}
    ecc = np.linalg.norm(sim.eccentricity[:, 0], axis=1)
    assert ecc.max() > 0.5e-3 and np.all(np.isfinite(sim.q))    # the journal reaches the wall
    assert sim.contact_loss_events["B"] > 0


def test_graph_constraint_and_actuator_jacobians_equal_finite_differences():
    """Phi_q (revolute and prismatic rows, drivers) and S = ds/dq by central differences, at
    random configurations of the slider-crank and of the graph 4-RRR."""
    rng = np.random.default_rng(4)
    for path in (IDEAL_SLIDER, PAPER_GRAPH):
        model = Model.of(rrr4.load_scene(path).graph)
        f = model.constraints(model.joint_names, drivers=True)
        for _ in range(3):
            q = rng.normal(size=model.nq)
            phi_q = np.array(f(q, np.zeros(model.nq))[1])
            S = np.array(model.actuator_coordinates_function(q)[1])
            eps = 1e-6
            fd, fd_s = np.zeros_like(phi_q), np.zeros_like(S)
            for k in range(model.nq):
                dq = np.zeros(model.nq)
                dq[k] = eps
                fd[:, k] = (np.array(f(q + dq, 0 * q)[0]) - np.array(f(q - dq, 0 * q)[0])).ravel() / (2 * eps)
                fd_s[:, k] = (np.array(model.actuator_coordinates_function(q + dq)[0])
                              - np.array(model.actuator_coordinates_function(q - dq)[0])).ravel() / (2 * eps)
            np.testing.assert_allclose(phi_q, fd, atol=1e-8)
            np.testing.assert_allclose(S, fd_s, atol=1e-8)


def test_graph_task_jacobian_equals_finite_differences_of_its_ik():
    mech = Mechanism.from_scene(rrr4.load_scene(PAPER_GRAPH))
    pose, eps = np.array([-0.015, 0.01, 0.05]), 1e-6
    fd = np.column_stack([(mech.ik(pose + e) - mech.ik(pose - e)) / (2 * eps) for e in np.eye(3) * eps])
    np.testing.assert_allclose(mech.jacobian(pose), fd, atol=1e-7)
    n = mech.null_space(pose)
    assert np.linalg.norm(mech.jacobian(pose).T @ n) < 1e-12


@pytest.fixture(scope="module")
def both_forms(paper_scene):
    return paper_scene, rrr4.load_scene(PAPER_GRAPH)


def test_graph_4rrr_kinematics_equal_the_nrrr_closed_form(both_forms):
    a, b = (Mechanism.from_scene(s) for s in both_forms)
    assert type(a).__name__ == "NRRRMechanism" and type(b).__name__ == "Mechanism"
    for pose in ([0.0, 0.0, 0.0], [-0.02, 0.015, 0.1], [-0.035, -0.01, -0.05]):
        _assert_same_angles(b.ik(pose), a.ik(pose), atol=1e-12)
        np.testing.assert_allclose(b.jacobian(pose), a.jacobian(pose), atol=1e-12)
        q = a.body_motion(pose)[0]
        _assert_same_coordinates(b.assemble(pose), q, atol=1e-12)


def test_graph_4rrr_preload_and_motion_equal_the_nrrr_form(both_forms):
    """Same preload torques (generic family by SVD vs closed form, then the QP) and the same
    simulated motion: with a given preload, and with the feed-forward alone (closed form in the
    right-hand side vs Hermite interpolation of frame samples)."""
    a, b = both_forms
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pa, pb = solve_preload(a), solve_preload(b)
    np.testing.assert_allclose(pb.tau, pa.tau, atol=1e-9)
    np.testing.assert_allclose(pb.reactions, pa.reactions, atol=1e-8)
    assert pb.joint_names == pa.joint_names
    ra, rb = simulate(a, t_end=0.03, preload=pa), simulate(b, t_end=0.03, preload=pa)
    np.testing.assert_allclose(rb.pose, ra.pose, atol=1e-9)
    np.testing.assert_allclose(rb.body("following_2"), ra.body("following_2"), atol=1e-9)
    np.testing.assert_allclose(ra.body("platform"), ra.pose)
    fa, fb = simulate(a, t_end=0.02), simulate(b, t_end=0.02)
    np.testing.assert_allclose(fb.tau, fa.tau, atol=1e-8)
    _assert_same_coordinates(fb.q, fa.q, atol=1e-9)


def _edit(data, fn):
    d = copy.deepcopy(data)
    fn(d["mechanism"])
    return d


def _rod_too_short(m):
    m["bodies"][1]["points"] = {"A": [-0.01, 0.0], "B": [0.01, 0.0]}


BAD_GRAPHS = [
    ("unknown body", lambda m: m["joints"][1].update(bodies=["crank", "conecting_rod"]),
     ("mechanism.joints[1].bodies: unknown body 'conecting_rod'", "did you mean 'connecting_rod'?")),
    ("body with no joint", lambda m: m["bodies"].append({"name": "flywheel", "mass": 1.0, "inertia": 1e-3}),
     "body 'flywheel' is not allowed (it has no joint"),
    ("cannot assemble", _rod_too_short, "mechanism: the mechanism does not assemble"),
    ("actuator on a missing joint", lambda m: m.update(actuators=[{"joint": "Q", "limit": 1.0}]),
     ("mechanism.actuators[0].joint: unknown joint 'Q'", "choose one of: O, A, B, P")),
    ("driver on a zero prismatic axis", lambda m: (m["joints"][3].update(axis=[0.0, 0.0]),
                                                  m["drivers"].append({"joint": "P", "speed": 0.1})),
     "mechanism.joints[3].axis: [0.0, 0.0] is not allowed (a direction of non-zero length)"),
    ("unknown point", lambda m: m["joints"][0].update(points=["O", "Q"]),
     "mechanism.joints[0].points[1]: unknown point of crank 'Q'"),
    ("cannot be fixed by its drivers", lambda m: m.update(drivers=[]), "degrees of freedom"),
]


@pytest.mark.parametrize("what,edit,expected", BAD_GRAPHS, ids=[b[0] for b in BAD_GRAPHS])
def test_bad_graph_scenes_are_refused_in_one_line(slider_data, what, edit, expected):
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(_edit(slider_data, edit)))
    msg = str(err.value)
    assert "\n" not in msg
    for fragment in (expected,) if isinstance(expected, str) else expected:
        assert fragment in msg


def test_bad_graph_scene_on_the_command_line_is_one_line(tmp_path, slider_data):
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(_edit(slider_data, _rod_too_short)))
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(p)], capture_output=True, text=True)
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "does not assemble" in r.stderr


def _five_chain_graph():
    """The graph 4-RRR with a fifth chain below the platform: redundancy 2."""
    d = yaml.safe_load(PAPER_GRAPH.read_text())
    m = d["mechanism"]
    m["ground"]["points"]["A5"] = [0.0, -0.42]
    m["bodies"] += [{"name": "driving_5", "mass": 0.4, "inertia": 2e-3,
                     "points": {"A": [-0.125, 0.0], "B": [0.125, 0.0]}, "pose": [-0.05, -0.31, 0.8]},
                    {"name": "following_5", "mass": 0.3, "inertia": 1.5e-3,
                     "points": {"B": [-0.125, 0.0], "C": [0.125, 0.0]}, "pose": [-0.03, -0.19, 1.4]}]
    next(b for b in m["bodies"] if b["name"] == "platform")["points"]["C5"] = [0.0, -0.1]
    m["joints"] += [{"name": "A5", "bodies": ["ground", "driving_5"], "points": ["A5", "A"]},
                    {"name": "B5", "bodies": ["driving_5", "following_5"], "points": ["B", "B"]},
                    {"name": "C5", "bodies": ["following_5", "platform"], "points": ["C", "C5"]}]
    m["actuators"].append({"name": "A5", "joint": "A5", "limit": 20.0})
    for a in m["actuators"]:
        a["limit"] = 20.0
    d["actuation"]["preload"]["weights"] = 1.0
    return d


def test_preload_methods_are_refused_where_the_redundancy_does_not_fit():
    with pytest.raises(SceneError, match="redundancy 0 is not allowed for a preload"):
        solve_preload(rrr4.load_scene(IDEAL_SLIDER))
    scene = check_scene(parse_scene(_five_chain_graph()))
    assert Model.of(scene.graph).redundancy == 2
    with pytest.raises(SceneError, match=r"method: 'exact' handles redundancy <= 1, the scene has 2 "
                                         r"\(choose one of: qp, nlp\)"):
        solve_preload(scene, method="exact")


def test_qp_preload_of_a_two_redundant_graph_meets_f_min():
    """Redundancy 2: the generic family (two null-space directions) and the QP keep every
    passive joint at f_min along the path, within the torque limits."""
    scene = check_scene(parse_scene(_five_chain_graph()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = solve_preload(scene, method="qp", sample_rate=100)
    assert sol.alpha.shape == (len(sol.t), 2) and len(sol.joint_names) == 10
    ok = sol.feasible
    assert ok.mean() > 0.9
    assert np.all(np.linalg.norm(sol.reactions[ok], axis=2) >= sol.f_min * (1 - 1e-6))
    assert np.all(np.abs(sol.tau[ok]) <= 20.0 * (1 + 1e-6))


def test_study_of_a_driven_scene_compares_clearance_with_the_ideal_twin(tmp_path):
    """`rrr4 run` on the slider-crank: arms with_clearance and ideal, a half-step rerun, the
    driven metrics and figures, written atomically."""
    from rrr4.results import write_results
    from rrr4.studies.study import run_study
    study = run_study(rrr4.load_scene(SLIDER), t_end=0.004, step=2e-6)
    assert set(study.arms) == {"with_clearance", "ideal"} and study.refinement.simulation.stats["step"] == 1e-6
    summary, files = write_results(study, tmp_path / "out", animate=False)
    assert {"orbits.png", "contact_force.png", "accelerations.png", "driver_effort.png", "summary.json",
            "report.md", "timeseries.csv"} <= set(files)
    c, ideal = summary["with_clearance"], summary["ideal"]
    assert c["contact_loss_events"]["B"] > 0 and ideal["contact_loss_events"]["B"] == 0
    assert c["acceleration_deviation_rms_m_s2"]["slider"] > 0 == ideal["acceleration_deviation_rms_m_s2"]["slider"]
    assert summary["step_convergence"]["steps_s"] == [2e-6, 1e-6]
    header = (tmp_path / "out" / "timeseries.csv").read_text().splitlines()[0]
    assert "with_clearance_slider_ax_m_s2" in header and "ideal_crank_drive_effort_Nm" in header


def test_a_driven_study_carries_no_leftover_of_the_preload_study(tmp_path):
    """A metric that does not apply is absent (never 0 or NaN): no gains, controller, platform
    error or torques without a task and actuators; the prismatic joint P has no journal, so
    it is not among the contact metrics; driver efforts carry their unit; no inverse dynamics
    along a path that does not exist is announced."""
    from rrr4.results import write_results
    from rrr4.studies.study import run_study
    lines = []
    study = run_study(rrr4.load_scene(SLIDER), t_end=0.002, step=2e-6, log=lines.append)
    summary, _ = write_results(study, tmp_path / "out", animate=False)
    assert not any("inverse dynamics" in line for line in lines)
    assert not {"gains", "controller", "chains"} & set(summary)
    assert summary["preload"]["reason"] == "no task body: the drivers set the motion"
    for arm in ("with_clearance", "ideal", "half_step"):
        m = summary[arm]
        assert not {"platform_error_rms_m", "platform_error_max_m", "torque_rms_Nm", "torque_peak_Nm",
                    "effort_at_limit_fraction", "driver_effort_peak", "driver_effort_rms"} & set(m)
        for key in ("contact_loss_events", "free_flight_fraction", "peak_contact_force_N", "min_contact_force_N"):
            assert set(m[key]) == {"A", "B"}  # O is driven; P is prismatic
        assert set(m["driver_effort_peak_Nm"]) == {"crank_drive"} and m["driver_effort_peak_Nm"]["crank_drive"] > 0
    report = (tmp_path / "out" / "report.md").read_text()
    assert "peak effort of driver crank_drive [N m]" in report


ROTOR = """
name: balanced_rotor
description: A balanced rotor turning in a bearing housing held by a torque arm
mechanism:
  kind: graph
  ground: {points: {O: [0.0, 0.0], G: [0.1, 0.1]}}
  bodies:
    - {name: rotor, mass: 1.0, inertia: 1.0e-3, points: {O: [0.0, 0.0]}, pose: [0.0, 0.0, 0.0]}
    - {name: housing, mass: 0.5, inertia: 1.0e-3, points: {O: [0.0, 0.0], T: [0.1, 0.0]}, pose: [0.0, 0.0, 0.0]}
    - {name: arm, mass: 0.1, inertia: 1.0e-4, points: {T: [0.0, -0.05], G: [0.0, 0.05]}, pose: [0.1, 0.05, 0.0]}
  joints:
    - {name: spindle, type: revolute, bodies: [ground, rotor], points: [O, O]}
    - name: bearing
      type: revolute
      bodies: [rotor, housing]
      points: [O, O]
      clearance: {journal: rotor, journal_radius: 0.01, radial_clearance: 1.0e-4}
    - {name: T, type: revolute, bodies: [housing, arm], points: [T, T]}
    - {name: G, type: revolute, bodies: [arm, ground], points: [G, G]}
  drivers:
    - {name: motor, joint: spindle, initial_deg: 90.0, speed_rpm: 600.0}
  task: none
effects:
  contact: {law: lankarani-nikravesh, restitution: 0.5, stiffness: auto}
  gravity: [0.0, -9.81]
initial: {journals: centred}
path: {type: none, duration: 0.01, sample_rate: 10000}
integrator: {method: rk4, step: 1.0e-5}
"""


@pytest.mark.parametrize("gravity", [[0.0, -9.81], [0.0, 0.0]])
def test_run_writes_a_study_where_no_centre_of_mass_moves_in_the_ideal_twin(tmp_path, gravity):
    """A balanced rotor in a bearing housing: in the ideal twin no centre of mass moves. Under
    gravity the housing drops into its clearance and rattles, so the acceleration figure shows
    what moves with clearance; without gravity nothing moves at all, and the figure is left
    out. Either way `rrr4 run` writes its results (it ended in ZeroDivisionError)."""
    from rrr4.cli import main
    data = yaml.safe_load(ROTOR)
    data["effects"]["gravity"] = gravity
    path = tmp_path / "rotor.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 0
    summary = yaml.safe_load((out / "summary.json").read_text())
    dev = summary["with_clearance"]["acceleration_deviation_max_m_s2"]
    assert max(summary["ideal"]["body_acceleration_peak_m_s2"].values()) < 1e-9
    if gravity[1]:
        assert dev["housing"] > 1.0 and (out / "accelerations.png").exists()
    else:
        assert max(dev.values()) < 1e-9 and not (out / "accelerations.png").exists()
    assert (out / "report.md").exists() and (out / "contact_force.png").exists()


def test_driven_figures_start_at_the_drivers_initial_angle(tmp_path):
    """The x axis of a driven scene's figures is the driver's angle from initial_deg: a short
    run spans [initial, initial + travel], a run of 3 or more revolutions the two after the first."""
    from rrr4.results.figures.study import driver_window
    from rrr4.studies.study import run_study
    scene = parse_scene(yaml.safe_load(ROTOR))
    study = run_study(scene, t_end=0.01)
    x_of, label, (lo, hi) = driver_window(study)
    x = x_of(study.arms["ideal"].simulation)
    assert label == "motor angle [deg]" and x[0] == pytest.approx(90.0) and lo == pytest.approx(90.0)
    assert hi == pytest.approx(x[-1]) == pytest.approx(90.0 + 360.0 * 600 / 60 * 0.01)
    long = dataclasses.replace(study, t_end=0.3)  # 3 revolutions at 600 rpm
    assert driver_window(long)[2] == pytest.approx((450.0, 1170.0))


FIVE_BAR = ROOT / "problems" / "redundant_five_bar.yaml"


def test_point_task_five_bar_ik_equals_the_closed_form_of_each_chain():
    """Task = a point of a body (2 DOF): Newton IK of the graph against the closed-form
    two-link IK of each chain (circle intersection, the elbow side of the pose guesses)."""
    scene = rrr4.load_scene(FIVE_BAR)
    mech = Mechanism.from_scene(scene)
    assert mech.n_task == 2 and Model.of(scene.graph).redundancy == 1
    bases = [np.array(scene.graph.joint(f"A{i}").points[0]) for i in (1, 2, 3)]
    for p in ([0.02, 0.0], [-0.01, 0.015], [0.0, -0.02]):
        d = [np.asarray(p) - a for a in bases]
        # l1 = l2 = 0.25 m: cos of the angle at the base = (l1^2 + r^2 - l2^2) / (2 l1 r) = r / (2 l1)
        want = [np.arctan2(v[1], v[0]) + np.arccos(np.linalg.norm(v) / (2 * 0.25)) for v in d]
        np.testing.assert_allclose(np.angle(np.exp(1j * (mech.ik(p) - want))), 0.0, atol=1e-10)
        J = mech.jacobian(p)
        assert J.shape == (3, 2) and np.linalg.norm(J.T @ mech.null_space(p)) < 1e-12


def test_point_task_five_bar_preload_holds_every_passive_joint():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = solve_preload(rrr4.load_scene(FIVE_BAR), sample_rate=100)
    assert sol.all_feasible and sol.joint_names == ("B1", "B2", "B3", "C1", "C2")
    assert np.min(np.linalg.norm(sol.reactions, axis=2)) >= sol.f_min * (1 - 1e-6)


def test_two_redundant_effort_basis_is_continuous_along_the_path():
    """Redundancy 2: the null-space basis of each sample is rotated onto the previous one, so
    alpha means the same along the path (the subspace turns slowly; the basis must too)."""
    from rrr4.trajectory import sample_path
    scene = check_scene(parse_scene(_five_chain_graph()))
    s = sample_path(scene.path, 100)
    fam = build(scene).effort_family(s.pose, s.pose_d, s.pose_dd)
    N = fam.tau_n
    turn = np.linalg.norm(np.einsum("kim,kil->kml", N[1:], N[:-1]) - np.eye(2), axis=(1, 2))
    assert turn.max() < 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = solve_preload(scene, method="qp", sample_rate=100)
    assert np.max(np.abs(np.diff(sol.tau, axis=0))) < 10.0


def test_duplicate_names_and_too_few_actuators_are_refused(slider_data):
    d = yaml.safe_load(FIVE_BAR.read_text())
    d["mechanism"]["actuators"][1]["name"] = "A1"
    with pytest.raises(SceneError, match=r"actuators\[1\]\.name: 'A1' is not allowed \(already the name of"):
        parse_scene(d)
    d = yaml.safe_load(FIVE_BAR.read_text())
    d["mechanism"]["actuators"] = d["mechanism"]["actuators"][:1]
    with pytest.raises(SceneError, match=r"actuation.mode: 'torque' is not allowed with 1 actuator\(s\) for a task "
                                         r"of 2 degrees of freedom"):
        parse_scene(d)


def test_seated_journal_on_a_driven_scene_starts_on_the_wall(slider_data):
    d = copy.deepcopy(slider_data)
    d["initial"] = {"journals": "seated"}
    sim = simulate(check_scene(parse_scene(d)), step=1e-6, t_end=1e-4)
    assert sim.penetration[0, 0] > 0 and np.linalg.norm(sim.eccentricity[0, 0]) > 0.5e-3
