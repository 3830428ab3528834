"""Bad input, tried as a careless or hostile user would: every way in ends in one clear line
that names the key, with no traceback, before anything is allocated or computed."""

import copy
import itertools
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

import rrr4
from rrr4 import SceneError, build, check_scene
from rrr4.scene import parse_scene, read_scene, set_key
from tests.conftest import PAPER, ROOT

LEAF_KEYS = [
    "mechanism.platform.mass", "mechanism.platform.inertia", "mechanism.chain_defaults.driving_link.length",
    "mechanism.chain_defaults.driving_link.mass", "mechanism.chain_defaults.following_link.length",
    "mechanism.chain_defaults.attachment_radius", "joints.journal_radius", "joints.radial_clearance",
    "effects.contact.restitution", "effects.contact.exponent", "effects.friction.coefficient", "effects.friction.v0",
    "effects.gravity", "actuation.torque_limit", "actuation.preload.min_force", "actuation.gains.kp",
    "actuation.gains.kd", "path.center", "path.radius", "path.duration", "path.sample_rate", "integrator.step",
]
BAD_VALUES = ["abc", "1e-4", 1e308, float("nan"), True, {"a": 1}, -1.0]



@pytest.mark.parametrize("key,value", list(itertools.product(LEAF_KEYS, BAD_VALUES)),
                         ids=[f"{k}={v!r}" for k, v in itertools.product(LEAF_KEYS, BAD_VALUES)])
def test_corpus_of_bad_scenes_is_refused_in_one_line_naming_the_key(paper_data, key, value):
    """154 scenes, each with one bad value: refused with a SceneError of one line that starts
    with the key (for the path keys, possibly after the scene check)."""
    data = copy.deepcopy(paper_data)
    set_key(data, key, value)
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(data))
    msg = str(err.value)
    assert "\n" not in msg and len(msg) < 400
    assert msg.startswith(key.split(".chain_defaults")[0].split(".")[0]) and key.split(".")[-1] in msg


def _write(tmp_path, name, content: bytes):
    p = tmp_path / name
    p.write_bytes(content)
    return p


@pytest.mark.parametrize("content,expected", [
    (b"\xff\xfe\x00m\x00e", "is binary"),
    ("name: caf\u00e9\n".encode("latin-1"), "is not UTF-8 text"),
    (b"", "is empty"),
    (b"# only a comment\n", "is empty"),
    (b"name: a\nname: b\n", r"key 'name' appears twice \(first at line 1\)"),
])
def test_unreadable_file_contents_are_one_line(tmp_path, content, expected):
    with pytest.raises(SceneError, match=expected):
        read_scene(_write(tmp_path, "s.yaml", content))


def test_directories_and_devices_are_not_scene_files(tmp_path):
    with pytest.raises(SceneError, match="is a directory"):
        read_scene(tmp_path)
    if os.path.exists("/dev/null"):
        with pytest.raises(SceneError, match="is not a regular file"):
            read_scene("/dev/null")
    with pytest.raises(SceneError, match="does not exist"):
        read_scene(tmp_path / "nope.yaml")


def test_yaml_alias_bomb_is_refused_quickly_with_a_bounded_message(tmp_path):
    """A billion-laughs scene: the message echoes a bounded rendering, not the expansion."""
    lines = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    lines += [f"a{i}: &a{i} [{', '.join(['*a' + str(i - 1)] * 10)}]" for i in range(1, 9)]
    lines += ["name: bomb", "mechanism: *a8"]
    with pytest.raises(SceneError) as err:
        read_scene(_write(tmp_path, "bomb.yaml", "\n".join(lines).encode()))
    assert len(str(err.value)) < 300


def test_a_number_yaml_reads_as_text_gets_a_hint(paper_data):
    paper_data["joints"]["radial_clearance"] = "1e-4"
    with pytest.raises(SceneError, match=r"joints.radial_clearance: '1e-4' is text, not a number .* write 1.0e-4"):
        parse_scene(paper_data)


