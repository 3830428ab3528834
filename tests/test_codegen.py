"""Generated C: builds warning-free with plain gcc, and computes what the Python model computes."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from rrr4 import Mechanism, SceneError, build, load_scene
from rrr4.cli import main as cli_main
from rrr4.codegen import (
    EXAMPLE_ANGLE_OFFSET,
    KERNELS,
    build_example,
    codegen,
    compile_library,
    load_library,
    preload_branch,
)
from rrr4.control import controller_function
from rrr4.preload.exact import exact_preload_function
from rrr4.preload.qp import qp_preload_function
from rrr4.scene import parse_scene
from rrr4.trajectory import trajectory_function

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

N_RANDOM = 200
TOL = 1e-10
STANDARD_HEADERS = {"math.h", "stdio.h", "stdarg.h", "string.h", "stdlib.h", "stddef.h", "stdint.h"}


@pytest.fixture(scope="module")
def built(tmp_path_factory, paper_scene):
    """Sources in src/; the shared library (-Werror) and the plain `gcc -O2 -Wall *.c -lm`
    build run side by side, since each compiles the whole generated file."""
    root = tmp_path_factory.mktemp("codegen")
    src = root / "src"
    branch = preload_branch(build(paper_scene))
    files = codegen(paper_scene, src, branch=branch)
    plain = subprocess.Popen(["gcc", "-O2", "-Wall", *sorted(p.name for p in src.glob("*.c")), "-lm"],
                             cwd=src, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lib = compile_library(src, root / "librrr4.so", flags=("-O2", "-Wall", "-Werror"))
    _, plain_err = plain.communicate()
    return {"branch": branch, "src": src, "files": files, "lib": lib, "plain_rc": plain.returncode,
            "plain_err": plain_err, "a_out": src / "a.out"}


@pytest.fixture(scope="module")
def example_output(built, tmp_path_factory):
    """stdout of the example main.c, built with -O2 -Wall -Werror."""
    exe = build_example(built["src"], tmp_path_factory.mktemp("example") / "example")
    return subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout


def _motions(rng, k):
    """Random reachable desired motions around the workspace centre: (3, k) arrays."""
    pose = np.vstack([rng.uniform(-0.05, 0.05, (2, k)), rng.uniform(-0.25, 0.25, (1, k))])
    pose_d = rng.normal(size=(3, k)) * np.array([[0.3], [0.3], [1.0]])
    pose_dd = rng.normal(size=(3, k)) * np.array([[3.0], [3.0], [10.0]])
    return pose, pose_d, pose_dd


def _outputs(f, *args):
    out = f(*args)
    return [np.array(o) for o in (out if isinstance(out, (tuple, list)) else [out])]


def test_codegen_writes_sources_header_example_and_makefile(built):
    names = {p.name for p in built["files"]}
    assert names == {"rrr4_raw.c", "rrr4_raw.h", "rrr4.h", "rrr4.c", "main.c", "Makefile"}
    header = (built["src"] / "rrr4.h").read_text()
    for k in KERNELS:
        assert re.search(rf"\bint rrr4_{k}\(", header), k
    # units are stated for every argument of every wrapper
    for line in header.splitlines():
        if line.startswith(" *   in ") or line.startswith(" *   out "):
            assert "[" in line, line
    assert not list(built["src"].glob(".*")), "temporary files left behind"


def test_sources_need_only_the_c_standard_library(built):
    local = {p.name for p in built["src"].glob("*.h")}
    for path in built["src"].glob("*.c"):
        for inc in re.findall(r'#include\s*[<"]([^>"]+)[>"]', path.read_text()):
            assert inc in STANDARD_HEADERS | local, f"{path.name} includes {inc}"
    assert "casadi/" not in (built["src"] / "rrr4_raw.c").read_text()


def test_directory_builds_with_plain_gcc_without_warnings(built):
    assert built["plain_rc"] == 0, built["plain_err"]
    assert built["plain_err"].strip() == ""
    assert built["a_out"].exists()


def test_every_compiled_kernel_matches_python_on_random_inputs(built, paper_scene):
    rng = np.random.default_rng(7)
    mech = Mechanism.from_scene(paper_scene)
    branch = built["branch"]
    inv, exact = build(paper_scene).inverse_dynamics(), exact_preload_function(build(paper_scene), branch=branch)
    J_and_s = mech.jacobian_function
    cases = {
        "ik": lambda p: mech.ik_function(p, mech.modes),
        "jacobian": lambda p: J_and_s(p)[::3],
        "null_space": mech.null_space_function,
        "trajectory": trajectory_function(paper_scene.path),
        "inverse_dynamics": inv,
        "exact_preload": exact,
        "preload": lambda p, pd, pdd: exact(*inv(p, pd, pdd)),
        "controller_step": controller_function(build(paper_scene)),
        "qp_preload": qp_preload_function(build(paper_scene), "qrqp"),
    }
    assert set(cases) == set(KERNELS)
    compiled = load_library(built["lib"])
    pose, pose_d, pose_dd = _motions(rng, N_RANDOM)
    times = np.linspace(-0.1, paper_scene.path.duration + 0.1, N_RANDOM)
    qp_failures = 0
    for k in range(N_RANDOM):
        motion = (pose[:, k], pose_d[:, k], pose_dd[:, k])
        family = [np.array(v) for v in inv(*motion)]
        # measured angles off the reference, some by a full turn (wrapped encoder readings)
        theta = mech.ik(motion[0]) + rng.normal(scale=0.05, size=4) + 2 * np.pi * rng.integers(-1, 2, size=4)
        args = {
            "ik": motion[:1], "jacobian": motion[:1], "null_space": motion[:1], "trajectory": (times[k],),
            "inverse_dynamics": motion, "exact_preload": family, "preload": motion,
            "controller_step": (*motion, theta, rng.normal(scale=0.5, size=4)),
            "qp_preload": family,
        }
        for name, reference in cases.items():
            want = _outputs(reference, *args[name])
            try:
                got = _outputs(compiled[name], *args[name])
            except RuntimeError:  # the C returned non-zero: only allowed for an infeasible QP
                assert name == "qp_preload" and want[2].item() == 0.0, f"{name}, sample {k}"
                qp_failures += 1
                continue
            assert len(got) == len(want)
            for g, w in zip(got, want, strict=True):
                np.testing.assert_allclose(g.ravel(order="F"), w.ravel(order="F"), rtol=TOL, atol=TOL,
                                           err_msg=f"{name}, sample {k}")
    assert qp_failures < N_RANDOM // 2, "too few feasible QPs to compare"


def test_example_prints_what_the_python_controller_computes(built, example_output, paper_scene):
    rows = {}
    for line in example_output.splitlines():
        if not line.startswith("#"):
            tag, *vals = line.split()
            rows.setdefault(tag, []).append(np.array(vals, dtype=float))
    mech = Mechanism.from_scene(paper_scene)
    traj, step = trajectory_function(paper_scene.path), controller_function(build(paper_scene))

    kin = rows["kinematics"][0]
    pose0 = np.array(traj(0.0)[0]).ravel()
    np.testing.assert_allclose(kin[1:5], mech.ik(pose0), rtol=TOL, atol=TOL)
    np.testing.assert_allclose(kin[5:17], mech.jacobian(pose0).ravel(order="F"), rtol=TOL, atol=TOL)
    np.testing.assert_allclose(rows["null_space"][0][1:], mech.null_space(pose0), rtol=TOL, atol=TOL)

    steps = rows["step"]
    assert len(steps) == 11 and steps[-1][0] == pytest.approx(paper_scene.path.duration)
    for row in steps:
        pose, pose_d, pose_dd = (np.array(v).ravel() for v in traj(row[0]))
        theta = mech.ik(pose) - EXAMPLE_ANGLE_OFFSET * np.arange(1, 5)
        theta_d = mech.jacobian(pose) @ pose_d
        tau, _, _, _, alpha, feasible = _outputs(step, pose, pose_d, pose_dd, theta, theta_d)
        np.testing.assert_allclose(row[1:5], tau.ravel(), rtol=TOL, atol=TOL)
        np.testing.assert_allclose(row[5:7], [alpha.item(), feasible.item()], rtol=TOL, atol=TOL)


def test_example_preload_is_feasible_and_stays_on_one_branch(built, example_output):
    """Along the reference path the generated controller never flips the preload sign, so no
    bearing force reverses; the global optimum per instant (branch 0) would."""
    assert f"#define RRR4_PRELOAD_BRANCH {built['branch']}" in (built["src"] / "rrr4.h").read_text()
    assert built["branch"] in (1, -1)
    steps = np.array([line.split()[1:] for line in example_output.splitlines() if line.startswith("step")], dtype=float)
    alpha, feasible = steps[:, 5], steps[:, 6]
    assert np.all(feasible == 1.0)
    assert np.all(built["branch"] * alpha > 0)


@pytest.mark.parametrize("method", ["exact", "qp"])
def test_controller_step_is_feedforward_plus_clipped_pd(paper_data, method):
    """tau = clip(tau_ff + kp wrap(ik(pose) - theta) + kd (J pose_d - theta_d), +-limit),
    with tau_ff the scene's preload of the desired motion (exact on a branch, or the QP)."""
    paper_data["actuation"]["preload"]["method"] = method
    scene = parse_scene(paper_data)
    rng = np.random.default_rng(3)
    mech = Mechanism.from_scene(scene)
    problem = build(scene)
    step = controller_function(problem, sign=1)
    inv = problem.inverse_dynamics()
    exact = (exact_preload_function(problem, branch=1) if method == "exact" else
             qp_preload_function(problem, "qrqp", 1.0))
    a, lim = scene.actuation, np.array(scene.torque_limit)
    saturated = 0
    for _ in range(40):
        pose, pose_d, pose_dd = (v[:, 0] for v in _motions(rng, 1))
        error = rng.normal(scale=0.02, size=4)
        theta = mech.ik(pose) - error + 2 * np.pi * rng.integers(-1, 2, size=4)
        theta_d = rng.normal(scale=0.5, size=4)
        tau, tau_ff, _, _, alpha, _ = _outputs(step, pose, pose_d, pose_dd, theta, theta_d)
        alpha_ref, tau_ref, feasible, _ = _outputs(exact, *inv(pose, pose_d, pose_dd))
        if feasible.item() == 0.0 and method == "qp":  # qrqp's answer is undefined there
            continue
        np.testing.assert_allclose(tau_ff.ravel(), tau_ref.ravel(), rtol=1e-9, atol=1e-9)
        assert alpha.item() == pytest.approx(alpha_ref.item(), abs=1e-9)
        pd = tau_ref.ravel() + a.kp * error + a.kd * (mech.jacobian(pose) @ pose_d - theta_d)
        np.testing.assert_allclose(tau.ravel(), np.clip(pd, -lim, lim), rtol=1e-9, atol=1e-9)
        saturated += np.any(np.abs(pd) > lim)
    assert saturated > 0, "no sample exercised the torque limits"


