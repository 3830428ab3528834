"""Drivers with a motion law (mechanism.drivers[].time_law): the ideal slider-crank started
from rest by a quintic law against its closed form (slider position, the driver's effort
against the power balance of the kinetic energy), a time table against constant
acceleration, the constant speed's equations unchanged, and bad driver specs."""

import copy

import casadi as ca
import numpy as np
import pytest
import yaml

from rrr4 import Mechanism, Problem, SceneError, simulate
from rrr4.scene import inline_tables, parse_scene
from rrr4.studies.wear import cycle_duration
from tests.conftest import ROOT

IDEAL_SLIDER = ROOT / "problems" / "flores_slider_crank_ideal.yaml"
R, L = 0.05, 0.12                      # crank and connecting-rod lengths [m]
TRAVEL, T_LAW = 2 * np.pi, 0.03        # one crank revolution from rest to rest in 30 ms


def _scene(driver: dict, duration: float = 0.04, sample_rate: float = 10000.0):
    data = yaml.safe_load(IDEAL_SLIDER.read_text())
    data["mechanism"]["drivers"][0] = {"name": "crank_drive", "joint": "O", **driver}
    data["path"].update(duration=duration, sample_rate=sample_rate)
    return parse_scene(data)


def _quintic(t):
    """theta, theta_dot, theta_ddot of the quintic law from rest to rest (closed form)."""
    u = np.clip(t / T_LAW, 0.0, 1.0)
    th = TRAVEL * (10 * u**3 - 15 * u**4 + 6 * u**5)
    thd = TRAVEL / T_LAW * (30 * u**2 - 60 * u**3 + 30 * u**4)
    thdd = TRAVEL / T_LAW**2 * (60 * u - 180 * u**2 + 120 * u**3)
    return th, thd, thdd


def test_quintic_driver_starts_the_slider_crank_from_rest_on_the_closed_form():
    """Crank angle of the quintic law; slider x = r cos(theta) + sqrt(l^2 - r^2 sin^2 theta) at
    theta(t); the driver's effort times the crank rate equals the rate of the kinetic energy
    (no gravity, no friction: the power balance), with the kinetic energy from the bodies'
    masses and velocities and its rate by central differences."""
    scene = _scene({"time_law": "quintic", "travel_deg": 360.0, "duration": T_LAW})
    sim = simulate(scene, step=1e-6)
    th, thd, _ = _quintic(sim.t)
    assert np.max(np.abs(sim.qd[0])) < 1e-12  # starts from rest
    crank, slider = sim.body("crank"), sim.body("slider")
    np.testing.assert_allclose(np.unwrap(crank[:, 2]), th, atol=1e-8)
    x = R * np.cos(th) + np.sqrt(L**2 - R**2 * np.sin(th)**2)
    np.testing.assert_allclose(slider[:, 0], x, atol=1e-9 * np.max(x))
    m = np.repeat([[b.mass, b.mass, b.inertia] for b in scene.graph.bodies], 1, axis=0).ravel()
    kinetic = 0.5 * np.sum(m * sim.qd**2, axis=1)
    dt = sim.t[1] - sim.t[0]
    power = sim.driver_effort[1:-1, 0] * thd[1:-1]
    rate = (kinetic[2:] - kinetic[:-2]) / (2 * dt)
    scale = np.max(np.abs(power))
    assert scale > 1.0  # the start-up takes real power
    assert np.max(np.abs(power - rate)) < 2e-3 * scale  # central difference error ~ dt^2
    # after the law the crank rests at one revolution and takes no effort
    after = sim.t > T_LAW + 1e-3
    np.testing.assert_allclose(np.unwrap(crank[:, 2])[after], TRAVEL, atol=1e-8)
    assert np.max(np.abs(sim.driver_effort[after])) < 1e-6 * np.max(np.abs(sim.driver_effort))


