"""Identification (rrr4.identify, `rrr4 identify`): a synthetic truth from the seated model
itself (coverage of the intervals), a simulated run of a perturbed reference scene, an
unidentifiable parameter set, the CLI round trip and bad input in one line."""

from __future__ import annotations

import numpy as np
import pytest

import rrr4
from rrr4.cli import main
from rrr4.errors import MeasurementError, SceneError
from rrr4.identify import (
    Measurements,
    identify,
    measurements_from_simulation,
    read_measurements,
    resolve_parameters,
)
from rrr4.identify.seated import FRICTION_EXPLAINED_MIN, seated_measurements
from rrr4.studies.robustness import perturbed
from rrr4.studies.study import arm_scene

from .conftest import PAPER, one_line

CLEARANCE, FRICTION, STIFFNESS = "joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness"
LINK = "mechanism.chains[0].driving_link.length"


@pytest.fixture(scope="module")
def problem():
    return rrr4.build(rrr4.load_scene(PAPER))


def _truth(problem, keys, shifts):
    """Parameters and true values: each shifted by `shifts` in its scaled coordinate."""
    params = resolve_parameters(problem, keys)
    return params, np.array([q.value(q.coordinate(q.nominal) + s) for q, s in zip(params, shifts, strict=True)])


def _noise(m: Measurements) -> dict:
    """1 um on the position, 1e-5 rad (1 um at the 0.1 m attachment radius) on the
    orientation, 1 % of each effort's RMS."""
    out = {"x_m": 1e-6, "y_m": 1e-6, "theta_rad": 1e-5}
    out.update({c: 0.01 * float(np.sqrt(np.mean(v ** 2))) for c, v in m.columns.items() if c.startswith("tau_")})
    return out


def _noisy(m: Measurements, noise: dict, seed: int) -> Measurements:
    rng = np.random.default_rng(seed)
    cols = {c: v + noise[c] * rng.standard_normal(v.size) if c in noise else v for c, v in m.columns.items()}
    return Measurements(m.t, cols, {}, m.source)


def _simulated(problem, case: str, t_end: float):
    """A run of the perturbed mechanism (robustness case) under the nominal preloaded controller."""
    plant = rrr4.build(perturbed(problem, case))
    return rrr4.simulate(arm_scene(plant, "with_preload"), t_end=t_end, model=arm_scene(problem, "with_preload"))


# ---------------------------------------------------------------------- synthetic truth


def test_noise_levels_are_estimated_from_the_residuals(problem):
    keys = [CLEARANCE, FRICTION]
    params, truth = _truth(problem, keys, [0.1, -0.3])
    clean = seated_measurements(problem, params, truth, np.linspace(0.0, 1.0, 501))
    noise = _noise(clean)
    res = identify(problem, _noisy(clean, noise, 7), keys, method="seated")
    for c, s in noise.items():
        assert res.noise[c] == pytest.approx(s, rel=0.1), c
        assert res.noise_estimated[c]
    assert res.fit["reduced_chi2"] == pytest.approx(1.0, abs=0.05)
    given = identify(problem, _noisy(clean, noise, 7), keys, noise={"x_m": 1e-6}, method="seated")
    assert given.noise["x_m"] == 1e-6 and not given.noise_estimated["x_m"]


def test_b_and_c_clearances_of_one_chain_are_flagged_as_inseparable(problem):
    # the following link is nearly a two-force member: its two journals carry the same load and
    # move its end by the sum of their seats, so the data see c_B1 + c_C1, never c_B1 - c_C1
    keys = ["joints.per_joint.B1.radial_clearance", "joints.per_joint.C1.radial_clearance", FRICTION]
    params, truth = _truth(problem, keys, [0.1, -0.1, 0.2])
    clean = seated_measurements(problem, params, truth, np.linspace(0.0, 1.0, 201))
    res = identify(problem, _noisy(clean, _noise(clean), 3), keys, method="seated")
    v = res.verdict
    assert not v["identifiable"] and v["collinearity_index"] > 20
    combo = v["not_identifiable"][0]["combination"]
    assert set(combo) == set(keys[:2]) and np.sign(combo[keys[0]]) == -np.sign(combo[keys[1]])
    assert "following link" in v["not_identifiable"][0]["excite"]
    assert "cannot separate" in res.table()
    # the sum is well determined all the same
    i, j = 0, 1
    var_sum = res.covariance[i, i] + res.covariance[j, j] + 2 * res.covariance[i, j]
    assert np.sqrt(var_sum) < 0.05 * np.sqrt(res.covariance[i, i])


