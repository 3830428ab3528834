"""Generated C for the controller of any scene with a task body and actuators: the table step
of a graph (references tabulated along the path, piecewise cubics, the feedback law), the
closed-form step of an n-RRR other than the 4-RRR, compiled with gcc and compared with the
Python controller at many samples; in the loop; and the refusal of a scene without a task."""

import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rrr4 import SceneError, build, load_scene, simulate
from rrr4.cli import main as cli_main
from rrr4.codegen import (
    EXAMPLE_ANGLE_OFFSET,
    STEP_KERNELS,
    build_example,
    codegen,
    compile_library,
    generated_controller,
    kernels,
    load_library,
)
from rrr4.control import (
    controller_function,
    controller_step,
    feedback_function,
    interpolants,
    reference_grid,
    step_inputs,
    tabulated,
)
from rrr4.studies.study import study_controller

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
N_RANDOM = 400


def _act(scene, **kw):
    return replace(scene, actuation=replace(scene.actuation, **kw))


def _generated(scene, root: Path) -> dict:
    """codegen of `scene` into root/src, its kernels compiled with -Werror and loaded, and the
    example's stdout."""
    src = root / "src"
    files = codegen(scene, src)
    lib = compile_library(src, root / "librrr4.so")
    exe = build_example(src, root / "example")
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    return {"problem": build(scene), "src": src, "files": files, "c": load_library(lib, STEP_KERNELS),
            "example": out}


@pytest.fixture(scope="module")
def five_bar(tmp_path_factory):
    return _generated(load_scene(PROBLEMS / "redundant_five_bar.yaml"), tmp_path_factory.mktemp("five_bar"))


@pytest.fixture(scope="module")
def three_rrr(tmp_path_factory):
    return _generated(load_scene(PROBLEMS / "rrr3_circle.yaml"), tmp_path_factory.mktemp("rrr3"))


def _outputs(f, *args):
    return [np.array(v) for v in f.map(args[0].shape[1])(*args)]


def _random_states(rng, problem, t):
    """Measured coordinates around the references at the times t: (n, N) theta, theta_d."""
    step = controller_step(problem)
    n, N = problem.model.n_actuators, len(t)
    refs = _outputs(step, *step_inputs(step, problem.path, t), np.zeros((n, N)), np.zeros((n, N)))
    return refs[2] + rng.normal(scale=0.02, size=(n, N)), refs[3] + rng.normal(scale=0.5, size=(n, N))


def test_graph_codegen_writes_the_step_its_path_header_example_and_makefile(five_bar):
    names = {p.name for p in five_bar["files"]}
    assert names == {"rrr4_raw.c", "rrr4_raw.h", "rrr4.h", "rrr4.c", "main.c", "Makefile"}
    header = (five_bar["src"] / "rrr4.h").read_text()
    assert "int rrr4_controller_step(double t, const double theta[3], const double theta_d[3], double tau[3]" in header
    assert "int rrr4_trajectory(double t," in header and "rrr4_ik" not in header
    assert "#define RRR4_N_ACTUATORS 3" in header
    assert f"#define RRR4_TABLE_SAMPLES {len(reference_grid(five_bar['problem']))} " in header
    for line in header.splitlines():  # units for every argument
        if line.startswith(" *   in ") or line.startswith(" *   out "):
            assert "[" in line, line


def test_graph_c_step_is_the_python_step_and_the_interpolated_references(five_bar):
    """At random times (beyond the path's ends too) and measured states: the compiled C equals
    the CasADi step, and an independent evaluation (scipy's cubics through the tabulated
    references, the feedback law) to rounding."""
    problem, c = five_bar["problem"], five_bar["c"]["controller_step"]
    rng = np.random.default_rng(1)
    T = problem.path.duration
    t = np.sort(np.r_[rng.uniform(-0.1 * T, 1.1 * T, N_RANDOM), reference_grid(problem)[::50]])
    theta, theta_d = _random_states(rng, problem, t)
    got = _outputs(c, t[None, :], theta, theta_d)
    want = _outputs(controller_step(problem), t[None, :], theta, theta_d)
    for name, a, b in zip(c.name_out(), got, want, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12, err_msg=name)
    t_s = reference_grid(problem)
    refs = tabulated(problem, t_s)
    cubic = interpolants(t_s, refs.theta_ref, refs.theta_d_ref, refs.theta_dd_ref, refs.tau_ff)
    tc = np.clip(t, 0.0, T)
    np.testing.assert_allclose(got[2], cubic["th"](tc).T, rtol=0, atol=1e-13)
    np.testing.assert_allclose(got[3], cubic["thd"](tc).T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[1], cubic["ff"](tc).T, rtol=0, atol=1e-12)
    tau = np.array(feedback_function(problem).map(len(t))(cubic["th"](tc).T, cubic["thd"](tc).T, cubic["ff"](tc).T,
                                                            theta, theta_d))
    np.testing.assert_allclose(got[0], tau, rtol=0, atol=1e-10)
    assert np.all(np.abs(got[0]) <= 5.0) and np.any(np.abs(got[0]) == 5.0)  # clipped at the limit


