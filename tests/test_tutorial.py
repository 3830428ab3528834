"""docs/tutorial.md, executed: its files are written and its commands run as a user would,
in an empty directory, with the `rrr4` command of this installation; then what its text
claims is checked against what the commands wrote."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial.md"
BLOCK = re.compile(r"(?:<!-- file: (?P<file>[\w.]+) -->\n)?```(?P<lang>\w+)\n(?P<body>.*?)```", re.S)


def blocks():
    """(file name or None, language, text) of every fenced block, in order."""
    return [(m["file"], m["lang"], m["body"]) for m in BLOCK.finditer(TUTORIAL.read_text(encoding="utf-8"))]


def shell(cmd: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    cmd = re.sub(r"^python ", f"{sys.executable} ", cmd)
    return subprocess.run(cmd, shell=True, cwd=cwd, env=env, capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="module")
def tutorial(tmp_path_factory):
    d = tmp_path_factory.mktemp("tutorial")
    ran = []
    for name, lang, body in blocks():
        if name:
            (d / name).write_text(body, encoding="utf-8")
        elif lang == "sh":
            for line in body.strip().splitlines():
                r = shell(line, d)
                assert r.returncode == 0, f"`{line}` exited {r.returncode}: {r.stderr[-2000:]}"
                ran.append((line, r))
    return d, ran


def test_every_block_is_used():
    kinds = {(bool(f), lang) for f, lang, _ in blocks()}
    assert kinds <= {(True, "yaml"), (True, "python"), (False, "sh")}, "a block the test would not run"
    assert {"my_robot.yaml", "my_table.yaml"} <= {f for f, _, _ in blocks()}


def test_tutorial_runs_and_its_claims_hold(tutorial):
    d, ran = tutorial
    commands = " ".join(line.split()[0] + " " + line.split()[1] for line, _ in ran if line.startswith("rrr4"))
    for cmd in ("check", "run", "animate", "codegen", "sweep", "map"):
        assert f"rrr4 {cmd}" in commands
    s = json.loads((d / "results" / "my_robot" / "summary.json").read_text())
    pre, comp, none = (s[a] for a in ("with_preload", "with_preload_compensated", "without_preload"))
    assert sum(pre["contact_loss_events"].values()) == 0 and sum(comp["contact_loss_events"].values()) == 0
    assert comp["platform_error_rms_m"] < pre["platform_error_rms_m"] < none["platform_error_rms_m"]
    assert comp["platform_error_rms_m"] < 2e-6          # the text says 1.2 um
    assert 0.8e-4 < none["platform_error_rms_m"] < 1.3e-4  # the text says 0.1 mm
    check = next(r for line, r in ran if line.startswith("rrr4 check my_robot"))
    assert "holds at every sample; peak effort 4.4 N m at actuator A4" in check.stdout
    assert (d / "my_robot.gif").stat().st_size > 0
    out = (d / "controller_output.txt").read_text().splitlines()
    assert any(line.startswith("step ") for line in out)
    rows = list(csv.DictReader(open(d / "results" / "sweeps" / "my_sweep" / "results.csv")))
    assert len(rows) == 4 and all(r["status"] == "ok" for r in rows)
    assert (d / "results" / "my_robot_map" / "map.png").exists()
    py = next(r for line, r in ran if line.startswith("python"))
    assert "contact losses: 0" in py.stdout


def test_the_graph_part_runs_and_its_claims_hold(tutorial):
    d, ran = tutorial
    check = next(r for line, r in ran if line.startswith("rrr4 check my_table"))
    assert "carriage_1: (-176.775, -300.000) mm" in check.stdout
    assert "kp = 2000 N/m, kd = 50 N s/m), |effort| <= 60 N" in check.stdout
    peak = re.search(r"holds at every sample; peak effort ([\d.]+) N at actuator", check.stdout)
    assert peak and 20 < float(peak[1]) < 24
    s = json.loads((d / "results" / "my_table" / "summary.json").read_text())
    pre, comp, none = (s[a] for a in ("with_preload", "with_preload_compensated", "without_preload"))
    assert sum(pre["contact_loss_events"].values()) == sum(comp["contact_loss_events"].values()) == 0
    assert sum(none["contact_loss_events"].values()) > 100
    assert comp["platform_error_rms_m"] < 3e-6 < 2e-5 < pre["platform_error_rms_m"] < 4e-5 < 1e-4 < \
        none["platform_error_rms_m"]
    out = (d / "table_controller_output.txt").read_text().splitlines()
    assert out[0].startswith("# t [s], tau [N] (4), alpha [N] (1)") and any(x.startswith("step ") for x in out)


def test_the_tight_limit_the_text_describes(tutorial):
    d, _ = tutorial
    text = (d / "my_robot.yaml").read_text().replace("torque_limit: 6.0", "torque_limit: 4.0")
    (d / "tight.yaml").write_text(text)
    r = shell("rrr4 check tight.yaml", d)
    assert r.returncode == 1
    assert "actuator A4 needs 4.4 N m at t = 0.058 s against its limit 4 N m" in r.stdout
    assert "rrr4 map" in r.stdout


def test_the_driven_crank_starts_from_rest_as_the_text_says(tutorial):
    d, ran = tutorial
    check = next(r for line, r in ran if line.startswith("rrr4 check my_crank"))
    assert ("motor: joint O from 0 deg, quintic law: 1600 deg in 0.2 s (mean 1333.33 rpm), then at rest"
            in check.stdout)
    py = next(r for line, r in ran if line.startswith("python my_crank"))
    runs = dict(re.findall(r"^(instant|smooth) start: (.*)$", py.stdout, re.M))
    numbers = {k: [float(x) for x in re.findall(r"[\d.]+(?= (?:N|rpm)\b)|(?<=losses )\d+", v)]
               for k, v in runs.items()}
    (li, fi, ti, vi), (ls, fs, ts, vs) = numbers["instant"], numbers["smooth"]
    assert vi == vs == 2500.0                      # both end at the quintic law's peak speed
    assert ls < li and fs < fi / 2 and ts < ti / 2  # the table: 37 < 67 losses, 6.2 < 19.3 kN, 233 < 531 N m
    assert 15e3 < fi < 25e3 and 4e3 < fs < 9e3