def test_the_default_parameters_on_synthetic_truth_say_stiffness_is_barely_determined(problem):
    params, truth = _truth(problem, [CLEARANCE, FRICTION, STIFFNESS], [0.1, 0.5, np.log(0.7)])
    clean = seated_measurements(problem, params, truth, np.linspace(0.0, 1.0, 101))
    res = identify(problem, _noisy(clean, _noise(clean), 5), method="seated")
    assert res.keys == [CLEARANCE, FRICTION, STIFFNESS]
    assert STIFFNESS in res.verdict["poorly_determined"] and not res.verdict["identifiable"]
    lo, hi = res.interval[2]  # its profile interval: wide, and it holds the truth
    assert lo <= truth[2] <= hi and hi / lo > 2 and res.fit["intervals"][STIFFNESS] == "profile"
    assert abs(res.value(CLEARANCE) - truth[0]) < 3 * res.standard_error[0]


# ---------------------------------------------------------------------- a simulated mechanism


def test_a_simulated_run_with_20_percent_more_clearance_gives_it_back(problem):
    sim = _simulated(problem, "clearance +20 %", 0.3)
    res = identify(problem, measurements_from_simulation(sim), [CLEARANCE, FRICTION], method="seated")
    assert res.value(CLEARANCE) == pytest.approx(1.2e-4, rel=0.01)
    assert res.value(FRICTION) == pytest.approx(0.1, abs=0.01)
    assert res.fit["angles"] == "measured" and res.fit["preload"] == "measured efforts"
    assert res.fit["rms_residual"]["x_m"] < 0.5e-6


def test_a_simulated_run_with_friction_0_2_gives_it_back(problem):
    sim = _simulated(problem, "friction 0.2", 1.0)
    res = identify(problem, measurements_from_simulation(sim), [CLEARANCE, FRICTION], method="seated")
    assert res.value(FRICTION) == pytest.approx(0.2, abs=0.015)
    assert res.value(CLEARANCE) == pytest.approx(1e-4, rel=0.01)
    # noise-free, the seat model's error is what is left: 0.1923 against 0.2, 8.5 plain standard errors
    # off; the residuals' autocorrelation carries it into the interval (0.1834 to 0.2012)
    lo, hi = res.interval[1]
    assert lo <= 0.2 <= hi and res.fit["model_error_inflation"][1] > 3.0, (res.interval[1], res.fit)
    assert res.fit["friction_explained_ratio"] >= FRICTION_EXPLAINED_MIN
    # without the feedback's lag the friction comes out far too low: the lag is what makes it right
    lagless = identify(problem, measurements_from_simulation(sim), [CLEARANCE, FRICTION], effort_lag=0.0,
                       method="seated")
    assert lagless.value(FRICTION) < 0.17


def test_the_cli_writes_an_identified_scene_that_checks_and_resimulates_the_run(problem, tmp_path, capsys):
    sim = _simulated(problem, "clearance +20 %", 1.0)
    measured = measurements_from_simulation(sim)
    csv = measured.write_csv(tmp_path / "timeseries.csv", prefix="with_preload_")
    out = tmp_path / "ident"
    assert main(["identify", str(PAPER), str(csv), "--parameters", f"{CLEARANCE},{FRICTION}=0:0.5",
                 "--method", "seated", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "joints.radial_clearance" in text and "verdict: identifiable" in text
    assert {p.name for p in out.iterdir()} == {"identified.yaml", "identification.json", "fit.png", "residuals.png",
                                              "correlation.png"}
    assert main(["check", str(out / "identified.yaml")]) == 0
    identified = rrr4.load_scene(out / "identified.yaml")
    assert identified.clearance_joints and identified.joint("B1").radial_clearance == pytest.approx(1.2e-4, rel=0.01)
    # re-simulating the identified mechanism under the same controller reproduces the run
    again = rrr4.simulate(arm_scene(rrr4.build(identified), "with_preload"), t_end=1.0,
                          model=arm_scene(problem, "with_preload"))
    nominal = rrr4.simulate(arm_scene(problem, "with_preload"), t_end=1.0)
    err = np.sqrt(np.mean(np.sum((again.pose[:, :2] - sim.pose[:, :2]) ** 2, axis=1)))
    err_nominal = np.sqrt(np.mean(np.sum((nominal.pose[:, :2] - sim.pose[:, :2]) ** 2, axis=1)))
    assert err < 1e-6 and err < err_nominal / 10, (err, err_nominal)  # 0.26 um against 4.7 um


# ---------------------------------------------------------------------- bad input, one line each


def _csv(tmp_path, header: str, rows: list[str]):
    p = tmp_path / "m.csv"
    p.write_text(header + "\n" + "\n".join(rows) + "\n")
    return p


def test_bad_measurement_files_end_inone_line(problem, tmp_path):
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,foo", ["0,1", "0.1,2"]), problem)
    one_line(e.value, "no pose or effort column", "x_m")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "time,x_m", ["0,1", "0.1,2"]), problem)
    one_line(e.value, "no time column")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,x_m", ["0,0", "0.2,0", "0.1,0"]), problem)
    one_line(e.value, "not increasing at row 3", "0.2", "0.1")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,x_m", ["0,0", "0.1,nan"]), problem)
    one_line(e.value, "column x_m is nan in row 2")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,x_m", ["0,0", "0.1,abc"]), problem)
    one_line(e.value, "column x_m", "'abc'", "row 3")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,a_x_m,b_x_m", ["0,0,0", "0.1,0,0"]), problem)
    one_line(e.value, "several arms", "a, b", "--arm")
    with pytest.raises(MeasurementError) as e:
        read_measurements(_csv(tmp_path, "t_s,a_x_m", ["0,0", "0.1,0"]), problem, arm="c")
    one_line(e.value, "arm", "'c'", "a")
    with pytest.raises(MeasurementError) as e:
        read_measurements(tmp_path / "missing.csv", problem)
    one_line(e.value, "measurement file", "does not exist")
    with pytest.raises(MeasurementError, match="millimetres"):
        read_measurements(_csv(tmp_path, "t_s,x_m,y_m", ["0,0,0", "0.1,-20.0,15.0"]), problem)
    read_measurements(_csv(tmp_path, "t_s,x_m,y_m", ["0,0,0", "0.1,-0.02,0.015"]), problem)