def test_graph_c_step_at_the_table_instants_is_the_tabulated_controller(five_bar):
    problem, c = five_bar["problem"], five_bar["c"]["controller_step"]
    t = reference_grid(problem)
    refs = tabulated(problem, t)
    n = refs.theta_ref.shape[1]
    got = _outputs(c, t[None, :], refs.theta_ref.T, refs.theta_d_ref.T)
    np.testing.assert_allclose(got[2].T, refs.theta_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(got[1].T, refs.tau_ff, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[4].T, refs.alpha, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[0].T, np.clip(refs.tau_ff, -5.0, 5.0), rtol=0, atol=1e-10)  # no error: feed-forward
    assert np.all(got[5] == 1.0) and refs.feasible.all() and n == 3


def test_graph_example_prints_what_the_python_step_commands(five_bar):
    problem = five_bar["problem"]
    rows = np.array([[float(v) for v in line.split()[1:]] for line in five_bar["example"].splitlines()
                     if line.startswith("step ")])
    assert len(rows) == 11
    t, n = rows[:, 0], problem.model.n_actuators
    step = controller_step(problem)
    refs = _outputs(step, t[None, :], np.zeros((n, len(t))), np.zeros((n, len(t))))
    theta = refs[2] - EXAMPLE_ANGLE_OFFSET * np.arange(1, n + 1)[:, None]
    out = _outputs(step, t[None, :], theta, refs[3])
    np.testing.assert_allclose(rows[:, 1:1 + n], out[0].T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rows[:, 1 + n], out[4].ravel(), rtol=0, atol=1e-12)
    assert np.all(rows[:, -1] == out[5].ravel())


def test_graph_c_controller_of_the_reference_4rrr_agrees_with_the_nrrr_one():
    """paper_circle_graph is paper_circle written as a graph, with the same preload (qp) and no
    compensation: at the table instants its C step (Newton IK, SVD family, tabulated QP
    preload) commands what the n-RRR's closed-form C step commands, to the IK's tolerance."""
    g = build(load_scene(PROBLEMS / "paper_circle_graph.yaml"))
    n = build(load_scene(PROBLEMS / "paper_circle.yaml"))
    fg, fn = generated_controller(g)[0], generated_controller(n)[0]
    t = reference_grid(g)
    rng = np.random.default_rng(2)
    ins = step_inputs(fn, n.path, t)
    theta, theta_d = (rng.normal(scale=s, size=(4, len(t))) for s in (0.01, 0.5))
    theta = theta + _outputs(fn, *ins, np.zeros((4, len(t))), np.zeros((4, len(t))))[2]
    a, b = _outputs(fg, t[None, :], theta, theta_d), _outputs(fn, *ins, theta, theta_d)
    wrap = (a[2] - b[2] + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(wrap).max() < 1e-10
    for k, tol in ((0, 1e-7), (1, 1e-9), (3, 1e-10), (4, 1e-9)):  # tau, tau_ff [N m], theta_d_ref, alpha
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=tol, err_msg=fg.name_out(k))
    assert np.all(a[5] == b[5])


def test_nrrr_without_redundancy_gets_its_closed_form_step_in_c(three_rrr):
    """A 3-RRR (no preload) has a closed-form step: codegen writes it with the path (no 4-RRR
    kinematics kernels), and its C computes what the Python step computes."""
    problem, c = three_rrr["problem"], three_rrr["c"]["controller_step"]
    header = (three_rrr["src"] / "rrr4.h").read_text()
    assert "int rrr4_controller_step(const double pose_des[3]" in header and "RRR4_TABLE_SAMPLES" not in header
    assert "out alpha empty (pass NULL)" in header
    rng = np.random.default_rng(3)
    t = rng.uniform(0.0, problem.path.duration, N_RANDOM)
    theta, theta_d = _random_states(rng, problem, t)
    ins = step_inputs(c, problem.path, t)
    got, want = _outputs(c, *ins, theta, theta_d), _outputs(controller_function(problem), *ins, theta, theta_d)
    for name, a, b in zip(c.name_out(), got, want, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12, err_msg=name)
    assert len([line for line in three_rrr["example"].splitlines() if line.startswith("step ")]) == 11


def test_graph_compensated_step_holds_the_seated_references():
    """With compensation: clearance the table holds the IK closed around the predicted seats,
    which moves the references by the order of the clearance (0.1 mm over 0.25 m links)."""
    base = load_scene(PROBLEMS / "redundant_five_bar.yaml")
    base = replace(base, path=replace(base.path, sample_rate=100.0))  # 101 Newton solves, not 1001
    plain, comp = build(base), build(_act(base, compensation="clearance"))
    t = reference_grid(comp)[::5]
    z = np.zeros((3, len(t)))
    a = _outputs(controller_step(comp), t[None, :], z, z)
    b = _outputs(controller_step(plain), t[None, :], z, z)
    shift = np.abs(a[2] - b[2]).max()
    assert 1e-5 < shift < 5e-3
    refs = tabulated(comp, reference_grid(comp))
    np.testing.assert_allclose(a[2].T, refs.theta_ref[::5], rtol=0, atol=1e-14)


def test_generated_graph_controller_in_the_loop_is_the_python_controller():
    """paper_circle_graph (sampled at 10 kHz): the compiled table step in the loop gives the
    trajectory of the Python arm (tabulated references, interpolated, feedback law in CasADi)
    to rounding: the cubics are evaluated in the same order."""
    scene = load_scene(PROBLEMS / "paper_circle_graph.yaml")
    a = simulate(scene, t_end=0.05, controller="python")
    b = simulate(scene, t_end=0.05, controller="generated")
    assert b.stats["controller"] == "generated" and b.stats["control_rate"] == 1e4
    assert np.max(np.abs(a.pose - b.pose)) < 1e-12
    np.testing.assert_allclose(a.tau, b.tau, rtol=0, atol=1e-9)
    assert a.contact_loss_events == b.contact_loss_events


def test_the_study_runs_the_generated_step_of_a_sampled_graph_controller():
    scene = load_scene(PROBLEMS / "redundant_five_bar.yaml")
    assert study_controller(build(scene)) == "python"  # continuous: no rate to sample at
    assert study_controller(build(_act(scene, control_rate=1e4))) == "generated"


def test_cli_codegen_of_a_graph_scene_and_refusal_of_a_driven_one(tmp_path, capsys):
    out = tmp_path / "c"
    assert cli_main(["codegen", str(PROBLEMS / "redundant_five_bar.yaml"), "--out", str(out)]) == 0
    assert (out / "rrr4.h").exists() and (out / "main.c").exists()
    capsys.readouterr()
    assert cli_main(["codegen", str(PROBLEMS / "flores_slider_crank.yaml"), "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mechanism.task" in err and "no task body" in err
    assert not (tmp_path / "d").exists()
    assert cli_main(["codegen", str(PROBLEMS / "redundant_five_bar.yaml"), "--out", str(out), "--branch", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "branch: 1 is not allowed for scene 'redundant_five_bar'" in err
    assert (out / "rrr4.h").exists()  # the earlier output is left as it was


def test_a_scene_without_actuators_has_no_controller():
    scene = load_scene(PROBLEMS / "redundant_five_bar.yaml")
    bare = replace(scene, graph=replace(scene.graph, actuators=()))
    with pytest.raises(SceneError, match="mechanism.actuators: scene 'redundant_five_bar' has no actuators"):
        controller_step(build(bare))


def test_nrrr_with_a_preload_without_a_pointwise_law_gets_the_table_step(paper_scene):
    """The nlp preload (smoothed along the path) has no pointwise law: the 4-RRR's controller
    step is then the table step, with the path kernel only, and its references are the
    closed-form IK's (modulo 2 pi, continuous along the path)."""
    nlp = replace(paper_scene, path=replace(paper_scene.path, sample_rate=100.0))
    qp = build(_act(nlp, preload=replace(nlp.actuation.preload, method="qp")))
    nlp = build(_act(nlp, preload=replace(nlp.actuation.preload, method="nlp")))
    assert tuple(k.name for k in kernels(nlp)) == STEP_KERNELS
    f, g = controller_step(nlp), controller_step(qp)
    assert f.name_in(0) == "t" and g.name_in(0) == "pose_des"
    t = reference_grid(nlp)
    z = np.zeros((4, len(t)))
    a, b = _outputs(f, t[None, :], z, z), _outputs(g, *step_inputs(g, qp.path, t), z, z)
    assert np.abs(np.diff(a[2], axis=1)).max() < 0.1  # continuous
    np.testing.assert_allclose((a[2] - b[2] + np.pi) % (2 * np.pi) - np.pi, 0.0, atol=1e-12)
    np.testing.assert_allclose(a[3], b[3], rtol=0, atol=1e-10)


def test_table_step_converges_to_the_closed_form_step_between_its_samples():
    """Between the table's instants (midpoints) the graph's step against the n-RRR's closed
    form of the same mechanism (independent IK and inverse dynamics), without preload: the
    errors of theta_ref, theta_d_ref and tau_ff fall as h^4 (x16 per halving; >= x10 asked)."""
    g0, n0 = (load_scene(PROBLEMS / f) for f in ("paper_circle_graph.yaml", "paper_circle.yaml"))
    errors = []
    for rate in (125.0, 250.0, 500.0):
        g, n = (build(replace(_act(s, control_rate=None, preload=replace(s.actuation.preload, method="none")),
                              path=replace(s.path, sample_rate=rate))) for s in (g0, n0))
        f, h = controller_step(g), controller_step(n)
        t_s = reference_grid(g)
        t = 0.5 * (t_s[1:] + t_s[:-1])
        z = np.zeros((4, len(t)))
        a, b = _outputs(f, t[None, :], z, z), _outputs(h, *step_inputs(h, n.path, t), z, z)
        errors.append([np.abs((a[2] - b[2] + np.pi) % (2 * np.pi) - np.pi).max(), np.abs(a[3] - b[3]).max(),
                       np.abs(a[1] - b[1]).max()])
    errors = np.array(errors)
    assert np.all(errors[:-1] / errors[1:] > 10.0), errors
    assert np.all(errors[-1] < [2e-10, 5e-9, 5e-9]), errors


@pytest.fixture(scope="module")
def xyt(tmp_path_factory):
    return _generated(load_scene(PROBLEMS / "xyt_table.yaml"), tmp_path_factory.mktemp("xyt"))


def test_graph_with_prismatic_actuators_and_no_redundancy_gets_its_table_step(xyt):
    """The x-y-theta table: two prismatic actuators (forces [N], errors not wrapped) and a
    rotary one, no null space (alpha empty): its C equals the Python step at random samples."""
    problem, c = xyt["problem"], xyt["c"]["controller_step"]
    header = (xyt["src"] / "rrr4.h").read_text()
    assert "FX (prismatic, N), FY (prismatic, N), TR (revolute, N m)" in " ".join(header.replace("\n * ", " ").split())
    assert "double *alpha" in header and c.numel_out(4) == 0
    rng = np.random.default_rng(4)
    t = rng.uniform(0.0, problem.path.duration, N_RANDOM)
    theta, theta_d = _random_states(rng, problem, t)
    theta[:2] += 4.0  # a prismatic error of 4 m is not wrapped: clipped at the force limit
    got, want = _outputs(c, t[None, :], theta, theta_d), _outputs(controller_step(problem), t[None, :], theta, theta_d)
    for name, a, b in zip(c.name_out(), got, want, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12, err_msg=name)
    limits = np.array(problem.torque_limit)[:2, None]
    np.testing.assert_array_equal(got[0][:2], -limits * np.ones_like(got[0][:2]))
    assert len([line for line in xyt["example"].splitlines() if line.startswith("step ")]) == 11
