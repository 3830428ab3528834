"""The equation builder: exactly the effects a scene asks for, consistent forms, and the
clearance model converging to the ideal one."""

import dataclasses
import types

import casadi as ca
import numpy as np
import pytest

from rrr4 import SceneError, build, load_scene, simulate
from rrr4.mechanism import Mechanism
from rrr4.trajectory import sample_path

from .conftest import ROOT

CONSERVATIVE = ROOT / "problems" / "conservative_free.yaml"


def _ops(f: ca.Function) -> set:
    return {f.instruction_id(k) for k in range(f.n_instructions())}


def _with(scene, clearance=None, friction=None, mode=None, restitution=None, radial_clearance=None):
    joints = scene.joints
    if clearance is not None:
        joints = tuple(dataclasses.replace(j, clearance=j.name in clearance) for j in joints)
    if radial_clearance is not None:
        joints = tuple(dataclasses.replace(j, radial_clearance=radial_clearance) for j in joints)
    eff = scene.effects
    if friction is not None:
        eff = dataclasses.replace(eff, friction=dataclasses.replace(eff.friction, law=friction))
    if restitution is not None:
        eff = dataclasses.replace(eff, contact=dataclasses.replace(eff.contact, restitution=restitution))
    act = scene.actuation if mode is None else dataclasses.replace(scene.actuation, mode=mode)
    return dataclasses.replace(scene.with_joints(joints), effects=eff, actuation=act)


def test_frictionless_scene_has_no_friction_term_in_its_graph(paper_scene):
    with_f = build(paper_scene).equations().acceleration
    without = build(_with(paper_scene, friction="none")).equations().acceleration
    assert ca.OP_SIGN in _ops(with_f)
    assert not _ops(without) & {ca.OP_SIGN, ca.OP_TANH, ca.OP_EXP}
    assert without.n_instructions() < with_f.n_instructions()
    assert not any(any(without.which_depends(name, ["power_friction", "friction_force"], 1, False))
                   for name in ("q", "qd"))


def test_all_ideal_scene_has_no_contact_code(paper_scene):
    eqs = build(_with(paper_scene, clearance=(), mode="free")).equations()
    f = eqs.acceleration
    assert not _ops(f) & {ca.OP_FMAX, ca.OP_IF_ELSE_ZERO}   # no clamped law, no onset switch
    assert f.size_in("delta_dot0") == (0, 1) and f.size_out("contact_force") == (2, 0)
    assert eqs.n_constraints == 24 and "contact" not in " ".join(eqs.terms)
    partial = build(_with(paper_scene, clearance=("B2", "C4"), mode="free")).equations()
    assert partial.n_constraints == 8 + 2 * 6 and partial.clearance_joints == ("B2", "C4")
    assert {ca.OP_FMAX, ca.OP_IF_ELSE_ZERO} <= _ops(partial.acceleration)


def test_each_mode_depends_on_its_own_inputs(paper_scene):
    """free: no effort, no references; torque: the controller's efforts only (the controller,
    not the equations, holds the references); prescribed: the references only."""
    free = build(load_scene(CONSERVATIVE)).equations().acceleration
    torque = build(paper_scene).equations().acceleration
    prescribed = build(_with(paper_scene, mode="prescribed")).equations().acceleration
    refs = ("theta_ref", "theta_d_ref", "theta_dd_ref")
    for name in ("effort", *refs):
        assert not any(free.which_depends(name, ["qdd"], 1, False))
    assert all(torque.which_depends("effort", ["qdd"], 1, False))
    assert not any(prescribed.which_depends("effort", ["qdd"], 1, False))
    for name in refs:
        assert not any(torque.which_depends(name, ["qdd"], 1, False))
        assert any(prescribed.which_depends(name, ["qdd"], 1, False))


