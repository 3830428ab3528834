"""Force elements (``forces:``): spring-dampers, rotational spring-dampers and loads against
closed forms (the damped oscillator of Exudyn's spring-damper example), the energy audit with
springs, dampers and loads, the equations without them unchanged, the controller's model with
a process load, and one-line errors for bad elements."""

import copy
import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import yaml

import rrr4
from rrr4 import SceneError, build, check_scene, simulate
from rrr4.dynamics.elements import ELEMENT_TERMS
from rrr4.scene import parse_scene, set_key
from rrr4.scene.vocabulary import FORCE_ELEMENTS

from .conftest import ROOT

PROCESS = ROOT / "problems" / "process_load_circle.yaml"
M_CARRIAGE, M_MASS = 1.5, 0.5  # [kg]: the x motion moves both


def oscillator(forces, duration=1.0, step=1e-3, method="rk4", rate=1000.0) -> dict:
    """A point mass on two prismatic joints (x: carriage on the ground, y: mass on the
    carriage), free actuators, at rest at x = 0.1 m; `forces` the scene's list."""
    return {
        "name": "oscillator",
        "mechanism": {
            "kind": "graph",
            "bodies": [{"name": "carriage", "mass": M_CARRIAGE, "inertia": 0.01, "pose": [0.1, 0.0, 0.0]},
                       {"name": "mass", "mass": M_MASS, "inertia": 0.01, "pose": [0.1, 0.0, 0.0],
                        "points": {"tip": [0.0, 0.0]}}],
            "joints": [{"name": "x", "type": "prismatic", "bodies": ["ground", "carriage"], "axis": [1, 0]},
                       {"name": "y", "type": "prismatic", "bodies": ["carriage", "mass"], "axis": [0, 1]}],
            "actuators": [{"joint": "x", "limit": 100}, {"joint": "y", "limit": 100}],
            "task": {"body": "mass", "point": [0, 0]},
        },
        "actuation": {"mode": "free"},
        "forces": forces,
        "path": {"type": "line", "start": [0.1, 0.0, 0.0], "end": [0.1, 0.0, 0.0], "duration": duration,
                 "sample_rate": rate},
        "integrator": {"method": method, "step": step},
    }


def rotor(forces, duration=1.0, step=1e-3) -> dict:
    """A disc (centre of mass on its pivot, inertia 0.02 kg m^2) on a revolute joint of a
    carriage on a prismatic joint; the task point sits 0.05 m off the pivot; at rest at angle 0."""
    return {
        "name": "rotor",
        "mechanism": {
            "kind": "graph",
            "bodies": [{"name": "carriage", "mass": 1.0, "inertia": 0.01, "pose": [0.0, 0.0, 0.0]},
                       {"name": "disc", "mass": 0.5, "inertia": 0.02, "pose": [0.0, 0.0, 0.0]}],
            "joints": [{"name": "x", "type": "prismatic", "bodies": ["ground", "carriage"], "axis": [1, 0]},
                       {"name": "r", "bodies": ["carriage", "disc"]}],
            "actuators": [{"joint": "x", "limit": 100}, {"joint": "r", "limit": 100}],
            "task": {"body": "disc", "point": [0.05, 0.0]},
        },
        "actuation": {"mode": "free"},
        "forces": forces,
        "path": {"type": "line", "start": [0.05, 0.0, 0.0], "end": [0.05, 0.0, 0.0], "duration": duration,
                 "sample_rate": 1000},
        "integrator": {"method": "rk4", "step": step},
    }


def damped(t, x0, x_eq, m, k, c):
    """Closed form of m x'' + c x' + k (x - x_eq) = 0 from rest at x0 (underdamped)."""
    w0 = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = w0 * np.sqrt(1 - z * z)
    return x_eq + (x0 - x_eq) * np.exp(-z * w0 * t) * (np.cos(wd * t) + z * w0 / wd * np.sin(wd * t))


SPRING = {"type": "spring_damper", "name": "spring", "bodies": ["ground", "mass"], "points": [[-0.4, 0.0], "tip"],
          "stiffness": 200.0, "damping": 2.0, "free_length": 0.4}
SPRING_SCENE = parse_scene(oscillator([SPRING]))


def test_the_registry_holds_exactly_the_vocabulary():
    assert tuple(ELEMENT_TERMS) == FORCE_ELEMENTS