def test_bad_identification_arguments_end_inone_line(problem):
    m = Measurements(np.linspace(0, 0.1, 11), {"x_m": np.zeros(11), "y_m": np.zeros(11)})
    with pytest.raises(SceneError) as e:
        identify(problem, m, ["joints.radial_clearence"], method="seated")
    one_line(e.value, "joints.radial_clearence", "joints.radial_clearance")
    with pytest.raises(SceneError) as e:
        identify(problem, m, ["joints.per_joint.A1.radial_clearance"], method="seated")
    one_line(e.value, "A1", "B1")
    with pytest.raises(SceneError) as e:
        identify(problem, m, ["mechanism.chains[7].base[0]"], method="seated")
    one_line(e.value, "chain 7", "0 to 3")
    with pytest.raises(SceneError) as e:
        identify(problem, m, {FRICTION: [0.5, 0.2]}, method="seated")
    one_line(e.value, FRICTION, "lower <= nominal <= upper")
    with pytest.raises(SceneError) as e:
        identify(problem, m, method="shooting")
    one_line(e.value, "method", "seated")
    with pytest.raises(MeasurementError) as e:
        identify(problem, Measurements(np.linspace(0, 2, 11), {"x_m": np.zeros(11)}), [CLEARANCE], method="seated")
    one_line(e.value, "2 s", "1 s")
    with pytest.raises(MeasurementError) as e:
        identify(problem, m, noise={"z_m": 1e-6}, method="seated")
    one_line(e.value, "noise", "z_m", "x_m")
    with pytest.raises(MeasurementError) as e:
        identify(problem, Measurements(np.linspace(0, 0.1, 11), {"tau_A1_Nm": np.ones(11)}), method="seated")
    one_line(e.value, "tau_A1_Nm alone", "at least 2")
    no_preload = rrr4.build(rrr4.load_scene(PAPER.parent / "no_preload_circle.yaml"))
    with pytest.raises(SceneError) as e:
        identify(no_preload, m, method="seated")
    one_line(e.value, "actuation.preload", "seated")


def test_the_cli_refuses_bad_input_inone_line(tmp_path, capsys):
    p = _csv(tmp_path, "t_s,x_m", ["0,0", "0.2,0", "0.1,0"])
    assert main(["identify", str(PAPER), str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "not increasing" in err
    assert main(["identify", str(PAPER), str(p), "--parameters", "effects.friction.coefficient=a:b",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--parameters" in err and "LOWER:UPPER" in err
    p_ok = _csv(tmp_path, "t_s,x_m", ["0,0", "0.1,0", "0.2,0"])
    for window, words in (("0.3", ["--window", "T0:T1"]), ("0.5:0.9", ["window", "0 instants", "0 to 0.2 s"])):
        assert main(["identify", str(PAPER), str(p_ok), "--window", window, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and all(w in err for w in words), err
    assert not (tmp_path / "o").exists()



def test_the_cli_refuses_an_output_it_cannot_write_before_any_work(tmp_path, capsys):
    a_file = tmp_path / "file.txt"
    a_file.write_text("keep")
    for out in (a_file / "sub", a_file):
        assert main(["identify", str(PAPER), str(tmp_path / "missing.csv"), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--out" in err, err
    assert a_file.read_text() == "keep" and [p.name for p in tmp_path.iterdir()] == ["file.txt"]


# ---------------------------------------------------------------------- closing the loop


@pytest.mark.slow
def test_the_identified_model_compensates_as_well_as_the_true_one_in_every_robustness_case(problem):
    from rrr4.studies.robustness import CASES, robustness
    rows = robustness(problem, t_end=1.0, identified=True)
    for case in CASES:
        rms = {r["model"]: r["platform_error_rms_m"] for r in rows
               if r["case"] == case and r["arm"] == "with_preload_compensated"}
        assert rms["identified"] <= max(1.25 * rms["true"], rms["true"] + 0.5e-6), (case, rms)