@pytest.mark.parametrize("name", ["../x", "a/b", ".", "", "x y"])
def test_a_scene_name_must_be_a_plain_name(paper_data, name):
    paper_data["name"] = name
    with pytest.raises(SceneError, match="name: .* is not allowed"):
        parse_scene(paper_data)


def test_sizes_that_cannot_be_computed_are_refused_before_allocating(paper_data):
    d = copy.deepcopy(paper_data)
    d["path"]["sample_rate"] = 1e6
    d["path"]["duration"] = 100.0
    with pytest.raises(SceneError, match=r"path.sample_rate: .* \(at most 5e\+06 samples\)"):
        parse_scene(d)
    d = copy.deepcopy(paper_data)
    d["integrator"]["step"] = 2.0
    with pytest.raises(SceneError, match=r"integrator.step: 2 s is not allowed \(must not exceed path.duration"):
        parse_scene(d)


@pytest.mark.parametrize("kwargs,expected", [
    ({"step": 0}, r"step: 0 is not allowed"),
    ({"output_rate": 0}, r"output_rate: 0 is not allowed"),
    ({"t_end": "abc"}, r"t_end: 'abc' is not allowed \(a number is required\)"),
    ({"t_end": 1e9}, r"t_end: 1e\+09 s is not allowed .* \(at most"),
    ({"preload": "qp"}, r"preload: 'qp' is not allowed"),
    ({"stp": 1e-5}, r"stp: unknown override 'stp' .* did you mean 'step'\?"),
    ({"integrator": "rk44"}, r"integrator: unknown integrator 'rk44' .* did you mean 'rk4'\?"),
])
def test_simulate_arguments_are_checked_in_one_line(paper_scene, kwargs, expected):
    with pytest.raises(SceneError, match=expected):
        rrr4.simulate(paper_scene, **kwargs)


@pytest.mark.parametrize("kwargs,expected", [
    ({"sample_rate": 0}, r"sample_rate: 0 is not allowed"),
    ({"nlp_rate": -1}, r"nlp_rate: -1 is not allowed"),
    ({"method": "qpp"}, r"method: unknown value 'qpp' .* did you mean 'qp'\?"),
    ({"qp_solver": "osq"}, r"qp_solver: unknown value 'osq' .* did you mean 'osqp'\?"),
])
def test_solve_preload_arguments_are_checked_in_one_line(paper_scene, kwargs, expected):
    with pytest.raises(SceneError, match=expected):
        rrr4.solve_preload(paper_scene, **kwargs)


def test_bad_scene_file_on_the_command_line_is_one_line(tmp_path):
    p = _write(tmp_path, "dup.yaml", PAPER.read_bytes() + b"\nname: again\n")
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(p)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().count("\n") == 0 and "appears twice" in r.stderr


def test_lower_case_joint_name_gets_a_suggestion(paper_data):
    paper_data["joints"]["clearance"] = ["b1"]
    with pytest.raises(SceneError, match="did you mean 'B1'"):
        parse_scene(paper_data)


def test_missing_path_says_missing(paper_data):
    d = copy.deepcopy(paper_data)
    del d["path"]["type"]
    with pytest.raises(SceneError) as err:
        parse_scene(d)
    assert str(err.value).startswith("path.type: missing (choose one of:")
    assert yaml.safe_dump(paper_data)  # the fixture stays intact


