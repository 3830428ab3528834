"""What a user looks for in the outputs: friction forces and ideal-joint reactions in
timeseries.csv, `rrr4 --version`, the integrator/step/output-rate overrides of `rrr4 run`
(validated, recorded in summary.json), `rrr4 animate` options, and the C compile time
reported apart from the wall time."""

import csv
import json
import re
import subprocess
import sys
import uuid

import numpy as np
import pytest
import yaml
from PIL import Image

import rrr4
from rrr4.cli import main
from rrr4.codegen import build
from rrr4.results import write_results
from rrr4.scene import parse_scene
from rrr4.studies.study import run_study
from tests.conftest import PAPER, ROOT

RRR3 = ROOT / "problems" / "rrr3_circle.yaml"


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """The reference 4-RRR with three clearance joints (the other five ideal), journals
    centred so that they hit and slide at once: 10 ms, written with its timeseries."""
    data = yaml.safe_load(PAPER.read_text())
    data["joints"]["clearance"] = ["B1", "C1", "C2"]
    data["initial"]["journals"] = "centred"
    study = run_study(parse_scene(data, name="mixed", source=""), t_end=0.01)
    out = tmp_path_factory.mktemp("mixed") / "mixed"
    write_results(study, out, animate=False)
    with (out / "timeseries.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    return study, {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def test_timeseries_has_the_friction_force_of_every_clearance_joint(mixed):
    study, cols = mixed
    sim = study.arms["with_preload"].simulation
    t = cols["t_s"]
    rows = np.searchsorted(sim.t, t - 1e-12)
    mu = study.scene.effects.friction.coefficient
    slid = 0
    for k, j in enumerate(sim.clearance_joints):
        fn, ft = cols[f"with_preload_Fn_{j}_N"], cols[f"with_preload_Ft_{j}_N"]
        e = sim.eccentricity[rows, k]
        n = e / np.linalg.norm(e, axis=1, keepdims=True)
        tangent = np.c_[-n[:, 1], n[:, 0]]
        # the column is the contact force's component along the tangent, within Coulomb's cone
        np.testing.assert_allclose(ft, np.sum(sim.contact_force[rows, k] * tangent, axis=1), atol=1e-9)
        np.testing.assert_allclose(fn, -np.sum(sim.contact_force[rows, k] * n, axis=1), atol=1e-9)
        assert np.all(np.abs(ft) <= mu * fn + 1e-9)
        slid += int(np.sum(np.abs(ft) > 1e-3))
    assert slid > 0   # the journals slide: friction is not all zeros


def test_timeseries_has_the_reaction_of_every_ideal_joint(mixed):
    study, cols = mixed
    sim = study.arms["with_preload"].simulation
    assert sim.ideal_passive_joints == ("B2", "B3", "B4", "C3", "C4")
    rows = np.searchsorted(sim.t, cols["t_s"] - 1e-12)
    for k, j in enumerate(sim.ideal_passive_joints):
        np.testing.assert_allclose(cols[f"with_preload_Rx_{j}_N"], sim.reaction[rows, k, 0], atol=1e-9)
        np.testing.assert_allclose(cols[f"with_preload_Ry_{j}_N"], sim.reaction[rows, k, 1], atol=1e-9)
    # the preload loads the pins: several times the reaction of the unloaded arm
    loaded, unloaded = (np.hypot(cols[f"{a}_Rx_B2_N"], cols[f"{a}_Ry_B2_N"])
                        for a in ("with_preload", "without_preload"))
    assert loaded.min() > 1.0 and loaded.mean() > 3 * unloaded.mean()
    assert not any(k.startswith("with_preload_Rx_B1") for k in cols)   # B1 has clearance, not a pin


def test_version_is_the_package_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"rrr4 {rrr4.__version__}"
    p = subprocess.run([sys.executable, "-m", "rrr4.cli", "--version"], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0 and p.stdout.strip() == f"rrr4 {rrr4.__version__}"


def test_run_overrides_take_effect_and_are_recorded(tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(RRR3), "--out", str(out), "--t-end", "0.01", "--integrator", "generalized-alpha",
                 "--step", "2e-5", "--output-rate", "5000"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["overrides"] == {"t_end_s": 0.01, "integrator": "generalized-alpha", "step_s": 2e-5,
                              "output_rate_Hz": 5000.0}
    m = s["without_preload"]
    assert m["integrator"] == "generalized-alpha" and m["step_s"] == pytest.approx(2e-5) and m["steps"] == 500
    data = np.load(out / "motion.npz")
    assert np.diff(data["t"]).max() == pytest.approx(1e-3)   # the animation keeps the path's 1 kHz


@pytest.mark.parametrize("args, match", [
    (["--integrator", "rk5"], r"--integrator: unknown integrator 'rk5' \(choose one of: .*rk4"),
    (["--step", "0"], r"--step: 0.0 is not allowed \(must be a finite number > 0\)"),
    (["--output-rate", "-5"], r"--output-rate: -5.0 is not allowed"),
    (["--step", "1e-4", "--output-rate", "20000"], r"--output-rate: 20000 Hz is not allowed at step 0.0001 s "
                                                    r"\(at most one output per step: <= 10000 Hz\)"),
])
def test_bad_run_overrides_are_one_line_and_write_nothing(tmp_path, capsys, args, match):
    out = tmp_path / "out"
    assert main(["run", str(RRR3), "--out", str(out), "--t-end", "0.01", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(match, err[0]), err
    assert not out.exists()


@pytest.fixture(scope="module")
def rrr3_result(tmp_path_factory):
    out = tmp_path_factory.mktemp("anim") / "rrr3"
    write_results(run_study(rrr4.load_scene(RRR3), t_end=0.01), out)
    return out


def test_animate_takes_frames_fps_and_magnification(rrr3_result, tmp_path):
    gif = tmp_path / "m.gif"
    assert main(["animate", str(rrr3_result), "--out", str(gif), "--frames", "4", "--fps", "5",
                 "--magnification", "50"]) == 0
    im = Image.open(gif)
    assert im.n_frames == 4 and im.info["duration"] == 200   # 5 frames per second: 200 ms each
    from rrr4.results.animation import build, load_motion
    data, scene = load_motion(rrr3_result)
    fig, _, _ = build(data, rrr4.build(scene), 4, magnification=50.0)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("clearance circles x50," in t for t in labels)
    circle = next(p for p in fig.axes[0].patches)
    assert circle.radius == pytest.approx(50.0 * scene.joints[0].radial_clearance)


@pytest.mark.parametrize("args, match", [
    (["--frames", "0"], r"--frames: 0 is not allowed \(an integer from 1 to"),
    (["--fps", "0"], r"--fps: 0.0 is not allowed \(must be a finite number > 0\)"),
    (["--magnification", "-2"], r"--magnification: -2.0 is not allowed"),
    (["--out", "x.avi"], r"--out: .*x.avi' is not allowed \(a .gif file, or .mp4 when ffmpeg is installed\)"),
])
def test_bad_animate_options_are_one_line(rrr3_result, tmp_path, capsys, args, match):
    args = [a if a != "x.avi" else str(tmp_path / "x.avi") for a in args]
    assert main(["animate", str(rrr3_result), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(match, err[0]), err


def test_mp4_needs_ffmpeg(rrr3_result, tmp_path, capsys):
    from matplotlib.animation import writers
    out = tmp_path / "m.mp4"
    code = main(["animate", str(rrr3_result), "--out", str(out), "--frames", "3"])
    if writers.is_available("ffmpeg"):
        assert code == 0 and out.stat().st_size > 0
    else:
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and "needs ffmpeg" in err[0] and not out.exists()


def test_compiling_is_announced_and_timed_apart(tmp_path, monkeypatch):
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path / "cache"))
    heard = []
    previous = build.compile_notice(heard.append)
    try:
        before = build.compile_time()
        # a source no cache holds yet
        text = f"double rrr4_probe_{uuid.uuid4().hex}(double x) {{ return 2.0 * x; }}\n"
        build.library("probe", {"probe.c": text})
        spent = build.compile_time() - before
        build.library("probe", {"probe.c": text})   # from the cache: neither said nor timed
    finally:
        build.compile_notice(previous)
    assert heard == ["probe"] and spent > 0 and build.compile_time() - before == spent


def test_run_says_compiling_and_reports_compile_time_apart_from_wall_time(tmp_path, monkeypatch, capsys):
    """With compiled stepping and an empty cache, `rrr4 run` says 'compiling ...' on stderr and
    summary.json gives the compiler's seconds apart from the arm's wall time."""
    monkeypatch.setenv("RRR4_JIT", "1")
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "out"
    assert main(["run", str(RRR3), "--out", str(out), "--t-end", "0.005"]) == 0
    err = capsys.readouterr().err
    assert re.search(r"rrr4 run: compiling \w+ \(C compiler", err)
    s = json.loads((out / "summary.json").read_text())
    arm = s["without_preload"]
    assert arm["compile_time_s"] > 0 and s["compile_time_s"] == pytest.approx(arm["compile_time_s"])
    assert arm["wall_time_s"] > 0 and "C compile time" in (out / "report.md").read_text()
