"""Time-optimal path following (rrr4.optimal) and the tabulated time law a scene carries."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import rrr4
from rrr4.errors import InfeasibleError, SceneError
from rrr4.optimal import optimal_time_law, path_family
from rrr4.trajectory import trajectory_function

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "problems" / "paper_circle.yaml"
TABLE = ROOT / "problems" / "xyt_table.yaml"
FIVE_BAR = ROOT / "problems" / "redundant_five_bar.yaml"
MOVING_MASS = 2.0 + 1.0 + 0.5  # kg: both carriages and the table move along x


@pytest.fixture(scope="module")
def paper():
    return rrr4.build(PAPER)


@pytest.fixture(scope="module")
def law(paper):
    return optimal_time_law(paper, points=200)


@pytest.mark.parametrize("path", [PAPER, FIVE_BAR])
def test_family_is_affine_in_acceleration_and_squared_speed(path):
    """The coefficients reproduce the problem's own effort family at any (a, b)."""
    problem = rrr4.build(path)
    fam = path_family(problem, np.linspace(0.0, 1.0, 7))
    rng = np.random.default_rng(1)
    a, b = rng.normal(0, 30, 7), rng.uniform(0, 40, 7)
    alpha = rng.normal(0, 2, (7, fam.tau_n.shape[2]))
    direct = problem.effort_family(fam.pose, fam.pose_s * np.sqrt(b)[:, None],
                                   fam.pose_s * a[:, None] + fam.pose_ss * b[:, None])
    tau = direct.tau_p + np.einsum("knm,km->kn", direct.tau_n, alpha)
    r = direct.r_p + np.einsum("kjcm,km->kjc", direct.r_n, alpha)
    assert np.allclose(fam.efforts(a, b, alpha), tau, rtol=1e-10, atol=1e-10 * np.abs(tau).max())
    assert np.allclose(fam.reactions(a, b, alpha), r, rtol=1e-10, atol=1e-10 * np.abs(r).max())


@pytest.mark.parametrize("points", [11, 100, 101, 400])
def test_bang_bang_along_a_prismatic_axis(points):
    """Rest to rest over L with the x force limited to F: T = 2 sqrt(m L / F), exactly where
    the switch falls on a grid point (N even), else from above and second order in 1/N."""
    law = optimal_time_law(TABLE, points=points, contact=False)
    exact = 2 * np.sqrt(MOVING_MASS * 0.2 / 50.0)
    if points % 2 == 0:
        assert law.duration == pytest.approx(exact, rel=1e-6)
    else:
        assert 0 < law.duration / exact - 1 <= 0.15 / points**2
    assert law.statistics["success"]
    assert np.abs(law.efforts[:, 0]).max() <= 50.0 * (1 + 1e-8)
    assert law.binding_counts()["actuator FX"] > 0.9 * points


def test_bang_bang_turn_of_a_revolute_axis():
    """A 1-DOF turn of Theta with the torque limited to T: 2 sqrt(I Theta / T)."""
    scene = rrr4.load_scene(TABLE)
    turn = replace(scene, path=replace(scene.path, end=(0.0, 0.0, 1.0)))
    law = optimal_time_law(turn, points=200, contact=False)
    assert law.duration == pytest.approx(2 * np.sqrt(0.004 * 1.0 / 0.5), rel=1e-6)


def test_reference_scene_meets_every_constraint_at_every_point(law, paper):
    limits = np.asarray(law.torque_limit)
    assert law.statistics["success"] and law.contact and law.sign in (1, -1)
    assert np.all(np.abs(law.efforts) <= limits * (1 + 1e-7))
    assert law.axial.min() >= law.f_min * (1 - 1e-7)
    # the efforts are the inverse dynamics of the resulting motion
    fam = paper.effort_family(law.pose, law.pose_d, law.pose_dd)
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, law.alpha)
    assert np.abs(tau - law.efforts).max() <= 1e-9 * np.abs(law.efforts).max()
    # the time grid is the constant-acceleration motion of the grid
    seg = np.diff(law.t)
    assert np.allclose(np.diff(law.s), 0.5 * seg * (law.s_dot[:-1] + law.s_dot[1:]), rtol=1e-9)
    assert np.allclose(np.diff(law.s_dot), law.s_ddot[:-1] * seg, atol=1e-9 * law.s_dot.max())
    # both signs of the contact condition solved, the faster kept
    by_sign = law.statistics["duration_by_sign"]
    assert set(by_sign) == {"+1", "-1"} and law.duration == pytest.approx(min(v for v in by_sign.values() if v))
    # something binds at (almost) every point of a time-optimal law
    assert sum(bool(b) for b in law.binding) > 0.9 * len(law.s)