def test_codegen_rejects_a_file_as_output_directory(paper_scene, tmp_path):
    f = tmp_path / "taken"
    f.write_text("keep me")
    with pytest.raises(SceneError, match="--out"):
        codegen(paper_scene, f)
    assert f.read_text() == "keep me"


def test_codegen_rejects_a_scene_without_a_task_and_keeps_earlier_files(tmp_path):
    """A driven mechanism (no task body: its drivers prescribe the motion) has no controller."""
    scene = load_scene(Path(__file__).resolve().parents[1] / "problems" / "flores_slider_crank.yaml")
    (tmp_path / "rrr4.h").write_text("/* earlier */")
    with pytest.raises(SceneError, match="mechanism.task: scene 'flores_slider_crank' has no task body"):
        codegen(scene, tmp_path, branch=1)
    assert [p.name for p in tmp_path.iterdir()] == ["rrr4.h"]
    assert (tmp_path / "rrr4.h").read_text() == "/* earlier */"


def test_codegen_rejects_an_unknown_preload_branch(paper_scene, tmp_path):
    with pytest.raises(SceneError, match="branch"):
        codegen(paper_scene, tmp_path, branch=2)
    assert not list(tmp_path.iterdir())


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_makefile_builds_the_example_and_library_from_the_generated_files(built):
    plan = subprocess.run(["make", "-n", "-B", "example", "librrr4.so"], cwd=built["src"], capture_output=True,
                          text=True, check=True).stdout
    compiled = set(re.findall(r"(\S+\.c)\b", plan))
    assert compiled == {p.name for p in built["src"].glob("*.c")}
    assert "-shared" in plan and "-lm" in plan