def test_spring_damper_follows_the_damped_oscillation_and_converges_at_fourth_order():
    """x(t) of a mass (2 kg in x) on a spring-damper (k = 200 N/m, c = 2 N s/m: omega_0 = 10
    rad/s, zeta = 0.05) from 0.1 m against the closed form over 1 s (1.6 periods, amplitude
    down to 61 %): the RK4 error falls 16-fold per halved step (measured 7.1e-6 m at h = 20 ms,
    4.4e-7 at 10 ms, 2.7e-8 at 5 ms)."""
    errors = []
    for h in (0.02, 0.01, 0.005):
        r = simulate(parse_scene(oscillator([SPRING], step=h, rate=50.0)))
        x = r.body("mass")[:, 0]
        errors.append(np.max(np.abs(x - damped(r.t, 0.1, 0.0, M_CARRIAGE + M_MASS, 200.0, 2.0))))
        assert np.all(np.abs(r.body("mass")[:, 1]) < 1e-12)  # the spring along x leaves y at rest
    assert errors[-1] < 5e-8
    assert errors[0] / errors[1] > 12 and errors[1] / errors[2] > 12
    # the decay and the period are the closed form's: the amplitude has fallen to exp(-zeta w0 t)
    assert np.min(x) == pytest.approx(np.min(damped(r.t, 0.1, 0.0, 2.0, 200.0, 2.0)), abs=1e-8)


def test_bathe_converges_at_second_order_on_the_spring_damper():
    """Measured: 3.5e-5 m at h = 4 ms, 8.8e-6 at 2 ms (ratio 4.0)."""
    errors = []
    for h in (4e-3, 2e-3):
        r = simulate(parse_scene(oscillator([SPRING], step=h, method="bathe", rate=250.0)))
        errors.append(np.max(np.abs(r.body("mass")[:, 0] - damped(r.t, 0.1, 0.0, 2.0, 200.0, 2.0))))
    assert errors[1] < 1e-5
    assert 3.5 < errors[0] / errors[1] < 4.5


def test_rotational_spring_damper_on_a_joint_follows_the_damped_oscillation():
    """A disc (I = 0.02 kg m^2) on a revolute joint with a rotational spring-damper (0.5 N m/rad,
    0.004 N m s/rad, free angle 0.2 rad) from angle 0: the closed form to RK4 error; the
    carriage does not move (the disc turns about its centre of mass)."""
    spring = {"type": "rotational_spring_damper", "joint": "r", "stiffness": 0.5, "damping": 0.004,
              "free_angle": 0.2}
    r = simulate(parse_scene(rotor([spring], step=2e-3)))
    phi = r.body("disc")[:, 2]
    assert np.max(np.abs(phi - damped(r.t, 0.0, 0.2, 0.02, 0.5, 0.004))) < 1e-7
    assert np.max(np.abs(r.body("carriage")[:, 0])) < 1e-12


def test_constant_load_deflects_the_spring_by_f_over_k():
    """A 10 N load along x on the mass, spring k = 200 N/m critically damped... nearly
    (zeta = 0.9) over 3 s: the mass settles at free position + F/k = 0.05 m (to 1e-9 m), and
    the free length left out is the initial distance (so the start is the spring's rest)."""
    spring = {k: v for k, v in SPRING.items() if k != "free_length"} | {"damping": 36.0}
    load = {"type": "load", "body": "mass", "force": [10.0, 0.0]}
    scene = parse_scene(oscillator([spring, load], duration=3.0, step=2e-3))
    problem = build(scene)
    assert problem.force_parameters[2] == pytest.approx(0.5)  # |(0.1, 0) - (-0.4, 0)|
    r = simulate(scene)
    x = r.body("mass")[:, 0]
    assert x[-1] == pytest.approx(0.1 + 10.0 / 200.0, abs=1e-9)
    assert np.max(np.abs(x - damped(r.t, 0.1, 0.15, 2.0, 200.0, 36.0))) < 1e-8


def test_energy_audit_counts_spring_energy_damper_dissipation_and_the_work_of_loads(tmp_path):
    """A spring with preload, a damper, a constant force and torque in the body frame and a
    tabulated load: W_in (the loads' work) - dE - D closes to the integrator's error (RK4 at
    1 ms, measured 4.9e-10 relative, set by the table's kinks; 2e-14 with constant loads only),
    the damper's dissipation is positive and growing, and the
    potential at t = 0 is the spring's k (L - L0)^2 / 2 + F0 (L - L0)."""
    table = tmp_path / "push.csv"
    table.write_text("t,fx,fy,tz\n0.0,0.0,0.0,0.0\n0.3,5.0,-2.0,0.1\n0.6,-3.0,0.0,0.0\n")
    spring = SPRING | {"free_length": 0.45, "preload": 1.5}
    loads = [{"type": "load", "body": "mass", "force": [2.0, 1.0], "torque": 0.3, "frame": "body"},
             {"type": "load", "body": "carriage", "table": "push.csv"}]
    data = oscillator([spring, *loads], step=1e-3)
    scene = parse_scene(data, source=str(tmp_path / "oscillator.yaml"))
    r = simulate(scene)
    e = r.energy
    assert e["potential"][0] == pytest.approx(0.5 * 200.0 * 0.05**2 + 1.5 * 0.05, rel=1e-12)
    assert e["dissipated_damping"][-1] > 1e-3 and np.all(np.diff(e["dissipated_damping"]) >= -1e-15)
    assert np.max(np.abs(e["work_in"])) > 1e-2
    assert r.energy_audit_residual < 1e-8