def test_simulate_compiles_by_default_and_falls_back_with_one_warning(monkeypatch):
    import warnings

    import rrr4.simulation.run as simulation
    monkeypatch.delenv("RRR4_JIT", raising=False)
    assert simulation.default_jit() == ("background" if simulation.c_compiler() is not None else False)
    monkeypatch.setattr(simulation, "c_compiler", lambda: None)
    monkeypatch.setattr(simulation, "_NO_COMPILER_WARNED", False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert simulation.default_jit() is False and simulation.default_jit() is False
    assert len([w for w in caught if "no C compiler found" in str(w.message)]) == 1
    monkeypatch.setenv("RRR4_JIT", "0")
    assert simulation.default_jit() is False


def test_v_min_of_the_equations_floors_the_approach_velocity():
    """The force scales the hysteresis by the scene's v_min, not by a constant: with v_min =
    1e-5 m/s and a captured approach of 2e-5 m/s the damping term is 50x that at 1e-3."""
    import numpy as np

    from rrr4.mechanism import Mechanism
    s = rrr4.load_scene(PAPER)    # Lankarani-Nikravesh, c_r = 0.9: a hysteresis term
    forces = {}
    for v_min in (1e-5, 1e-3):
        eqs = build(s).equations(v_min=v_min)
        mech = Mechanism.from_scene(s)
        _, qd, _ = mech.body_motion([0.0, 0.0, 0.0], [0.05, 0.0, 0.0])
        qd = qd + np.random.default_rng(0).normal(0.0, 1e-3, qd.size)   # journals approach their walls
        nc = len(eqs.clearance_joints)
        ecc = np.zeros((len(s.joints), 2))
        ecc[:, 0] = s.joints[0].radial_clearance + 1e-6
        q = mech.seated_coordinates([0.0, 0.0, 0.0], ecc)
        out = eqs.acceleration(q=q, qd=qd, delta_dot0=np.full(nc, 2e-5), in_contact=np.ones(nc))
        forces[v_min] = np.array(out["normal_force"]).ravel()
    assert not np.allclose(forces[1e-5], forces[1e-3])


def test_cli_refuses_a_bad_t_end_and_an_unwritable_out_before_any_work(tmp_path):
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "run", str(PAPER), "--t-end", "-1"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--t-end: -1.0 is not allowed" in r.stderr and "preload" not in r.stdout
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "run", str(PAPER), "--out", str(blocker / "sub")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--out:" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_sigterm_while_writing_results_leaves_no_temporary_directory(tmp_path):
    """SIGTERM lands while the result directory is being written (the animation renders):
    one line, exit 143, the temporary directory removed, no result half-written."""
    import signal
    import time
    out = tmp_path / "res"
    p = subprocess.Popen([sys.executable, "-m", "rrr4.cli", "run", str(PAPER), "--t-end", "0.06", "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 240
    while time.time() < deadline and p.poll() is None and not list(tmp_path.glob(".res.tmp-*/*.png")):
        time.sleep(0.05)
    assert p.poll() is None, "the run ended before it wrote anything"
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143 and "terminated; earlier results are left as they were" in err
    assert "Traceback" not in err and not list(tmp_path.glob(".res.*")) and not out.exists()


def test_sigint_during_a_simulation_ends_in_the_interrupt_line(tmp_path):
    """Ctrl-C while CasADi steps the simulation (the signal usually lands inside a CasADi
    call): one line, exit 130, nothing written."""
    import signal
    import time
    out = tmp_path / "res"
    p = subprocess.Popen([sys.executable, "-m", "rrr4.cli", "run", str(PAPER), "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "RRR4_JIT": "0", "PYTHONUNBUFFERED": "1"})
    # wait for the first simulation to start (past loading and the preload, whatever the
    # machine's load): it runs for tens of seconds in the VM
    deadline = time.monotonic() + 180
    line = ""
    while "simulate with" not in line and time.monotonic() < deadline and p.poll() is None:
        line = p.stdout.readline()
    time.sleep(0.5)
    assert p.poll() is None
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130 and "interrupted; earlier results are left as they were" in err
    assert "Traceback" not in err and not out.exists()


GRAPH_KEYS = ["mechanism.bodies[0].mass", "mechanism.bodies[1].inertia", "mechanism.bodies[2].pose",
              "mechanism.joints[2].clearance.radial_clearance", "mechanism.joints[3].axis",
              "mechanism.bodies[0].points", "path.duration", "integrator.step"]



@pytest.mark.parametrize("key,value", list(itertools.product(GRAPH_KEYS, BAD_VALUES)),
                         ids=[f"{k}={v!r}" for k, v in itertools.product(GRAPH_KEYS, BAD_VALUES)])
def test_corpus_of_bad_graph_scenes_is_refused_in_one_line(key, value):
    data = yaml.safe_load((ROOT / "problems" / "flores_slider_crank.yaml").read_text())
    set_key(data, key, value)
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(data))
    msg = str(err.value)
    leaf = key.split(".")[-1]
    assert "\n" not in msg and leaf in msg


@pytest.mark.filterwarnings("ignore")
def test_any_value_anywhere_is_a_scene_or_one_line(paper_data):
    """Property: whatever value lands on whatever key, parsing and checking the scene ends in
    a Scene or in a one-line SceneError, never another exception."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    values = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), st.floats(allow_nan=True),
                       st.text(max_size=12), st.lists(st.floats(-1e3, 1e3), max_size=5),
                       st.dictionaries(st.text(max_size=5), st.integers(), max_size=3))

    @settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
    @given(key=st.sampled_from(LEAF_KEYS + ["name", "mechanism.chains[0].base", "path.type", "effects.contact.law"]),
           value=values)
    def check(key, value):
        data = copy.deepcopy(paper_data)
        if key == "mechanism.chains[0].base":
            data["mechanism"]["chains"][0]["base"] = value
        else:
            set_key(data, key, value)
        try:
            check_scene(parse_scene(data))
        except SceneError as e:
            assert "\n" not in str(e)

    check()


def test_result_directories_get_the_umask_mode(tmp_path):
    from rrr4.files import atomic_directory
    old = os.umask(0o022)
    try:
        out = atomic_directory(tmp_path / "r", lambda d: (d / "summary.json").write_text("{}"), "summary.json")
    finally:
        os.umask(old)
    assert (out.stat().st_mode & 0o777) == 0o755


@pytest.mark.parametrize("value", [42, None, [], {"name": "x"}, b"paper_circle.yaml"])
def test_front_doors_refuse_what_is_not_a_scene_or_a_problem_in_one_line(value, tmp_path):
    """Every front door builds its Problem through Problem.from_scene, which names the argument
    (a scene file's path is read; a missing one is the file's own one-line error)."""
    for door in (rrr4.build, rrr4.simulate, rrr4.solve_preload, lambda s: rrr4.codegen(s, tmp_path / "c")):
        with pytest.raises(SceneError) as err:
            door(value)
        assert str(err.value).startswith("scene: ") and "\n" not in str(err.value)
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("value", [[1.0, 2.0], -1.0, 0.0, None, "x", [1.0, 2.0, 3.0, float("nan")]])
def test_effort_limits_are_checked_in_one_line(paper_scene, value):
    with pytest.raises(SceneError) as err:
        paper_scene.with_torque_limit(value)
    assert str(err.value).startswith("torque_limit: ") and "\n" not in str(err.value)
    assert paper_scene.with_torque_limit(2.5).torque_limit == (2.5,) * 4


def test_front_doors_take_a_scene_files_path(tmp_path):
    assert rrr4.build(PAPER).scene == rrr4.load_scene(PAPER)
    assert rrr4.build(str(PAPER)) is rrr4.build(PAPER)
    with pytest.raises(SceneError, match="scene file 'missing.yaml' does not exist"):
        rrr4.simulate("missing.yaml")


def test_nesting_and_alias_bombs_end_in_one_line(tmp_path):
    from rrr4.scene import MAX_DEPTH, read_yaml
    deep = tmp_path / "deep.yaml"
    deep.write_text("mechanism: " + "[" * 3000 + "]" * 3000 + "\n")
    with pytest.raises(SceneError, match=f"nested too deeply \\(at most {MAX_DEPTH} levels"):
        rrr4.load_scene(deep)
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n" for p, c in zip("abcdef", "bcdefg", strict=True)))
    with pytest.raises(SceneError, match="too large"):
        read_yaml(bomb)


def test_a_sweep_over_one_joints_clearance_changes_only_that_joint():
    """redundant_five_bar.yaml shares one clearance block among its five joints through a YAML
    alias (&pin): reading a scene gives every joint its own block."""
    from rrr4.scene import read_yaml
    data = read_yaml(ROOT / "problems" / "redundant_five_bar.yaml")
    set_key(data, "mechanism.joints[3].clearance.radial_clearance", 2.0e-4)
    scene = parse_scene(data)
    clear = {j.name: j.radial_clearance for j in scene.graph.joints if j.clearance}
    assert clear.pop("B1") == 2.0e-4 and set(clear.values()) == {1.0e-4}, clear


@pytest.mark.parametrize("command", ["run", "map", "robustness", "bench", "codegen", "sweep", "animate"])
def test_every_command_refuses_an_output_it_cannot_write_before_any_work(tmp_path, capsys, command):
    """--out under a file, under /proc, onto the wrong kind: one line naming --out, exit 2,
    nothing written (checked before the scene is simulated or the cluster started)."""
    from rrr4.cli import main
    a_file = tmp_path / "file.txt"
    a_file.write_text("keep")
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"scene": str(PAPER), "grid": {"joints.radial_clearance": [1e-4]}}))
    first = {"sweep": str(spec), "animate": str(ROOT / "results" / "paper_circle")}.get(command, str(PAPER))
    outs = [a_file / "sub", "/proc/rrr4-out"] + ([tmp_path / "missing" / "m.gif", tmp_path] if command == "animate"
                                                 else [a_file])
    for out in outs:
        code = main([command, *(["accuracy"] if command == "bench" else []), first, "--out", str(out)])
        err = capsys.readouterr().err.strip()
        assert code == 2 and err.count("\n") == 0 and "--out" in err, (out, err)
    assert a_file.read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == ["file.txt", "spec.yaml"]


def test_api_options_that_do_not_apply_and_wrong_guesses_end_in_one_line():
    slider = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    with pytest.raises(SceneError, match="controller: 'generated' is not allowed here \\(actuation.mode is 'free'"):
        rrr4.simulate(slider, controller="generated", t_end=1e-3)
    mech = rrr4.Mechanism.from_scene(slider)
    target = mech.driver_targets(0.0)[0]
    for guess in ([0.0, 0.0], "x", [float("nan")] * mech.nq):
        with pytest.raises(SceneError, match=f"guess: .* is not allowed \\(a vector of {mech.nq} finite numbers\\)"):
            mech.assemble(target, guess=guess)
    with pytest.raises(SceneError, match="target: .* is not allowed"):
        mech.assemble([0.0, 1.0, 2.0])


def test_a_file_that_is_not_a_scene_is_named_never_echoed(tmp_path, capsys):
    from rrr4.cli import main
    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\n")
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"scene": str(secret), "grid": {"joints.radial_clearance": [1e-4]}}))
    for args in (["check", str(secret)], ["sweep", str(spec), "--out", str(tmp_path / "o")]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "is not a scene" in err and "root:x" not in err and err.count("\n") == 1


FLOATING_PAIR = """
    - name: float1
      mass: 0.1
      inertia: 1.0e-4
      points: {P: [0.05, 0.0], Q: [0.05, 0.02]}
      pose: [0.3, 0.3, 0.0]
    - name: float2
      mass: 0.1
      inertia: 1.0e-4
      points: {P: [-0.05, 0.0], Q: [-0.05, 0.02]}
      pose: [0.4, 0.3, 0.0]
  joints:
    - {name: F, type: revolute, bodies: [float1, float2], points: [P, P]}
    - {name: G, type: revolute, bodies: [float1, float2], points: [Q, Q]}
"""


@pytest.mark.parametrize("command", ["check", "run"])
def test_a_floating_sub_mechanism_ends_in_one_line_naming_its_bodies(tmp_path, command):
    """Two bodies pinned to each other twice, not to the ground, with a driver on each pin so
    that the count of degrees of freedom matches: one line naming the floating bodies, no
    solver chatter (it printed about 30 000 lines of CasADi warnings before its error)."""
    text = (ROOT / "problems" / "flores_slider_crank.yaml").read_text()
    text = text.replace("  joints:\n", FLOATING_PAIR, 1).replace("  drivers:\n", (
        "  drivers:\n    - {name: f_drive, joint: F, initial_deg: 0.0, speed_rpm: 0.0}\n"
        "    - {name: g_drive, joint: G, initial_deg: 0.0, speed_rpm: 0.0}\n"), 1)
    scene = tmp_path / "floating.yaml"
    scene.write_text(text)
    args = [command, str(scene)] + (["--out", str(tmp_path / "out")] if command == "run" else [])
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", *args], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, cwd=tmp_path)
    lines = (r.stdout + r.stderr).strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, lines[:5]
    assert "mechanism.joints: bodies 'float1', 'float2' are not allowed to float" in lines[0]
    assert not (tmp_path / "out").exists()


def test_newton_that_meets_nan_prints_nothing_and_fails_in_one_line(paper_scene, capfd):
    """Assembly at targets out of reach: CasADi's Newton meets NaN and warned once per
    evaluation; now nothing is printed at the file-descriptor level, and the error is one line."""
    m = rrr4.Mechanism.from_scene(paper_scene)
    for target in ([5.0, 5.0, 0.0], [0.0, 0.0, 3.0]):
        with pytest.raises(rrr4.KinematicsError) as e:
            m.assemble(target)
        assert "\n" not in str(e.value)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_building_a_qpoases_preload_prints_no_banner(paper_data, capfd):
    """qpOASES prints its copyright notice when a solver is built, whatever its printLevel:
    it is captured (the one place that captures C output), the preload still solves."""
    paper_data["actuation"]["preload"]["min_force"] = 9.875  # a solver no other test builds
    scene = parse_scene(paper_data)
    capfd.readouterr()
    sol = rrr4.solve_preload(scene, "qp", qp_solver="qpoases", sample_rate=50.0, signs=1.0)
    out, err = capfd.readouterr()
    assert out == "" and err == "" and np.all(np.isfinite(sol.alpha))


def test_an_interrupt_lost_inside_the_work_still_stops_the_command(tmp_path, monkeypatch, capsys):
    """A Ctrl-C that lands inside a CasADi solver can stop only that solver, which returns
    as if unconverged; the run goes on. The command must still write nothing and exit 130."""
    import argparse
    import signal

    from rrr4 import cli
    from rrr4.files import atomic_directory, stop_requested

    out = tmp_path / "res"

    def work(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)  # the handler runs here ...
        except KeyboardInterrupt:
            pass  # ... and the interrupt is lost, as in a solver that swallows it
        atomic_directory(out, lambda d: (d / "summary.json").write_text("{}"), "summary.json")
        return 0

    def fails(args):  # a solver stopped by the interrupt reports that it did not converge
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass
        raise SceneError("preload: not converged")

    def steps(args):  # the interrupt lost, then a simulation: its stepping stops at its next block
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass
        rrr4.simulate(rrr4.load_scene(PAPER), t_end=0.01)
        raise AssertionError("the simulation ran on")

    for func in (work, fails, steps):
        parser = argparse.ArgumentParser()
        parser.add_argument("command")
        parser.set_defaults(func=func)
        monkeypatch.setattr(cli, "build_parser", lambda parser=parser: parser)
        assert cli.main(["run"]) == 130, func.__name__
        assert not out.exists() and not list(tmp_path.iterdir())
        assert "interrupted; earlier results are left as they were" in capsys.readouterr().err
        assert not stop_requested()  # cleared when the command ends