def test_time_table_driver_moves_with_constant_acceleration_per_row():
    """A table of (t, s, s_dot) rows: constant acceleration up, constant speed, the crank at
    initial + travel s(t) exactly between rows (s = a t^2 / 2 on the first row)."""
    a, t1 = 200.0, 0.05  # s_ddot [1/s^2] for t1, then s_dot = a t1 to s = 1
    s1, v1 = 0.5 * a * t1**2, a * t1
    t2 = t1 + (1 - s1) / v1
    rows = [[0.0, 0.0, 0.0], [t1, s1, v1], [t2, 1.0, v1]]
    scene = _scene({"initial_deg": 30.0, "time_law": "table", "travel_deg": -90.0, "time_table": rows})
    d = scene.graph.drivers[0]
    assert d.duration == t2 and d.speed == pytest.approx(-np.pi / 2 / t2)
    t = np.array([0.0, 0.3 * t1, t1, 0.5 * (t1 + t2), t2, t2 + 0.1])
    s = np.where(t <= t1, 0.5 * a * t**2, s1 + v1 * (np.minimum(t, t2) - t1))
    want = np.radians(30.0) - np.pi / 2 * s
    np.testing.assert_allclose(Mechanism.from_scene(scene).driver_targets(t)[:, 0], want, atol=1e-12)
    value, rate, acc = (float(v) for v in Mechanism.from_scene(scene).model.driver_values(0.3 * t1))
    assert rate == pytest.approx(-np.pi / 2 * a * 0.3 * t1) and acc == pytest.approx(-np.pi / 2 * a)


def test_speed_table_driver_runs_up_and_holds_its_speed():
    """A speed table [t, speed]: a linear run-up from rest to OMEGA in t1, then OMEGA to t2;
    the angle is the speed's integral, OMEGA t^2 / (2 t1) then OMEGA (t - t1 / 2), exactly."""
    omega, t1, t2 = 300.0, 0.02, 0.05
    scene = _scene({"time_law": "table", "speed_table": [[0.0, 0.0], [t1, omega], [t2, omega]]})
    d = scene.graph.drivers[0]
    assert d.travel == pytest.approx(omega * (t2 - t1 / 2)) and d.duration == t2
    t = np.array([0.0, 0.25 * t1, t1, 0.03, t2])
    want = np.where(t <= t1, omega * t**2 / (2 * t1), omega * (t - t1 / 2))
    mech = Mechanism.from_scene(scene)
    np.testing.assert_allclose(mech.driver_targets(t)[:, 0], want, rtol=1e-12, atol=1e-12)
    value, rate, acc = (float(v) for v in mech.model.driver_values(0.01))
    assert rate == pytest.approx(omega * 0.01 / t1) and acc == pytest.approx(omega / t1)
    backwards = _scene({"time_law": "table", "speed_table": [[0.0, 0.0], [t1, -omega]]}).graph.drivers[0]
    assert backwards.travel == pytest.approx(-omega * t1 / 2)


def test_constant_speed_driver_builds_the_equations_it_always_built():
    """The default law is a constant speed: value initial + speed t, rate speed, no
    acceleration, the same expressions as before motion laws existed (committed results
    unchanged); and a scene saying time_law: constant is the same scene."""
    scene = _scene({"initial_deg": 10.0, "speed_rpm": 5000.0})
    said = _scene({"initial_deg": 10.0, "speed_rpm": 5000.0, "time_law": "constant"})
    assert said == scene and scene.graph.drivers[0].time_law == "constant"
    t = ca.SX.sym("t")
    value, rate, acc = Mechanism.from_scene(scene).model.driver_values(t)
    d = scene.graph.drivers[0]
    assert str(value) == str(ca.vertcat(d.initial + d.speed * t)) and str(rate) == str(ca.vertcat(d.speed))
    assert acc.shape == (1, 1) and float(acc) == 0.0