def test_what_the_contact_condition_and_the_null_space_cost(law, paper):
    free = optimal_time_law(paper, points=200, contact=False)
    minimum_norm = optimal_time_law(paper, points=200, contact=False, null_space=False)
    assert free.duration < law.duration            # keeping contact costs cycle time
    assert free.duration <= minimum_norm.duration * (1 + 1e-7)   # alpha free is a relaxation of alpha = 0
    assert np.all(minimum_norm.alpha == 0.0)


def test_effort_objective_at_a_given_duration(law, paper):
    slow = optimal_time_law(paper, "effort", points=100, duration=1.5 * law.duration)
    assert slow.duration == pytest.approx(1.5 * law.duration, rel=1e-7)
    assert slow.axial.min() >= slow.f_min * (1 - 1e-7)
    # less effort than the time-optimal law at the same grid, which is slower and unsaturated
    assert np.abs(slow.efforts).max() < np.abs(law.efforts).max()
    mixed = optimal_time_law(paper, "time+effort", points=100, effort_weight=0.01)
    assert law.duration * (1 - 1e-6) <= mixed.duration


def test_duration_converges_with_the_grid(paper):
    durations = [optimal_time_law(paper, points=n, sign=1).duration for n in (50, 100, 200, 400)]
    steps = np.abs(np.diff(durations))
    assert steps[-1] < steps[0] and steps[-1] < 2e-3 * durations[-1]


def test_a_scene_carries_the_optimal_time_law(law, paper, tmp_path):
    law.save_table(tmp_path / "optimal_time_law.csv")
    text = PAPER.read_text().replace("  duration: 1.0               # s\n  time_law: quintic",
                                     "  time_law: table\n  time_table: optimal_time_law.csv")
    assert "time_table" in text
    (tmp_path / "paper_optimal.yaml").write_text(text)
    scene = rrr4.load_scene(tmp_path / "paper_optimal.yaml")
    assert scene.path.duration == pytest.approx(law.duration, rel=1e-12)
    assert scene == paper.scene.with_time_table(law.table)
    pose, pose_d, pose_dd = (np.array(v).T for v in trajectory_function(scene.path).map(len(law.t))(law.t[None, :]))
    assert np.abs(pose - law.pose).max() < 1e-12
    assert np.abs(pose_d - law.pose_d).max() < 1e-9
    # between grid points: s(t) piecewise quadratic, so the rates stay those of the law's segments
    mid = 0.5 * (law.t[:-1] + law.t[1:])
    _, pd_mid, _ = (np.array(v).T for v in trajectory_function(scene.path).map(len(mid))(mid[None, :]))
    s_dot_mid = law.s_dot[:-1] + law.s_ddot[:-1] * np.diff(law.t) / 2
    fam = path_family(paper, law.s)  # pose_s varies along a segment: compare speeds, loosely
    assert np.allclose(np.linalg.norm(pd_mid[:, :2], axis=1), np.linalg.norm(fam.pose_s[:-1, :2], axis=1) * s_dot_mid,
                       rtol=0.05, atol=1e-6)


@pytest.mark.parametrize("rows, words", [
    ([(0, 0, 0), (1, 1, 1)], "not a constant acceleration"),
    ([(0, 0, 0), (0.5, 0.25, 1), (0.4, 1, 0)], "t must increase"),
    ([(0, 0, 0), (1, 0.5, 1)], "ends at s = 0.5"),
    ([(0, 0, 0), (1, 1, -2)], "s_dot = -2"),
    ([(0, 0, 0), (1, float("nan"), 1)], "finite"),
    ([(0, 0, 0)], "at least 2"),
    ([[0, 0]], r"row 0 \[0, 0\] is not allowed \(three numbers"),
    ([(0, 0, 0), (1, "a", 1)], r"row 1 \(1, 'a', 1\) is not allowed"),
])
def test_bad_time_tables_end_in_one_line(rows, words):
    scene = rrr4.load_scene(PAPER)
    with pytest.raises(SceneError, match=words) as e:
        scene.with_time_table(rows)
    assert "\n" not in str(e.value)