def test_tabulated_load_is_interpolated_linearly_and_held_outside_its_rows(tmp_path):
    table = tmp_path / "push.csv"
    table.write_text("t,fx,fy,tz\n0.2,4.0,0.0,0.0\n0.4,8.0,0.0,0.0\n")
    scene = parse_scene(oscillator([{"type": "load", "body": "carriage", "table": "push.csv"}]),
                        source=str(tmp_path / "oscillator.yaml"))
    eqs = build(scene).equations()
    q = np.array([0.1, 0.0, 0.0, 0.1, 0.0, 0.0])
    for t, fx in ((0.0, 4.0), (0.2, 4.0), (0.3, 6.0), (0.35, 7.0), (0.4, 8.0), (2.0, 8.0)):
        out = eqs.acceleration(q=q, qd=np.zeros(6), t=t)
        assert float(out["qdd"][0]) == pytest.approx(fx / (M_CARRIAGE + M_MASS), rel=1e-12)


def test_a_scene_without_forces_builds_the_same_equations(paper_scene):
    """No force term, no force numbers among the inputs, and a zero load, which adds the
    force code, changes no output at random states."""
    plain = build(paper_scene)
    eqs = plain.equations()
    assert not any("force elements" in t for t in eqs.terms)
    assert plain.force_parameters.size == 0 and eqs.parameters.size == plain.contact_parameters.size
    zero = replace(paper_scene, forces=parse_scene(oscillator([{"type": "load", "body": "mass", "force": [0.0, 0.0]}
                                                               ])).forces)
    zero = replace(zero, forces=(replace(zero.forces[0], bodies=("platform",)),))
    with_zero = build(zero).equations()
    assert any("force elements" in t for t in with_zero.terms)
    rng = np.random.default_rng(3)
    q0 = plain.start_coordinates
    for _ in range(3):
        args = dict(q=q0 + 1e-5 * rng.standard_normal(q0.size), qd=rng.standard_normal(q0.size),
                    effort=rng.standard_normal(4), delta_dot0=np.full(8, 1e-3), in_contact=np.ones(8), t=0.1)
        a, b = eqs.acceleration(**args), with_zero.acceleration(**args)
        for k in ("qdd", "lambda", "contact_force", "power_in", "power_damping"):
            np.testing.assert_allclose(np.array(b[k]), np.array(a[k]), rtol=1e-12, atol=1e-12)


def test_force_numbers_are_inputs_so_scenes_differing_in_them_share_the_equations():
    a = build(parse_scene(oscillator([SPRING])))
    b = build(parse_scene(oscillator([SPRING | {"stiffness": 300.0, "damping": 0.5}])))
    assert a.plant_key == b.plant_key
    assert a.equations().parametric is b.equations().parametric
    assert b.force_parameters[:2].tolist() == [300.0, 0.5]


def test_the_controller_is_shared_unless_it_balances_the_load(paper_scene):
    """An n-RRR's controller step depends only on the known constant loads on the platform:
    an unknown load, or a spring, leaves it that of the scene without forces; a known load
    makes it another (with the load folded in)."""
    process = rrr4.load_scene(PROCESS)
    unknown = replace(process, forces=tuple(replace(e, known=False) for e in process.forces))
    spring = replace(process, forces=(replace(SPRING_SCENE.forces[0], bodies=("ground", "platform"),
                                              points=((-0.3, 0.0), (0.0, 0.0))),))
    plain = build(replace(process, forces=()))
    assert build(unknown).controller_key == plain.controller_key == build(spring).controller_key
    assert build(process).controller_key != plain.controller_key
    assert build(unknown).plant_key == build(process).plant_key