def test_feedback_clips_at_the_actuator_limit_and_wraps_the_angle_error(paper_scene):
    from rrr4.control import feedback_function
    f = feedback_function(build(paper_scene))
    th = np.array([0.1, 0.2, 0.3, 0.4])
    tau = np.array(f(th + 2 * np.pi * np.array([1, -1, 0, 2]), np.zeros(4), [100.0, -100.0, 1.0, 0.0], th,
                     np.zeros(4))).ravel()
    np.testing.assert_allclose(tau, [5.0, -5.0, 1.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("mode, clearance", [("torque", ("B1", "C3")), ("prescribed", ("B1", "B2", "C3")),
                                             ("torque", ())])
def test_index1_form_satisfies_the_residual_form(paper_scene, mode, clearance):
    scene = _with(paper_scene, clearance=clearance, mode=mode)
    eqs = build(scene).equations()
    mech = Mechanism.from_scene(scene)
    rng = np.random.default_rng(3)
    q, qd, _ = mech.body_motion([0.01, 0.005, 0.05], [0.1, -0.2, 0.5])
    q = q + rng.normal(0, 3e-5, q.shape)
    args = dict(effort=rng.normal(0, 1, 4), theta_ref=mech.ik([0.01, 0.005, 0.05]) + 1e-3,
                theta_d_ref=rng.normal(0, 1, 4), theta_dd_ref=rng.normal(0, 1, 4),
                delta_dot0=np.full(len(clearance), 0.1), in_contact=np.ones(len(clearance)))
    out = eqs.acceleration(q=q, qd=qd, **args)
    res = eqs.residual(q=q, qd=qd, qdd=out["qdd"], **{"lambda": out["lambda"]}, **args)
    scale = np.max(np.abs(np.array(out["qdd"])))
    assert np.max(np.abs(np.array(res["dynamics"]))) < 1e-9 * max(scale, 1.0)
    assert np.max(np.abs(np.array(res["constraint"]))) < 1e-9 * max(scale, 1.0)
    if mode == "prescribed":   # the actuator torque is the driving constraints' reaction
        np.testing.assert_allclose(np.array(out["tau"]).ravel(), -np.array(out["lambda"]).ravel()[-4:])


def test_prescribed_mode_on_an_all_ideal_redundant_mechanism_is_refused(paper_scene):
    with pytest.raises(SceneError, match="actuation.mode"):
        build(_with(paper_scene, clearance=(), mode="prescribed")).equations()


def test_prescribed_actuator_angles_are_followed(paper_scene):
    scene = _with(paper_scene, mode="prescribed", friction="none")
    r = simulate(scene, integrator="rk4", step=1e-5, t_end=0.02)
    mech = Mechanism.from_scene(scene)
    theta = r.q[:, [6 * i + 2 for i in range(4)]]
    theta_ref = np.array([mech.ik(p) for p in r.pose_ref])
    assert np.max(np.abs(theta - theta_ref)) < 1e-8
    assert r.platform_error.max() < 2e-4     # within the clearances of the chains


def test_clearance_model_converges_to_the_ideal_model(paper_scene):
    """Clearance 100 -> 10 -> 1 um (stiffness grows as sqrt(1/c)) under a constant preload
    alpha = 3 N m: platform motion and the contact forces (averaged over 20-40 ms, after the
    start-up impacts) approach the ideal model's platform motion and joint reactions."""
    base = _with(paper_scene, friction="none", restitution=0.3)
    ps = sample_path(base.path)
    tau_p, tau_n, _, _ = build(base).inverse_dynamics().map(len(ps.t))(ps.pose.T, ps.pose_d.T, ps.pose_dd.T)
    preload = types.SimpleNamespace(t=ps.t, tau=(np.array(tau_p) + 3.0 * np.array(tau_n)).T)
    ideal = simulate(_with(base, clearance=()), integrator="rk4", step=1e-5, t_end=0.04, preload=preload)
    late = ideal.t >= 0.02
    r_ideal = ideal.reaction[late].mean(axis=0)
    assert np.linalg.norm(r_ideal, axis=1).min() > 4.0      # every joint loaded
    pos_err, force_err = [], []
    for c in (1e-4, 1e-5, 1e-6):
        r = simulate(_with(base, radial_clearance=c), integrator="rk4", step=2e-6, t_end=0.04, preload=preload)
        pos_err.append(np.max(np.linalg.norm(r.pose[late, :2] - ideal.pose[late, :2], axis=1)))
        force_err.append(np.max(np.linalg.norm(r.contact_force[late].mean(axis=0) - r_ideal, axis=1)))
    assert pos_err[0] > pos_err[1] > pos_err[2] and pos_err[2] < 1e-7
    assert force_err[0] > force_err[1] > force_err[2]
    assert force_err[2] < 0.05 * np.linalg.norm(r_ideal, axis=1).min()


def test_changing_only_the_integrator_or_path_rate_does_not_rebuild_the_equations(paper_scene):
    """The parametric equations and the ODE systems built on them are cached on the Problem
    of the plant's structure (Problem.plant_key), shared by every problem of that structure;
    the frame Functions are owned by the system (no module-level caches keyed by id)."""
    a = build(paper_scene)
    other = dataclasses.replace(paper_scene, name="renamed",
                                integrator=dataclasses.replace(paper_scene.integrator, step=2e-5),
                                path=dataclasses.replace(paper_scene.path, sample_rate=500.0))
    b = build(other)
    assert b is not a and b.structure("plant") is a.structure("plant")
    assert b.equations().parametric is a.equations().parametric
    simulate(other, t_end=2e-3)
    systems = a.structure("plant").memoized("system")
    assert any(k[2] == 2e-5 for system in systems for k in system.frames)
    assert build(_with(paper_scene, friction="none")).equations().parametric is not a.equations().parametric


def test_sampled_references_interpolate_the_exact_ones_and_cut_the_right_hand_side(paper_scene):
    """references='sampled': the controller's references (IK, feed-forward with preload) once
    per 1 kHz path sample, cubic Hermite in the right-hand side. Against the closed-form
    controller at 20 kHz over the whole path: theta_ref within 1e-10 rad, tau_ff within
    1e-8 N m at most instants (the QP preload's active-set switches are kinks a cubic
    cannot follow: there up to 2e-3 N m); the motion of the continuous controller within
    1e-9 m; the ODE smaller."""
    from dataclasses import replace

    from rrr4.control import controller_function, path_rows, tabulated
    scene = replace(paper_scene, actuation=replace(paper_scene.actuation, control_rate=None))
    f = controller_function(build(scene))
    t = np.linspace(0.0, scene.path.duration, 20001)
    rows = path_rows((scene).path, t)
    z = np.zeros((4, len(t)))
    _, tau, th, _, _, _ = (np.array(v).T for v in f.map(len(t))(*(rows[:, 3 * k:3 * k + 3].T for k in range(3)), z, z))
    tab = tabulated(build(scene), np.linspace(0.0, scene.path.duration, 1001), None)
    from scipy.interpolate import CubicHermiteSpline, CubicSpline
    assert np.max(np.abs(CubicHermiteSpline(tab.t, tab.theta_ref, tab.theta_d_ref, axis=0)(t) - th)) < 1e-10
    err = np.max(np.abs(CubicSpline(tab.t, tab.tau_ff, axis=0)(t) - tau), axis=1)
    assert np.median(err) < 1e-8 and np.max(err) < 2e-3
    a = simulate(scene, t_end=0.1)
    b = simulate(scene, t_end=0.1, references="sampled")
    assert np.max(np.abs(a.pose - b.pose)) < 1e-9
    assert b.stats["graph"]["ode"]["instructions"] < a.stats["graph"]["ode"]["instructions"]
    with pytest.raises(SceneError, match="references: unknown value 'sampeld'"):
        simulate(paper_scene, t_end=0.01, references="sampeld")


def test_scenes_that_differ_only_in_contact_numbers_share_their_compiled_code(paper_scene, tmp_path, monkeypatch):
    """Clearance, stiffness, restitution and friction coefficients enter the equations as an
    input (the contact parameters), and gains, torque limits and f_min the controller step
    (its settings), both carried in the discrete state, so a second clearance and preload
    level steps with the first one's compiled code: no new compilation, and a different
    motion (the journals sit deeper in a larger bearing)."""
    from rrr4.codegen.build import compilations
    from rrr4.control import controller_settings, parametric_controller
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    # a Newton tolerance of its own: no other test compiles (and loads) this stepping
    paper_scene = dataclasses.replace(paper_scene, integrator=dataclasses.replace(paper_scene.integrator,
                                                                                  newton_tol=1.2345e-7))
    other = _with(paper_scene, radial_clearance=2e-4)
    other = dataclasses.replace(other, effects=dataclasses.replace(other.effects, contact=dataclasses.replace(
        other.effects.contact, restitution=0.5), friction=dataclasses.replace(other.effects.friction,
                                                                             coefficient=0.2)))
    other = other.with_torque_limit([2 * v for v in other.torque_limit])
    act = other.actuation
    other = dataclasses.replace(other, actuation=dataclasses.replace(
        act, kp=1.5 * act.kp, kd=0.5 * act.kd,
        preload=dataclasses.replace(act.preload, min_force=2 * act.preload.min_force)))
    assert build(other).equations().parametric is build(paper_scene).equations().parametric
    assert parametric_controller(build(other)) is parametric_controller(build(paper_scene))
    changed = controller_settings(build(other)) != controller_settings(build(paper_scene))
    assert np.sum(changed) == 7  # kp, kd, 4 limits, f_min
    assert not np.array_equal(build(other).contact_parameters, build(paper_scene).contact_parameters)
    n0 = compilations()
    a = simulate(paper_scene, t_end=0.01, jit=True)
    n1 = compilations()
    b = simulate(other, t_end=0.01, jit=True)
    assert n1 > n0 and compilations() == n1
    assert np.max(np.linalg.norm(b.eccentricity[-1], axis=1)) > 1.5e-4 > np.max(np.linalg.norm(a.eccentricity[-1],
                                                                                                  axis=1))
    vm = simulate(other, t_end=0.01, jit=False)
    assert np.max(np.abs(vm.q - b.q)) < 1e-12


def test_with_geometry_inputs_scenes_that_differ_in_masses_and_geometry_share_their_compiled_code(tmp_path,
                                                                                                  monkeypatch):
    """inputs='geometry': masses, inertias and joint points are inputs of the equations too,
    and with references='sampled' the closed-form controller runs per case in Python, so a
    mechanism with a base moved by 50 um, a driving link 20 um longer and a heavier platform
    steps with the first one's compiled code. Its motion equals that of its own equations with
    the geometry folded in as constants (the default), to rounding."""
    import yaml

    from rrr4.codegen.build import compilations
    from rrr4.scene import parse_scene
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    data = yaml.safe_load((ROOT / "problems" / "paper_circle.yaml").read_text())
    data["integrator"] = {**data.get("integrator", {}), "newton_tol": 1.2346e-7}  # no other test compiles this
    nominal = parse_scene(data, name="nominal")
    chains = data["mechanism"]["chains"]
    chains[0]["base"] = [-0.3 + 5e-5, -0.3]
    chains[2]["driving_link"] = {"length": 0.25 + 2e-5, "mass": 0.40}
    data["mechanism"]["platform"]["mass"] = 0.88
    other = parse_scene(data, name="other")
    opts = {"t_end": 0.01, "inputs": "geometry", "references": "sampled"}
    shared = build(nominal).equations(inputs="geometry").parametric
    assert build(other).equations(inputs="geometry").parametric is shared
    n0 = compilations()
    a = simulate(nominal, jit=True, **opts)
    n1 = compilations()
    b = simulate(other, jit=True, **opts)
    assert n1 > n0 and compilations() == n1
    assert np.max(np.abs(b.q - a.q)) > 1e-5  # the first driving link sits on another base
    folded = simulate(other, jit=False, t_end=0.01, references="sampled")
    assert np.max(np.abs(folded.q - b.q)) < 1e-11
    with pytest.raises(SceneError, match="inputs: unknown value 'mass'"):
        simulate(nominal, t_end=0.01, inputs="mass")


def test_a_mechanism_without_actuators_builds_in_every_mode():
    """A driven scene has no actuators: its equations build in every mode, tree coordinates
    included (the reader refuses 'prescribed' without a task; the builder must not crash on
    it: it did, on the empty effort's power)."""
    from rrr4.dynamics.builder import parametric_equations
    scene = load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    problem = build(scene)
    for mode in ("free", "torque", "prescribed"):
        eqs = parametric_equations(problem.model, scene.effects, mode, forces=scene.forces)
        assert eqs.tree_acceleration is not None
        assert "power_in" in eqs.tree_acceleration.name_out()
