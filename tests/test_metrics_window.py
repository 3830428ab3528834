"""Short runs mislead: the settling time of the platform error, and the start-up window
(`rrr4 run --skip`, a sweep spec's `skip:`) that the windowed metrics discard."""

import json

import numpy as np
import pytest
import yaml

from rrr4 import SceneError, load_scene, simulate
from rrr4.cli import main
from rrr4.results.metrics import WHOLE_RUN, WINDOWED, arm_metrics, scalar_metrics, settling_time
from rrr4.results.summary import study_summary
from rrr4.studies.study import run_study
from rrr4.studies.sweeps import case_id, run_case
from tests.conftest import ROOT

RRR3 = ROOT / "problems" / "rrr3_circle.yaml"


def test_settling_time_is_when_the_error_enters_and_stays_in_its_final_band():
    t = np.linspace(0.0, 1.0, 10001)
    e = 1e-5 * (1 - np.exp(-t / 0.05))       # the offset builds with a 50 ms time constant
    # final band: [e(0.75) - 0.1 e_max, e_max + 0.1 e_max]; entered at 1 - exp(-t/tau) = 0.9
    assert settling_time(t, e) == pytest.approx(-0.05 * np.log(0.1 + np.exp(-15)), abs=2e-4)
    spike = e.copy()
    spike[5000] = 3e-5                        # a late excursion out of the band restarts the clock
    assert settling_time(t, spike) == pytest.approx(t[5001])
    assert settling_time(t, np.full_like(t, 2e-6)) == 0.0   # never out of its band


@pytest.fixture(scope="module")
def rrr3_sim():
    return simulate(load_scene(RRR3), t_end=0.02, output_rate=10000)


def test_skip_discards_the_start_up_window_from_the_windowed_metrics_only(rrr3_sim):
    sim = rrr3_sim
    whole, late = scalar_metrics(sim), scalar_metrics(sim, 0.01)
    keep = sim.t >= 0.01 - 1e-15
    assert late["platform_error_rms_m"] == pytest.approx(np.sqrt(np.mean(sim.platform_error[keep] ** 2)), rel=1e-12)
    assert late["platform_error_max_m"] == pytest.approx(sim.platform_error[keep].max(), rel=1e-12)
    assert late["torque_rms_Nm"] == pytest.approx(np.sqrt(np.mean(sim.tau[keep] ** 2)), rel=1e-12)
    # the offset builds from zero: the window's RMS is larger than the whole run's
    assert late["platform_error_rms_m"] > 1.05 * whole["platform_error_rms_m"]
    for k in ("contact_loss_events", "min_contact_force_N", "peak_contact_force_N"):  # per step: whole run
        assert late[k] == whole[k] or (np.isnan(late[k]) and np.isnan(whole[k]))
    full, cut = arm_metrics(sim, 1.0), arm_metrics(sim, 1.0, skip=0.01)
    assert cut["settling_time_s"] == full["settling_time_s"] > 0.0
    assert cut["free_flight_fraction"] != full["free_flight_fraction"] or cut["torque_rms_Nm"] != full["torque_rms_Nm"]


def test_the_summary_says_which_metrics_are_windowed_and_records_the_skip():
    study = run_study(load_scene(RRR3), t_end=0.02, skip=0.01)
    s = study_summary(study)
    w = s["metrics_window"]
    assert w["skip_s"] == 0.01 and w["over_window"] == list(WINDOWED) and w["over_whole_run"] == list(WHOLE_RUN)
    assert s["overrides"] == {"t_end_s": 0.02, "skip_s": 0.01}
    sim = study.arms["without_preload"].simulation
    assert s["without_preload"]["platform_error_rms_m"] == scalar_metrics(sim, 0.01)["platform_error_rms_m"]
    assert 0.0 < s["without_preload"]["settling_time_s"] <= 0.75 * 0.02 + 1e-12


@pytest.mark.parametrize("args, match", [
    (["--skip", "0.02"], r"--skip: 0.02 s is not allowed \(.*0 <= --skip < t_end = 0.02 s\)"),
    (["--skip", "-1"], r"--skip: -1.0 is not allowed \(must be a finite number >= 0\)"),
    (["--skip", "nan"], r"--skip: nan is not allowed"),
])
def test_a_skip_not_inside_the_run_is_one_line_and_writes_nothing(tmp_path, capsys, args, match):
    out = tmp_path / "out"
    assert main(["run", str(RRR3), "--out", str(out), "--t-end", "0.02", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert __import__("re").search(match, err[0]), err[0]
    assert not out.exists()


def test_a_sweep_case_with_a_skip_reports_the_windowed_metrics_under_its_own_id(rrr3_sim):
    text = yaml.safe_dump(yaml.safe_load(RRR3.read_text()), sort_keys=True)
    rows, _, _ = run_case(text, "rrr3_circle", 0.02, ["without_preload"], skip=0.01, options={"output_rate": 10000})
    (row,) = rows
    assert row["status"] == "ok"
    assert row["platform_error_rms_m"] == pytest.approx(scalar_metrics(rrr3_sim, 0.01)["platform_error_rms_m"],
                                                        rel=1e-9)
    assert case_id(text, 0.02, ["without_preload"]) == case_id(text, 0.02, ["without_preload"], 0.0)
    assert case_id(text, 0.02, ["without_preload"], 0.01) != case_id(text, 0.02, ["without_preload"])


def test_cli_run_with_skip_writes_the_window_into_summary_and_report(tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(RRR3), "--out", str(out), "--t-end", "0.02", "--skip", "0.01"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["metrics_window"]["skip_s"] == 0.01 and s["overrides"]["skip_s"] == 0.01
    report = (out / "report.md").read_text()
    assert "t >= 0.01 s" in report and "settling time" in report


def test_bad_skip_in_the_study_api_is_one_line():
    with pytest.raises(SceneError, match=r"^skip: 0.5 s is not allowed") as e:
        run_study(load_scene(RRR3), t_end=0.02, skip=0.5)
    assert "\n" not in str(e.value)