@pytest.mark.parametrize("driver, key, words", [
    ({"time_law": "quintic", "speed": 3.0, "travel_deg": 90, "duration": 1.0}, "drivers[0].speed",
     "not allowed with time_law 'quintic'"),
    ({"time_law": "quintic", "travel_deg": 0.0, "duration": 1.0}, "drivers[0].travel_deg", "0 is not allowed"),
    ({"time_law": "cycloidal", "travel": 1.0, "duration": 1.0}, "drivers[0].travel", "revolute"),
    ({"time_law": "quintic", "travel_deg": 90}, "drivers[0].duration", "missing"),
    ({"speed": 3.0, "duration": 1.0}, "drivers[0].duration", "not allowed with time_law 'constant'"),
    ({"time_law": "table", "travel_deg": 90, "time_table": [[0, 0, 0], [1, 1, 2]], "duration": 1.0},
     "drivers[0].duration", "last row"),
    ({"time_law": "table", "travel_deg": 90, "time_table": [[0, 0, 0], [0.5, 0.7, 2], [1, 1, 0]]},
     "drivers[0].time_table", "not a constant acceleration"),
    ({"time_law": "table", "travel_deg": 90, "time_table": "absent.csv"}, "drivers[0].time_table", "no such file"),
    ({"time_law": "ramp", "speed": 1.0}, "drivers[0].time_law", "constant, quintic"),
    ({"time_law": "table", "speed_table": [[0, 1.0], [0.1, -1.0]]}, "drivers[0].speed_table", "both signs"),
    ({"time_law": "table", "speed_table": [[0, 0.0], [0.1, 0.0]]}, "drivers[0].speed_table", "all speeds 0"),
    ({"time_law": "table", "speed_table": [[0, 1.0], [0.1, 2.0]], "travel_deg": 9.0}, "drivers[0].travel_deg",
     "integral"),
    ({"time_law": "table", "speed_table": [[0, 1.0], [0.1, 2.0]], "time_table": [[0, 0, 0], [1, 1, 2]],
      "travel_deg": 9.0}, "drivers[0].time_table", "not allowed with speed_table"),
    ({"time_law": "table", "travel_deg": 9.0}, "drivers[0].time_table", "missing"),
    ({"time_law": "quintic", "speed_table": [[0, 1.0], [0.1, 2.0]], "travel_deg": 9.0, "duration": 1.0},
     "drivers[0].speed_table", "only with time_law: table"),
])
def test_bad_driver_specs_are_refused_in_one_line(driver, key, words):
    with pytest.raises(SceneError) as e:
        _scene(driver)
    msg = str(e.value)
    assert "\n" not in msg and key in msg and words in msg, msg


def test_a_driver_time_table_file_is_read_beside_the_scene(tmp_path):
    data = yaml.safe_load(IDEAL_SLIDER.read_text())
    data["mechanism"]["drivers"][0] = {"joint": "O", "time_law": "table", "travel_deg": 180.0,
                                       "time_table": "law.csv"}
    (tmp_path / "law.csv").write_text("t,s,s_dot\n0,0,0\n0.02,0.5,50\n0.04,1,0\n")
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(copy.deepcopy(data)))
    from rrr4 import load_scene
    d = load_scene(path).graph.drivers[0]
    assert d.time_table[1] == (0.02, 0.5, 50.0) and d.travel == pytest.approx(np.pi) and d.duration == 0.04
    # a saved result's or a sweep case's copy carries the rows: it parses without the file
    assert inline_tables(data, tmp_path) and isinstance(data["mechanism"]["drivers"][0]["time_table"], list)
    assert parse_scene(data).graph.drivers[0] == d
    with pytest.raises(SceneError, match=r"^rrr4 wear|time_law: 'table' is not allowed with rrr4 wear"):
        cycle_duration(Problem.from_scene(parse_scene(data)))
    (tmp_path / "speed.csv").write_text("t,speed\n0,0\n0.02,50\n0.04,0\n")
    data["mechanism"]["drivers"][0] = {"joint": "O", "time_law": "table", "speed_table": "speed.csv"}
    path.write_text(yaml.safe_dump(data))
    d = load_scene(path).graph.drivers[0]
    assert d.travel == pytest.approx(1.0) and d.time_table[1] == pytest.approx((0.02, 0.5, 50.0))
    assert inline_tables(data, tmp_path) and parse_scene(data).graph.drivers[0] == d