def test_bad_time_table_files_end_in_one_line(tmp_path):
    base = PAPER.read_text().replace("  duration: 1.0               # s\n  time_law: quintic",
                                     "  time_law: table\n  time_table: law.csv")
    (tmp_path / "s.yaml").write_text(base)
    with pytest.raises(SceneError, match="path.time_table: 'law.csv' is not allowed .no such file"):
        rrr4.load_scene(tmp_path / "s.yaml")
    (tmp_path / "law.csv").write_text("t,s\n0,0\n1,1\n")
    with pytest.raises(SceneError, match="lacks the column.s. s_dot"):
        rrr4.load_scene(tmp_path / "s.yaml")
    (tmp_path / "law.csv").write_text("t,s,s_dot\n0,0,0\n1,1,2\n")
    (tmp_path / "s.yaml").write_text(base.replace("  time_law: table", "  duration: 2.0\n  time_law: table"))
    with pytest.raises(SceneError, match="path.duration: 2 s is not allowed .the time table ends at 1 s"):
        rrr4.load_scene(tmp_path / "s.yaml")
    (tmp_path / "q.yaml").write_text(PAPER.read_text().replace("time_law: quintic", "time_law: quintic\n  "
                                                                                    "time_table: law.csv"))
    with pytest.raises(SceneError, match="time_table: not allowed with time_law 'quintic'"):
        rrr4.load_scene(tmp_path / "q.yaml")


def test_infeasible_paths_name_where_and_which_constraint(paper):
    weak = paper.scene.with_torque_limit(0.05)
    words = r"path infeasible at s = 0 .*: the contact condition .f_min 10 N at every passive joint, sign .1. needs"
    with pytest.raises(InfeasibleError, match=words + r" actuator A\d at .* > its limit 0.05") as e:
        optimal_time_law(weak, points=50)
    assert "\n" not in str(e.value)
    # without the contact condition, a vertical plane with tiny limits cannot hold the platform up
    heavy = replace(weak, effects=replace(weak.effects, gravity=(0.0, -9.81)))
    with pytest.raises(InfeasibleError, match=r"actuator A\d needs .* > its limit 0.05 to hold it at rest"):
        optimal_time_law(heavy, points=50, contact=False)
    with pytest.raises(InfeasibleError, match=r"the contact condition .f_min 10000 N .* > its limit 5 at rest"):
        optimal_time_law(paper, points=50, f_min=1e4)


@pytest.mark.parametrize("kwargs, words", [
    ({"points": 1}, "points: 1 is not allowed"),
    ({"points": 10.5}, "points: 10.5 is not allowed"),
    ({"objective": "fast"}, "objective: unknown value 'fast'"),
    ({"objective": "effort"}, "duration: missing"),
    ({"sign": 2}, "sign: 2 is not allowed"),
    ({"end_speeds": (0.0,)}, "end_speeds"),
    ({"max_speed": -1.0}, "max_speed"),
])
def test_bad_arguments_end_in_one_line(paper, kwargs, words):
    with pytest.raises(SceneError, match=words):
        optimal_time_law(paper, **kwargs)


def test_contact_condition_needs_redundancy():
    with pytest.raises(SceneError, match="contact: True is not allowed for this scene"):
        optimal_time_law(TABLE, points=20)


def test_speed_bounds_bind():
    law = optimal_time_law(TABLE, points=100, contact=False, max_task_speed=0.5)
    assert law.statistics["success"]
    assert np.max(np.linalg.norm(law.pose_d[:, :2], axis=1)) <= 0.5 * (1 + 1e-7)
    assert law.binding_counts().get("task speed", 0) > 10
    acc = optimal_time_law(TABLE, points=100, contact=False, max_task_acceleration=5.0)
    assert np.max(np.linalg.norm(acc.pose_dd[:, :2], axis=1)) <= 5.0 * (1 + 1e-6)
    assert acc.duration > optimal_time_law(TABLE, points=100, contact=False).duration