def test_cli_codegen_writes_files_and_reports_bad_output_in_one_line(tmp_path, capsys):
    scene = Path(__file__).resolve().parents[1] / "problems" / "paper_circle.yaml"
    out = tmp_path / "c"
    assert cli_main(["codegen", str(scene), "--out", str(out)]) == 0
    assert (out / "rrr4.h").exists() and (out / "main.c").exists()
    capsys.readouterr()
    assert cli_main(["codegen", str(scene), "--out", str(out / "rrr4.h")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "SceneError" in err and "--out" in err


def test_external_library_reports_the_generated_signatures(built, paper_scene):
    """casadi.external sees the names and shapes the header documents."""
    lib = load_library(built["lib"], ["controller_step", "inverse_dynamics"])
    f = lib["controller_step"]
    assert [f.name_in(i) for i in range(f.n_in())] == ["pose_des", "pose_d_des", "pose_dd_des", "theta", "theta_d"]
    assert f.size_out(0) == (4, 1)
    g = lib["inverse_dynamics"]
    assert g.size_out(2) == (2, 8) and g.size_out(3) == (2, 8)


def test_the_library_cache_keeps_requested_sources_beside_the_library_and_compiles_once(tmp_path, monkeypatch):
    """rrr4.codegen.build.library: one library per C text in $RRR4_CACHE, its headers only
    included, its sources (on request) in <stem>_<key>/ for a later library to compile in;
    asking again compiles nothing, and a second library compiles the kept source in."""
    from rrr4.codegen import build as cache
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    sources = {"twice.h": "double twice(double x);\n",
               "twice.c": '#include "twice.h"\ndouble twice(double x) { return 2.0 * x; }\n'}
    n0 = cache.compilations()
    lib = cache.library("twice", sources, keep_sources=True)
    assert cache.library("twice", sources, keep_sources=True) == lib and cache.compilations() == n0 + 1
    assert lib.parent == tmp_path and lib.name.startswith("twice_") and lib.suffix == ".so"
    kept = lib.with_suffix("")
    assert {p.name: p.read_text() for p in kept.iterdir()} == sources
    user = {"quad.c": "double twice(double x);\ndouble quad(double x) { return twice(twice(x)); }\n"}
    assert cache.library("quad", user, extra=[kept / "twice.c"]).exists() and cache.compilations() == n0 + 2
    assert len(list(tmp_path.glob("*.so"))) == 2
