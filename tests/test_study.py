"""The study end to end (`rrr4 run`): short runs of the real pipeline, the summary's
structure and physical sense, and result directories that survive bad input and failures."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from rrr4 import SceneError, load_scene
from rrr4.cli import main
from rrr4.results import atomic_directory, loss_times, write_results
from rrr4.results.study import PRELOAD_ARMS
from rrr4.studies.study import run_study

ROOT = Path(__file__).resolve().parents[1]
T_END = 0.03  # s: the first part of the path, with the unloaded arm's first impacts
ARM_KEYS = {"contact_loss_events", "free_flight_fraction", "max_penetration_m", "peak_contact_force_N",
            "platform_error_rms_m", "platform_error_max_m", "torque_rms_Nm", "energy_audit_residual",
            "wall_time_s", "simulated_time_s"}
JOINTS = ["B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4"]


@pytest.fixture(scope="module")
def paper_study():
    return run_study(load_scene(ROOT / "problems" / "paper_circle.yaml"), t_end=T_END)


@pytest.fixture(scope="module")
def paper_summary(paper_study, tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "paper_circle"
    _, files = write_results(paper_study, out)
    assert sorted(files) == sorted(p.name for p in out.iterdir())
    return json.loads((out / "summary.json").read_text()), out


def test_summary_has_every_required_key_for_both_arms(paper_summary):
    summary, _ = paper_summary
    for arm in PRELOAD_ARMS:
        m = summary[arm]
        assert ARM_KEYS <= set(m)
        for key in ("contact_loss_events", "free_flight_fraction", "peak_contact_force_N"):
            assert list(m[key]) == JOINTS
        assert all(isinstance(v, int) and v >= 0 for v in m["contact_loss_events"].values())
        assert m["simulated_time_s"] == pytest.approx(T_END)
    assert summary["preload"]["method"] == "qp"
    assert summary["preload"]["feasible"] is True


def test_summary_is_physically_sensible(paper_summary):
    summary, _ = paper_summary
    clearance = 1e-4
    for arm in PRELOAD_ARMS:
        m = summary[arm]
        assert all(0.0 <= v <= 1.0 for v in m["free_flight_fraction"].values())
        # steel journals penetrate by micrometres, far less than the 0.1 mm clearance
        assert 0.0 <= m["max_penetration_m"] < 0.1 * clearance
        assert 0.0 <= m["platform_error_rms_m"] <= m["platform_error_max_m"] < clearance * 10
        assert m["energy_audit_residual"] < 1e-2
        assert m["torque_peak_Nm"] <= 5.0 + 1e-9  # the actuators' limit
    w, wo = summary["with_preload"], summary["without_preload"]
    # the preload pushes every journal into its bearing with at least f_min, and none lets go
    assert min(w["peak_contact_force_N"].values()) >= summary["preload"]["f_min_N"] * (1 - 1e-6)
    assert sum(w["contact_loss_events"].values()) == 0
    assert min(w["min_contact_force_N"].values()) > 0.5 * summary["preload"]["f_min_N"]
    # the internal torques show in the effort, not in the motion error
    assert w["torque_rms_Nm"] > 10 * wo["torque_rms_Nm"]
    assert w["platform_error_rms_m"] < wo["platform_error_rms_m"]


def test_loss_times_match_the_simulations_own_counter():
    """A centred start rattles (the journals fly across their clearance and rebound), so
    there are losses to locate; each one found in the output matches the integrator's counter
    (a continuous controller: the study then writes every step; a sampled one writes every
    control period, and two transitions inside one period are counted but not located)."""
    scene = load_scene(ROOT / "problems" / "paper_circle.yaml")
    scene = dataclasses.replace(scene, initial=dataclasses.replace(scene.initial, journals="centred"),
                                actuation=dataclasses.replace(scene.actuation, control_rate=None))
    study = run_study(scene, t_end=0.01)
    total = 0
    for arm in study.arms.values():
        sim = arm.simulation
        times = loss_times(sim)
        assert {j: len(v) for j, v in times.items()} == sim.contact_loss_events
        assert all(np.all((v > 0) & (v <= 0.01)) for v in times.values())
        total += sum(sim.contact_loss_events.values())
    assert total > 0


def test_results_hold_figures_csv_and_report(paper_summary, paper_study):
    summary, out = paper_summary
    for name in ("orbits.png", "contact_force.png", "platform_error.png", "torques.png", "preload_alpha.png"):
        assert (out / name).stat().st_size > 10_000
    data = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
    assert len(data) == round(T_END * paper_study.scene.path.sample_rate) + 1
    sim = paper_study.arms["with_preload"].simulation
    assert np.allclose(data["with_preload_error_m"], np.interp(data["t_s"], sim.t, sim.platform_error))
    report = (out / "report.md").read_text()
    assert f"{summary['with_preload']['platform_error_rms_m'] * 1e6:.4g}" in report


def test_summary_and_report_give_the_contact_numbers_the_simulations_used(paper_summary, paper_study):
    """stiffness: auto, the hysteresis factor, v_min and the friction parameters are written
    (not only the law's name), as the equations took them."""
    summary, out = paper_summary
    c = summary["contact"]
    problem = paper_study.problem
    assert c["stiffness_N_per_m^n"] == {j: problem.joint_stiffness(j) for j in JOINTS}
    assert c["v_min_m_s"] == paper_study.arms["with_preload"].simulation.stats["v_min"]
    assert c["friction"] == {"law": "ambrosio", "coefficient": 0.1, "v0_m_s": 1e-4, "v1_m_s": 2e-4}
    report = (out / "report.md").read_text()
    assert f"{problem.joint_stiffness('B1'):.4g} N/m^1.5" in report and "chi = 0.1425" in report


def test_rewriting_a_result_directory_replaces_it_and_leaves_no_temporaries(paper_study, tmp_path):
    out = tmp_path / "r"
    write_results(paper_study, out, animate=False)
    (out / "summary.json").write_text('{"earlier": true}')
    write_results(paper_study, out, animate=False)
    assert "with_preload" in json.loads((out / "summary.json").read_text())
    assert [p.name for p in tmp_path.iterdir()] == ["r"]


def test_failed_write_leaves_the_earlier_result_intact(tmp_path):
    out = tmp_path / "r"
    out.mkdir()
    (out / "summary.json").write_text("earlier")

    def fill(d):
        (d / "summary.json").write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_directory(out, fill)
    assert (out / "summary.json").read_text() == "earlier"
    assert [p.name for p in tmp_path.iterdir()] == ["r"]


def test_a_failed_figure_write_leaves_the_earlier_figure_and_no_temporary(tmp_path):
    """save_figure, the one way every figure reaches its file: written whole or not at all."""
    import matplotlib.pyplot as plt

    from rrr4.results.figures import save_figure
    path = tmp_path / "f.png"
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    assert save_figure(fig, path, dpi=50) == path and path.read_bytes().startswith(b"\x89PNG")
    earlier = path.read_bytes()

    def half_then_fail(fname, **kw):
        with open(fname, "wb") as f:
            f.write(b"\x89PNG half")
        raise OSError("disk full")

    fig, _ = plt.subplots()
    fig.savefig = half_then_fail
    with pytest.raises(OSError, match="disk full"):
        save_figure(fig, path, dpi=50)
    assert path.read_bytes() == earlier and [p.name for p in tmp_path.iterdir()] == ["f.png"]
    assert not plt.fignum_exists(fig.number)   # closed all the same


def test_non_result_directory_is_refused_as_output(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(SceneError, match="holds no summary.json"):
        atomic_directory(tmp_path, lambda d: None)
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_run_with_a_bad_scene_prints_one_line_and_keeps_earlier_results(tmp_path, paper_data, capsys):
    import yaml
    paper_data["effects"]["contact"]["law"] = "lankarani"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(paper_data))
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("earlier")
    assert main(["run", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "effects.contact.law" in err[0] and "lankarani-nikravesh" in err[0]
    assert (out / "summary.json").read_text() == "earlier"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml", "out"]


def test_run_with_a_bad_end_time_prints_one_line_and_keeps_earlier_results(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("earlier")
    scene = ROOT / "problems" / "rrr3_circle.yaml"
    assert main(["run", str(scene), "--out", str(out), "--t-end", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--t-end: -1.0 is not allowed" in err[0]
    assert (out / "summary.json").read_text() == "earlier"


def test_three_chain_study_has_only_the_without_preload_arm(tmp_path, capsys):
    out = tmp_path / "rrr3"
    assert main(["run", str(ROOT / "problems" / "rrr3_circle.yaml"), "--out", str(out), "--t-end", "0.01"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["with_preload"] is None and summary["targets"] == {}
    assert "no actuation redundancy" in summary["preload"]["reason"]
    assert list(summary["without_preload"]["contact_loss_events"]) == ["B1", "B2", "B3", "C1", "C2", "C3"]
    assert not (out / "preload_alpha.png").exists()
    assert "without preload" in capsys.readouterr().out


def test_ideal_scene_has_no_contact_and_reports_pin_reactions(tmp_path):
    study = run_study(load_scene(ROOT / "problems" / "ideal_circle.yaml"), t_end=0.01)
    summary, files = write_results(study, tmp_path / "ideal", animate=False)
    assert "orbits.png" not in files and "contact_force.png" not in files
    assert summary["with_preload_compensated"] is None  # nothing to compensate without clearance
    for arm in ("with_preload", "without_preload"):
        m = summary[arm]
        assert sum(m["contact_loss_events"].values()) == 0 and m["max_penetration_m"] == 0.0
        assert all(v == 0.0 for v in m["free_flight_fraction"].values())
    # with preload, every ideal pin carries about f_min or more all the time (PD corrections aside)
    reactions = np.linalg.norm(study.arms["with_preload"].simulation.reaction, axis=2)
    assert reactions.shape[1] == 8
    assert reactions.min() >= 0.95 * summary["preload"]["f_min_N"]


def _limit6(tmp_path) -> Path:
    """A user's 4-RRR: the reference scene in a vertical plane with a 6 N m limit, where the
    preload needs more than the limit (actuator A4, by up to ~47 %)."""
    import yaml
    data = yaml.safe_load((ROOT / "problems" / "paper_circle.yaml").read_text())
    data["name"] = "limit6"
    data["effects"]["gravity"] = [0.0, -9.81]
    data["actuation"]["torque_limit"] = 6.0
    p = tmp_path / "limit6.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def test_check_says_where_and_by_how_much_the_preload_cannot_hold(tmp_path, capsys):
    """rrr4 check evaluates the scene's preload along the whole path: it names the actuator,
    the real peak effort it needs (not the first value over the limit) and when, exits 1, and
    points to rrr4 map."""
    from rrr4 import solve_preload
    path = _limit6(tmp_path)
    assert main(["check", str(path)]) == 1
    out, err = capsys.readouterr()
    with pytest.warns(UserWarning):
        sol = solve_preload(load_scene(path))
    need = np.abs(sol.tau[:, 3])
    over = np.flatnonzero(need > 6.0 * (1 + 1e-6))
    assert need.max() > 6.0 * 1.3 and need[over[0]] < need.max()  # the edge of the limit is not the answer
    k = int(np.argmax(need))
    assert (f"actuator A4 needs {need.max():.4g} N m at t = {sol.t[k]:.4g} s against its limit 6 N m" in out)
    assert "CANNOT HOLD" in out and f"rrr4 map {path}" in out and "clips every effort at its limit" in out
    assert "preload cannot hold" in err and len(err.strip().splitlines()) == 1
    # the reference scene's preload holds: exit 0, and the peak is said
    assert main(["check", str(ROOT / "problems" / "paper_circle.yaml")]) == 0
    assert "holds at every sample; peak effort 4.013 N m" in capsys.readouterr().out


def test_run_reports_an_infeasible_preload_and_never_commands_beyond_the_limits(tmp_path):
    """The study says which actuator, when and by how much (log, summary.json, report.md), and
    the simulations clip at the limits, loudly: the saturation is in every preloaded arm."""
    lines = []
    study = run_study(load_scene(_limit6(tmp_path)), t_end=0.01, log=lines.append)
    summary, _ = write_results(study, tmp_path / "out", animate=False)
    excess = {e["actuator"]: e for e in summary["preload"]["effort_over_limit"]}
    assert set(excess) == {"A3", "A4"}
    assert excess["A4"]["peak"] == pytest.approx(np.abs(study.preload.tau[:, 3]).max())
    assert excess["A4"]["limit"] == 6.0 and excess["A4"]["spans_s"][0][0] == 0.0
    assert "clips every effort" in summary["preload"]["efforts_in_simulation"]
    assert any(line.strip().startswith("actuator A4 needs 8.83") for line in lines)
    for arm in ("with_preload", "with_preload_compensated", "without_preload"):
        m = summary[arm]
        assert m["torque_peak_Nm"] <= 6.0 * (1 + 1e-12)
    # the feed-forward needs more than 6 N m at A4 from t = 0: the preloaded arms sit at the limit
    assert summary["with_preload"]["effort_at_limit_fraction"]["A4"] > 0.9
    assert summary["without_preload"]["effort_at_limit_fraction"]["A4"] == 0.0
    report = (tmp_path / "out" / "report.md").read_text()
    assert "The preload cannot hold:** actuator A4 needs 8.838 N m" in report
