"""What a new user of their own mechanism meets: a scene that names no assembly mode is told
which branch it took and which others close (with the entries that name them), in `rrr4
check` and when something fails on that branch; a point task takes a pose's first two
entries everywhere; the workspace map names a point task as the point it is."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import rrr4
from rrr4.problem import build
from rrr4.results.figures.map import map_labels

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _unnamed(tmp_path, name: str) -> Path:
    """`name`'s scene without its assembly mode and pose guesses, written to tmp_path."""
    data = yaml.safe_load((PROBLEMS / f"{name}.yaml").read_text())
    data["mechanism"].pop("assembly", None)
    for b in data["mechanism"]["bodies"]:
        b.pop("pose", None)
    data["name"] = f"my_{name}"
    path = tmp_path / f"my_{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_check_names_the_branch_it_took_the_others_and_how_to_name_one(tmp_path):
    """The reference 4-RRR written as a graph without its named mode assembles on another
    branch, where the preload cannot hold: `check` lists the branches that close, exits 1 and
    says another branch may be the one meant; named as the shipped scene names it, it passes."""
    path = _unnamed(tmp_path, "paper_circle_graph")
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 1, r.stderr
    hint = [line for line in r.stdout.splitlines() if "assembly branches close here" in line]
    assert len(hint) == 1 and "(the one taken: [{joint: B1, bend:" in hint[0] and "e.g. [" in hint[0]
    last = r.stderr.strip().splitlines()[-1]
    assert "preload cannot hold" in last and "name it in mechanism.assembly" in last
    named = rrr4.load_scene(PROBLEMS / "paper_circle_graph.yaml")
    assert build(named).branch_hint == ""  # a named mode: nothing to add


def test_branches_tell_apart_every_knee_sign_that_closes():
    """The five-bar without a named mode: its two knees (B1, B2) close in all four sign
    combinations at the path's start, and the hint lists the three not taken."""
    data = yaml.safe_load((PROBLEMS / "redundant_five_bar.yaml").read_text())
    data["mechanism"].pop("assembly")
    problem = build(rrr4.scene.parse_scene(data, "five_bar_unnamed"))
    found = problem.mechanism.branches(problem.start_target)
    assert len(found) == 4
    hint = problem.branch_hint
    assert hint.startswith("4 assembly branches close here") and hint.count("[{joint: B1") == 4


def test_a_point_task_takes_the_first_two_entries_of_a_pose_everywhere():
    problem = build(PROBLEMS / "redundant_five_bar.yaml")
    pose, pose_d, pose_dd = np.array([0.01, -0.005, 0.7]), np.array([0.1, 0.2, 9.0]), np.array([1.0, -1.0, 5.0])
    a = problem.body_motion(pose, pose_d, pose_dd)
    b = problem.mechanism.body_motion(pose, pose_d, pose_dd)
    c = problem.body_motion(pose[:2], pose_d[:2], pose_dd[:2])
    for x, y, z in zip(a, b, c, strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
        np.testing.assert_allclose(x, z, rtol=0, atol=0)
    with pytest.raises(rrr4.SceneError, match="target"):
        problem.body_motion(pose[:1], pose_d[:1], pose_dd[:1])


def test_the_workspace_map_names_a_point_task_as_its_point():
    five_bar = build(PROBLEMS / "redundant_five_bar.yaml")
    assert map_labels(five_bar, 0.0) == ("task point on distal_3", "of the task point on distal_3 (its angle free)")
    paper = build(PROBLEMS / "paper_circle.yaml")
    assert map_labels(paper, 0.0) == ("platform", "at theta = 0 rad")