def test_the_effort_family_balances_a_process_load_closed_form_and_graph_agree():
    """At rest, the efforts' wrench on the platform J^T (tau_p(load) - tau_p(no load)) is minus
    the load's (a 10 N force at a point 0.03 m off the centre, a 0.2 N m torque), in the
    closed-form n-RRR family; the graph form of the same mechanism (SVD) gives the same
    family."""
    scene = rrr4.load_scene(PROCESS)
    load = replace(scene.forces[0], force=(-10.0, 4.0), torque=0.2, points=((0.03, 0.0),))
    loaded, free = build(replace(scene, forces=(load,))), build(replace(scene, forces=()))
    pose = np.array([[-0.01, 0.005, 0.05]])
    zero = np.zeros((1, 3))
    d_tau = loaded.effort_family(pose, zero, zero).tau_p[0] - free.effort_family(pose, zero, zero).tau_p[0]
    J = free.mechanism.jacobian(pose[0])
    c, s = np.cos(0.05), np.sin(0.05)
    arm = np.array([c * 0.03, s * 0.03])
    moment = arm[0] * 4.0 - arm[1] * -10.0 + 0.2
    np.testing.assert_allclose(J.T @ d_tau, -np.array([-10.0, 4.0, moment]), atol=1e-10)
    graph = rrr4.load_scene(ROOT / "problems" / "paper_circle_graph.yaml")
    g = build(replace(graph, forces=(load,)))
    fam_g, fam_c = g.effort_family(pose, zero, zero), loaded.effort_family(pose, zero, zero)
    np.testing.assert_allclose(fam_g.tau_p, fam_c.tau_p, atol=1e-9)
    np.testing.assert_allclose(np.abs(fam_g.tau_n), np.abs(fam_c.tau_n), atol=1e-9)


def test_a_known_process_load_keeps_the_preload_and_an_unknown_one_is_met_by_feedback_only():
    """process_load_circle (10 N against x on the platform): known to the controller, the
    preload holds every journal with about f_min (smallest normal force > 8 N, no loss) and
    the error stays that of the reference scene (< 50 um RMS); unknown, the preload is planned
    for the unloaded mechanism, the smallest normal force falls below 5 N and the error grows
    to millimetres (the PD's kp = 200 N m/rad against 2.5 N m)."""
    scene = rrr4.load_scene(PROCESS)
    known = simulate(scene)
    unknown = simulate(replace(scene, forces=tuple(replace(e, known=False) for e in scene.forces)))
    assert sum(known.contact_loss_events.values()) == 0
    assert known.normal_force.min() > 8.0 and unknown.normal_force.min() < 5.0
    assert np.sqrt(np.mean(known.platform_error**2)) < 50e-6 < 1e-3 < np.sqrt(np.mean(unknown.platform_error**2))
    assert known.energy_audit_residual < 1e-4  # measured 7.6e-6, the reference scene 9.0e-6


def test_dotted_keys_reach_the_elements_numbers(paper_data):
    data = yaml.safe_load(PROCESS.read_text())
    set_key(data, "forces[0].force[0]", -4.0)
    assert parse_scene(data).forces[0].force == (-4.0, 0.0)


BAD = [
    ("forces", {"a": 1}, "forces:"),
    ("forces[0].type", "spring", "forces[0].type: unknown value 'spring'"),
    ("forces[0].body", "tool", "forces[0].body: unknown body 'tool'"),
    ("forces[0].point", "tip", "forces[0].point: unknown point of platform 'tip'"),
    ("forces[0].frame", "world", "forces[0].frame: unknown value 'world'"),
    ("forces[0].force", [1.0], "forces[0].force:"),
    ("forces[0].known", "yes", "forces[0].known: 'yes' is not allowed"),
    ("forces[0].stiffness", 5.0, "forces[0].stiffness: not used by type 'load'"),
    ("forces[0].table", "missing.csv", "forces[0].force: not allowed with table"),
]


@pytest.mark.parametrize("key,value,start", BAD, ids=[b[0] + "=" + repr(b[1]) for b in BAD])
def test_bad_force_elements_are_refused_in_one_line_naming_the_key(key, value, start):
    data = yaml.safe_load(PROCESS.read_text())
    set_key(data, key, value)
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(data))
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(start), msg


SPRING_BAD = [
    ({"stiffness": -1.0}, "forces[0].stiffness: -1 is not allowed"),
    ({"bodies": ["ground", "disc"]}, "forces[0].bodies: unknown body 'disc'"),
    ({"bodies": ["mass", "mass"]}, "forces[0].bodies: ['mass', 'mass'] is not allowed"),
    ({"points": [[0, 0], "nose"]}, "forces[0].points[1]: unknown point of mass 'nose'"),
    ({"free_length": -0.1}, "forces[0].free_length: -0.1 is not allowed"),
    ({"stiffness": 0.0, "damping": 0.0}, "forces[0].stiffness: 0 is not allowed together"),
    ({"joint": "x"}, "forces[0].joint: not used by type 'spring_damper'"),
]


