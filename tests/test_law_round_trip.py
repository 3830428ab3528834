"""The round trip of an optimal law: the time law `rrr4 optimize` writes (time_law.csv), taken
as the scene's path time table, runs on a scene with a control rate without the user giving
t_end: the run ends with the law, rounded up to whole control periods, and says so."""

import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

import rrr4
from rrr4 import Problem, SceneError
from rrr4.optimal import optimal_time_law
from rrr4.scene import parse_scene
from rrr4.simulation import run_end
from tests.conftest import ROOT

PAPER = ROOT / "problems" / "paper_circle.yaml"
LINE = {"type": "line", "start": [0.0, 0.0, 0.0], "end": [0.005, 0.0, 0.0], "duration": 0.1, "sample_rate": 1000}


def _line_scene_data():
    """The reference 4-RRR (control rate 10 kHz) on a 5 mm line: a short, cheap optimal law."""
    data = yaml.safe_load(PAPER.read_text())
    data["path"] = dict(LINE)
    return data


def _with_table(data, tmp_path):
    data = dict(data, path={k: v for k, v in data["path"].items() if k != "duration"})
    data["path"].update(time_law="table", time_table="time_law.csv")
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_an_optimal_law_as_the_time_table_runs_to_its_end_in_whole_control_periods(tmp_path):
    data = _line_scene_data()
    law = optimal_time_law(Problem.from_scene(parse_scene(data)), "time", points=20, contact=True)
    law.save_table(tmp_path / "time_law.csv")
    scene = rrr4.load_scene(_with_table(data, tmp_path))
    c = scene.actuation.control_rate
    T = scene.path.duration
    assert T == pytest.approx(law.duration, rel=1e-12)
    assert abs(T * c - round(T * c)) > 1e-3  # the law is not a whole number of periods
    t_end, note = run_end(scene)
    n = int(np.ceil(T * c))
    assert t_end == pytest.approx(n / c, rel=1e-12) and T <= t_end < T + 1 / c
    assert f"{n} whole periods" in note and "\n" not in note
    sim = rrr4.simulate(scene)
    assert sim.t[-1] == pytest.approx(t_end, rel=1e-12) and sim.stats["frames"] >= 1
    end = np.array(LINE["end"])
    np.testing.assert_allclose(sim.pose_ref[-1], end, atol=1e-12)  # the law ran to its end, then rests
    assert sum(sim.contact_loss_events.values()) == 0  # the preload holds along the optimal law
    with pytest.raises(SceneError) as e:  # a t_end of the user's that is not whole: one line, the way out
        rrr4.simulate(scene, t_end=T)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("t_end:") and f"{n} periods" in msg


def test_a_whole_duration_is_run_as_it_is():
    scene = parse_scene(_line_scene_data())
    assert run_end(scene) == (scene.path.duration, "")


@pytest.mark.slow
def test_rrr4_optimize_then_rrr4_run_on_its_time_law_csv(tmp_path):
    """The documented round trip on the command line: rrr4 optimize writes time_law.csv, the
    scene names it as its path time table, rrr4 run runs it and says the rounding."""
    data = _line_scene_data()
    (tmp_path / "line.yaml").write_text(yaml.safe_dump(data))
    env = dict(os.environ, MPLBACKEND="Agg")
    rrr4_cli = [sys.executable, "-m", "rrr4.cli"]
    r = subprocess.run([*rrr4_cli, "optimize", str(tmp_path / "line.yaml"), "--points", "20", "--no-replay",
                        "--out", str(tmp_path / "opt")], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    (tmp_path / "time_law.csv").write_bytes((tmp_path / "opt" / "time_law.csv").read_bytes())
    scene = _with_table(data, tmp_path)
    r = subprocess.run([*rrr4_cli, "run", str(scene), "--out", str(tmp_path / "run")], capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "whole periods" in r.stdout + r.stderr
    summary = (tmp_path / "run" / "summary.json").read_text()
    assert '"with_preload"' in summary