def test_replay_keeps_contact_at_the_optimal_duration(paper, tmp_path):
    """The design card's loop on the reference scene: every arm of the study replays the
    optimal law, and the preloaded arms lose no contact."""
    from rrr4.results.optimal import write_optimization
    from rrr4.studies.optimize import optimize
    opt = optimize(paper, points=200)
    assert set(opt.replay.arms) == {"with_preload", "with_preload_compensated", "without_preload"}
    for name, arm in opt.replay.arms.items():
        assert arm.simulation.t[-1] == pytest.approx(opt.law.duration, abs=1.01e-4)
        losses = sum(arm.simulation.contact_loss_events.values())
        assert (losses == 0) if name != "without_preload" else (losses > 0)
    assert opt.headroom is None
    assert opt.limits_only.duration < opt.law.duration
    summary, files = write_optimization(opt, tmp_path / "out", animate=False)
    assert summary["contact_cost_ratio"] == pytest.approx(opt.law.duration / opt.limits_only.duration)
    assert summary["replay"]["with_preload"]["contact_loss_events"] == {j: 0 for j in paper.clearance_joints}
    for f in ("phase_plane.png", "efforts.png", "contact_margin.png", "time_law.csv", "optimization.json",
              "replay/summary.json"):
        assert f in files and (tmp_path / "out" / f).is_file()
    again = rrr4.load_scene(PAPER).with_time_table(rrr4.scene.read_time_table(tmp_path / "out" / "time_law.csv"))
    assert again.path.duration == pytest.approx(opt.law.duration, rel=1e-12)


def test_optimize_command_line(tmp_path):
    import subprocess
    import sys
    out = tmp_path / "xyt"
    cmd = [sys.executable, "-m", "rrr4.cli", "optimize", str(TABLE), "--no-replay", "--points", "100",
           "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert "optimal duration: 0.236643" in r.stdout
    assert (out / "phase_plane.png").is_file() and not (out / "contact_margin.png").exists()
    bad = subprocess.run([*cmd[:5], "--objective", "effort", "--out", str(tmp_path / "bad")], capture_output=True,
                         text=True, cwd=ROOT)
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "duration: missing" in bad.stderr
    assert not (tmp_path / "bad").exists()  # writes nothing


@pytest.mark.skipif(__import__("shutil").which("gcc") is None, reason="needs gcc")
def test_generated_c_follows_the_optimal_time_law(law, paper, tmp_path):
    """codegen on a scene carrying the law: the compiled trajectory kernel is the law's motion."""
    from rrr4.codegen import codegen, compile_library, load_library
    scene = paper.scene.with_time_table(law.table)
    codegen(scene, tmp_path / "src", branch=1)
    lib = load_library(compile_library(tmp_path / "src", tmp_path / "librrr4.so"), ["trajectory"])["trajectory"]
    python = trajectory_function(scene.path)
    t = np.r_[law.t[::7], np.random.default_rng(2).uniform(0, law.duration, 40), law.duration + 0.1]
    for tk in t:
        for c, p in zip(lib(tk), python(tk), strict=True):
            assert np.allclose(np.array(c), np.array(p), rtol=1e-12, atol=1e-12)
    at_grid = np.array([np.array(lib(tk)[0]).ravel() for tk in law.t[::7]])
    assert np.abs(at_grid - law.pose[::7]).max() < 1e-12


def test_optimize_a_point_to_point_motion_writes_its_path(paper, tmp_path):
    from rrr4.results.optimal import write_optimization
    from rrr4.studies.optimize import motion_scene, optimize
    opt = optimize(paper, target=(0.02, 0.0, 0.0), nodes=10, replay=False)
    assert opt.curves is None and opt.limits_only.duration < opt.law.duration
    summary, files = write_optimization(opt, tmp_path / "p2p", animate=False)
    assert {"task_path.png", "efforts.png", "contact_margin.png", "motion.csv", "motion_limits_only.csv"} <= set(files)
    assert summary["contact_cost_ratio"] > 1.0
    follow = motion_scene(paper.scene, opt.law)   # the replay's path: a spline through the nodes, at their times
    pose = np.array(trajectory_function(follow.path).map(len(opt.law.t))(opt.law.t[None, :])[0]).T
    assert np.abs(pose - opt.law.pose).max() < 1e-12


def test_a_path_through_a_singularity_or_out_of_reach_ends_in_one_line(paper):
    scene = paper.scene
    far = replace(scene, path=replace(scene.path, type="line", start=(0.0, 0.0, 0.0), end=(0.3, 0.0, 0.0)))
    with pytest.raises(InfeasibleError, match=r"path infeasible at s = 0\.\d+ .*(out of reach|near-singular)") as e:
        optimal_time_law(far, points=50)
    assert "\n" not in str(e.value)