@pytest.mark.parametrize("change,start", SPRING_BAD, ids=[s for _, s in SPRING_BAD])
def test_bad_springs_are_refused_in_one_line(change, start):
    with pytest.raises(SceneError) as err:
        parse_scene(oscillator([SPRING | change]))
    assert "\n" not in str(err.value) and str(err.value).startswith(start), str(err.value)


def test_bad_rotational_springs_and_tables_are_refused_in_one_line(tmp_path):
    for change, start in (({"joint": "slide"}, "forces[0].joint: unknown revolute joint 'slide'"),
                          ({"joint": "r", "bodies": ["carriage", "disc"]}, "forces[0].bodies: not allowed with joint"),
                          ({"joint": "r", "free_length": 0.1}, "forces[0].free_length: not used by type")):
        spring = {"type": "rotational_spring_damper", "stiffness": 1.0} | change
        with pytest.raises(SceneError) as err:
            parse_scene(rotor([spring]))
        assert "\n" not in str(err.value) and str(err.value).startswith(start), str(err.value)
    for text, start in (("t,fx,fy\n0,1,1\n1,1,1\n", "lacks the column(s) tz"),
                        ("t,fx,fy,tz\n0,1,1,0\n0,2,2,0\n", "row 1: t = 0 s is not allowed"),
                        ("t,fx,fy,tz\n0,1,nan,0\n1,1,1,0\n", "row 0"),
                        ("t,fx,fy,tz\n0,1,1,0\n", "has 1 rows"), (None, "'bad.csv' is not allowed (no such file")):
        if text is None:
            (tmp_path / "bad.csv").unlink()
        else:
            (tmp_path / "bad.csv").write_text(text)
        with pytest.raises(SceneError) as err:
            parse_scene(oscillator([{"type": "load", "body": "mass", "table": "bad.csv"}]),
                        source=str(tmp_path / "s.yaml"))
        msg = str(err.value)
        assert "\n" not in msg and msg.startswith("forces[0].table:") and start in msg, msg


def test_the_cli_refuses_a_bad_force_element_in_one_line_without_traceback(tmp_path):
    data = yaml.safe_load(PROCESS.read_text())
    data = copy.deepcopy(data)
    data["forces"][0]["body"] = "tool"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    run = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(bad)], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert run.returncode != 0
    lines = [x for x in run.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "forces[0].body: unknown body 'tool'" in lines[0] and "Traceback" not in run.stderr


def test_a_tabulated_load_steps_in_compiled_c_as_in_the_virtual_machine(tmp_path):
    """The plant's generated C (gcc) evaluates the load table's interpolant: the same motion
    as CasADi's virtual machine (measured: identical to the last bit)."""
    (tmp_path / "push.csv").write_text("t,fx,fy,tz\n0.0,0.0,0.0,0.0\n0.3,5.0,-2.0,0.1\n0.6,-3.0,0.0,0.0\n")
    scene = parse_scene(oscillator([SPRING, {"type": "load", "body": "carriage", "table": "push.csv"}]),
                        source=str(tmp_path / "oscillator.yaml"))
    vm, compiled = simulate(scene, jit=False), simulate(scene, jit=True)
    assert compiled.stats["jit"] and not vm.stats["jit"]
    np.testing.assert_allclose(compiled.q, vm.q, rtol=0, atol=1e-12)
    free = damped(vm.t, 0.1, 0.0, M_CARRIAGE + M_MASS, 200.0, 2.0)  # without the load
    assert np.max(np.abs(vm.body("mass")[:, 0] - free)) > 1e-3  # the table's fx moved the mass


def test_summary_and_report_name_the_force_elements():
    """summary.json lists each element with its numbers (units in the keys) and report.md a
    line per element; a scene without forces has neither."""
    from rrr4.results.summary import force_element_summary
    from rrr4.results.tables import report_markdown
    scene = rrr4.load_scene(PROCESS)
    (load,) = [force_element_summary(e) for e in scene.forces]
    assert load["type"] == "load" and load["force_N"] == [-10.0, 0.0] and load["known"] is True
    summary = json.loads((ROOT / "results" / "process_load_circle" / "summary.json").read_text())
    assert summary["forces"] == [load]
    assert "- force element `cutting`: load on platform" in report_markdown(summary)
    plain = json.loads((ROOT / "results" / "paper_circle" / "summary.json").read_text())
    assert "forces" not in plain and "force element" not in report_markdown(plain)
