"""Sweeps on Dask: a local cluster and a separately started one give the same rows; finished
cases are kept and skipped; a failing case is recorded; bad specs end in one line."""

import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from rrr4 import SceneError, build
from rrr4.studies.sweeps import DRIVEN_METRICS, METRICS, case_scene, load_spec, parse_spec, sweep

ROOT = Path(__file__).resolve().parents[1]
SCENE = str(ROOT / "problems" / "paper_circle.yaml")
DRIVEN = str(ROOT / "problems" / "flores_slider_crank.yaml")
CLEARANCE_B = "mechanism.joints[2].clearance.radial_clearance"  # the slider-crank's clearance joint B


def _spec(tmp_path, **extra) -> Path:
    """A 2 x 2 grid on the reference scene stepped by RK4 at 1e-5 s, whose stability limit the
    contact stiffness of 1e15 N/m^1.5 breaks: that case fails on purpose."""
    scene = yaml.safe_load(Path(SCENE).read_text())
    scene["integrator"] = {"method": "rk4", "step": 1.0e-5}
    (tmp_path / "rk4_scene.yaml").write_text(yaml.safe_dump(scene, sort_keys=False))
    spec = {"scene": str(tmp_path / "rk4_scene.yaml"), "t_end": 0.005, "arms": ["with_preload", "without_preload"],
            "grid": {"joints.radial_clearance": [5.0e-5, 1.0e-4], "effects.contact.stiffness": [7.6e10, 1.0e15]}}
    spec.update(extra)
    p = tmp_path / "spec.yaml"
    p.write_text(yaml.safe_dump(spec, sort_keys=False))
    return p


def _rows(csv_path: Path) -> list[dict]:
    with csv_path.open(newline="") as f:
        return sorted(csv.DictReader(f), key=lambda r: (r["case"], r["arm"]))


def _same(a: list[dict], b: list[dict]) -> None:
    assert len(a) == len(b)
    for ra, rb in zip(a, b, strict=True):
        assert {k: v for k, v in ra.items() if k != "wall_time_s"} == {k: v for k, v in rb.items()
                                                                     if k != "wall_time_s"}


@pytest.fixture(scope="module")
def external_cluster(tmp_path_factory):
    """A Dask scheduler and two workers started as separate processes on 127.0.0.1."""
    d = tmp_path_factory.mktemp("dask")
    sched_file = d / "scheduler.json"
    bindir = Path(sys.executable).parent
    env = {**os.environ, "RRR4_JIT": "0"}
    procs = [subprocess.Popen([str(bindir / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(sched_file)], env=env, cwd=d,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(300):
            if sched_file.exists() and sched_file.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        procs.append(subprocess.Popen([str(bindir / "dask"), "worker", address, "--nworkers", "2", "--nthreads", "1",
                                       "--no-dashboard", "--host", "127.0.0.1"], env=env, cwd=d,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from dask.distributed import Client
        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_local_and_external_clusters_give_identical_rows_and_a_failing_case_is_recorded(tmp_path,
                                                                                         external_cluster):
    spec = _spec(tmp_path)
    a = sweep(spec, out=tmp_path / "local", workers=2)
    b = sweep(spec, out=tmp_path / "external", scheduler=external_cluster)
    assert a["cases"] == b["cases"] == 4 and a["skipped"] == b["skipped"] == 0
    ra, rb = _rows(a["csv"]), _rows(b["csv"])
    _same(ra, rb)
    assert list(ra[0]) == ["case", "joints.radial_clearance", "effects.contact.stiffness", "arm", "status", "error",
                           *METRICS]
    # the contact stiffness of 1e15 N/m^1.5 blows RK4 up at the scene's step: recorded, the others ran
    failed = [r for r in ra if r["status"] == "failed"]
    assert failed and all(float(r["effects.contact.stiffness"]) == 1e15 for r in failed)
    assert all("step" in r["error"] for r in failed)
    ok = [r for r in ra if r["status"] == "ok"]
    assert {r["joints.radial_clearance"] for r in ok} == {"5e-05", "0.0001"}
    assert all(int(r["contact_loss_events"]) == 0 for r in ok if r["arm"] == "with_preload")
    assert a["failed"] == b["failed"] == len({r["case"] for r in failed})


def test_a_rerun_skips_the_finished_cases_and_keeps_their_rows(tmp_path):
    spec = _spec(tmp_path, grid={"joints.radial_clearance": [5.0e-5, 1.0e-4]})
    first = sweep(spec, out=tmp_path / "o", workers=1)
    before = (tmp_path / "o" / "results.csv").read_text()
    again = sweep(spec, out=tmp_path / "o", workers=1)
    assert first["skipped"] == 0 and again["skipped"] == 2 and again["rows"] == []
    assert {f.name for f in first["figures"]} == {"platform_error_rms_m.png", "contact_loss_events.png",
                                                   "min_contact_force_N.png"}
    assert (tmp_path / "o" / "results.csv").read_text() == before
    # one more grid value: only the new case runs, appended to the same file
    more = sweep(_spec(tmp_path, grid={"joints.radial_clearance": [5.0e-5, 1.0e-4, 1.5e-4]}), out=tmp_path / "o",
                 workers=1)
    assert more["skipped"] == 2 and len(more["rows"]) == 2
    assert (tmp_path / "o" / "results.csv").read_text().startswith(before)


def test_monte_carlo_is_reproducible_from_its_seed(tmp_path):
    mc = {"samples": 5, "seed": 3, "keys": {"mechanism.chains[0].base[0]": {"normal": {"std": 1e-4}},
                                            "joints.radial_clearance": {"uniform": [8e-5, 1.2e-4]}}}
    a, b = load_spec(_spec(tmp_path, grid={}, monte_carlo=mc)), load_spec(_spec(tmp_path, grid={}, monte_carlo=mc))
    assert a.cases == b.cases and len(a.cases) == 5
    xs = [c["mechanism.chains[0].base[0]"] for c in a.cases]
    assert all(abs(x + 0.3) < 5e-4 for x in xs) and len(set(xs)) == 5      # around the base value -0.3 m
    assert all(8e-5 <= c["joints.radial_clearance"] <= 1.2e-4 for c in a.cases)
    grid_mc = load_spec(_spec(tmp_path, grid={"actuation.preload.min_force": [5, 10]}, monte_carlo=mc))
    assert len(grid_mc.cases) == 10


@pytest.mark.parametrize("change, match", [
    ({"arms": ["with_preloads"]}, r"arms: 'with_preloads' is not allowed on a scene with a task body \(choose from: "
                                  "with_preload, with_preload_compensated, without_preload\\)"),
    ({"arms": ["ideal"]}, "arms: 'ideal' is not allowed on a scene with a task body"),
    ({"grid": {"joints.radial_clearance": [-1.0e-4]}}, r"joints.radial_clearance: .* \(in the case joints"),
    ({"grid": {"joints..x": [1]}}, "key 'joints..x' is not allowed"),
    ({"grid": {"joints.radial_clearance": []}}, "grid.joints.radial_clearance: .* non-empty list"),
    ({"monte_carlo": {"samples": 0, "keys": {}}}, "monte_carlo.samples: 0 is not allowed"),
    ({"monte_carlo": {"samples": 2, "keys": {"joints.radial_clearance": {"gauss": 1}}}}, "monte_carlo.keys"),
    ({"monte_carlo": {"samples": 2, "keys": {"mechanism.chains[0].driving_link.length": {"normal": {"std": 1}}}}},
     "mean"),
    ({"t_end": -1}, "t_end: -1 is not allowed"),
    ({"skip": 0.005}, r"skip: 0.005 s is not allowed \(.*0 <= skip < t_end = 0.005 s\)"),
    ({"skip": -0.001}, r"skip: -0.001 is not allowed \(must be a finite number >= 0\)"),
    ({"skip": "1 ms"}, "skip: '1 ms' is not allowed"),
    ({"t_end": None, "skip": 2.0}, r"skip: 2 s is not allowed .* t_end = 1 s"),
    ({"scenery": 1}, "scenery: unknown key of a sweep spec"),
    ({"scene": "\x00"}, r"scene: '\\x00' is not allowed \(the base scene's YAML file, or a Scene\)"),
    # round two: keys that are not strings, no case at all, a grid counted before it is expanded,
    # a case that does not assemble (as rrr4 check says), all refused before any work
    ({"grid": {None: [1]}}, "grid: key None is not allowed"),
    ({"grid": {True: [1]}}, "grid: key True is not allowed"),
    ({"monte_carlo": {"samples": 2, "keys": {7: {"uniform": [0, 1]}}}}, "monte_carlo.keys: key 7 is not allowed"),
    ({"grid": {}}, "grid: no grid and no monte_carlo is not allowed"),
    ({"grid": {f"effects.friction.v{i}": list(range(10)) for i in range(9)}}, "grid: 1,000,000,000 cases"),
    ({"grid": {"mechanism.chain_defaults.following_link.length": [0.05]}}, r"in the case mechanism\.chain_defaults"),
])
def test_bad_specs_end_in_one_line(tmp_path, change, match):
    spec = yaml.safe_load(_spec(tmp_path).read_text())
    spec.update(change)
    with pytest.raises(SceneError, match=match) as e:
        parse_spec(spec)
    assert "\n" not in str(e.value)


def test_cli_sweep_reports_a_bad_spec_and_an_unreachable_scheduler_in_one_line(tmp_path, capsys):
    from rrr4.cli import main as cli_main
    assert cli_main(["sweep", str(tmp_path / "none.yaml")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    spec = _spec(tmp_path, grid={"joints.radial_clearance": [1.0e-4]})
    assert cli_main(["sweep", str(spec), "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--scheduler" in err


def test_workspace_map_agrees_with_the_controller_at_the_home_pose(paper_scene, tmp_path):
    """rrr4 map: the grid is evaluated at once; at the home pose (a grid point) the preload
    torque at rest equals the controller's own, and the condition number the Jacobian's."""
    import numpy as np

    from rrr4 import Mechanism
    from rrr4.control import controller_function
    from rrr4.studies.maps import workspace_map, write_map
    m = workspace_map(paper_scene, grid=21)
    i = j = 10  # x = y = 0
    assert m["x"][j] == pytest.approx(0.0, abs=1e-15) and m["y"][i] == pytest.approx(0.0, abs=1e-15)
    mech = Mechanism.from_scene(paper_scene)
    assert m["condition"][i, j] == pytest.approx(np.linalg.cond(mech.jacobian([0.0, 0.0, 0.0])), rel=1e-9)
    z = np.zeros(3)
    theta = mech.ik(z)
    tau_ff = np.array(controller_function(build(paper_scene))(z, z, z, theta, np.zeros(4))[1]).ravel()
    assert m["feasible_rest"][i, j] and m["torque_rest_Nm"][i, j] == pytest.approx(np.max(np.abs(tau_ff)), rel=1e-9)
    assert 0.2 < m["reachable"].mean() < 1.0 and not m["reachable"][0, 0]       # the corners are out of reach
    assert m["feasible_peak"].sum() <= m["feasible_rest"].sum()
    files = write_map(paper_scene, tmp_path / "map", grid=11)
    assert [f.name for f in files] == ["map.png", "map.npz", "map.json"]
    with pytest.raises(SceneError, match="--grid: 2 is not allowed"):
        workspace_map(paper_scene, grid=2)
    from rrr4 import load_scene
    with pytest.raises(SceneError, match="path.type: 'none' is not allowed for rrr4 map"):
        workspace_map(load_scene(ROOT / "problems" / "flores_slider_crank.yaml"), grid=5)


def test_workspace_map_of_the_graph_form_equals_the_closed_form(paper_scene, tmp_path):
    """The reference scene as a body/joint graph, assembled at every grid point by one
    continuation (Newton from the last point that closed), maps the same workspace as the
    closed form: the same reachable and feasible points, condition numbers and preload
    torques to 1e-8 relative; a point task (the five-bar) maps too."""
    import numpy as np

    from rrr4 import load_scene
    from rrr4.studies.maps import workspace_map, write_map
    closed = workspace_map(paper_scene, grid=15)
    graph = workspace_map(load_scene(ROOT / "problems" / "paper_circle_graph.yaml"), grid=15)
    for k in ("reachable", "feasible_rest", "feasible_peak"):
        assert np.array_equal(closed[k], graph[k]), k
    assert closed["reachable"].sum() > 50 and closed["feasible_rest"].sum() > 10
    both = closed["reachable"]
    for k in ("condition", "torque_rest_Nm", "torque_peak_Nm"):
        np.testing.assert_allclose(graph[k][both], closed[k][both], rtol=1e-8, err_msg=k)
    assert np.all(np.isnan(graph["min_transmission"]))
    files = write_map(load_scene(ROOT / "problems" / "redundant_five_bar.yaml"), tmp_path / "five_bar", grid=9)
    assert files[0].stat().st_size > 0


def test_a_sweep_over_the_mechanism_takes_its_geometry_as_inputs():
    """Contact numbers, gains, limits and f_min are inputs of the compiled stepping anyway; a
    spec that varies the mechanism's geometry or masses runs with them as inputs too and the
    controller's references tabulated per case (see
    test_with_geometry_inputs_scenes_that_differ_in_masses_and_geometry_share_their_compiled_code),
    so every sweep compiles once per structure."""
    from rrr4.studies.sweeps import case_options, load_spec
    assert case_options(load_spec(ROOT / "problems" / "sweeps" / "clearance_vs_preload.yaml")) == {}
    assert case_options(load_spec(ROOT / "problems" / "sweeps" / "tolerances.yaml")) == {
        "inputs": "geometry", "references": "sampled"}
    # no control rate: the controller follows the path inside the right-hand side, so the path
    # must not be a constant of the compiled code either
    continuous = parse_spec({"scene": "no_preload_circle.yaml", "grid": {"path.duration": [0.5, 1.0]}},
                            ROOT / "problems")
    assert case_options(continuous) == {"references": "sampled"}


def test_sweep_refuses_a_non_spec_and_too_many_workers_in_one_line(tmp_path):
    import os

    from rrr4.studies.sweeps import MAX_WORKERS_PER_CORE
    with pytest.raises(SceneError, match="spec: None is not allowed"):
        sweep(None)
    too_many = MAX_WORKERS_PER_CORE * (os.cpu_count() or 1) + 1
    with pytest.raises(SceneError, match=f"--workers: {too_many} is not allowed"):
        sweep(_spec(tmp_path), out=tmp_path / "o", workers=too_many)
    assert not (tmp_path / "o").exists()


def test_any_scheduler_address_ends_in_one_line_within_the_stated_time(tmp_path, monkeypatch):
    """Not a Dask scheduler: an HTTP server, a server that accepts and never answers, a bad or
    unsupported address. Each ends in one SceneError naming the address, within the bound."""
    import socket
    import threading
    import time
    from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

    from rrr4.studies import sweeps as sweeps_module
    monkeypatch.setattr(sweeps_module, "SCHEDULER_TIMEOUT", 3.0)
    spec = _spec(tmp_path)
    for bad, match in ((8786, "--scheduler: 8786 is not allowed"), ("tls://127.0.0.1:1", "tls:// is not supported"),
                       ("tcp://127.0.0.1:x", "is not allowed")):
        with pytest.raises(SceneError, match=match):
            sweep(spec, out=tmp_path / "o", scheduler=bad)
    silent = socket.socket()
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)  # accepts connections (the kernel's backlog) and never answers
    class Quiet(SimpleHTTPRequestHandler):
        def log_message(self, *args):  # the rejected Dask handshake is expected
            pass

    ThreadingHTTPServer.daemon_threads = True  # a request that never completes must not keep it alive
    http = ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=http.serve_forever, daemon=True).start()
    try:
        for port in (silent.getsockname()[1], http.server_address[1]):
            t0 = time.perf_counter()
            with pytest.raises(SceneError, match=f"--scheduler: 'tcp://127.0.0.1:{port}' is not a reachable") as e:
                sweep(spec, out=tmp_path / "o", scheduler=f"tcp://127.0.0.1:{port}")
            assert "\n" not in str(e.value) and time.perf_counter() - t0 < 3.0 + 10.0
    finally:
        silent.close()
        http.shutdown()


def test_any_value_on_any_spec_key_is_a_spec_or_one_line(tmp_path):
    """Property (the bad-scene property, for sweep specs): whatever value lands on whatever
    key of a spec, parsing it ends in a SweepSpec or in a one-line SceneError."""
    from hypothesis import HealthCheck, example, given, settings
    from hypothesis import strategies as st

    base = yaml.safe_load(_spec(tmp_path).read_text())
    values = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), st.floats(allow_nan=True),
                       st.text(max_size=12), st.lists(st.one_of(st.floats(-1e3, 1e3), st.none(), st.text(max_size=3)),
                                                      max_size=4),
                       st.dictionaries(st.one_of(st.text(max_size=8), st.none(), st.integers()),
                                       st.one_of(st.integers(), st.lists(st.floats(0, 1), max_size=3)), max_size=3))
    keys = ["scene", "t_end", "skip", "arms", "grid", "monte_carlo", "grid.joints.radial_clearance",
            "monte_carlo.samples", "monte_carlo.keys", "monte_carlo.seed", "extra"]

    @settings(max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))
    @given(key=st.sampled_from(keys), value=values)
    @example(key="scene", value="\n")  # found by hypothesis: a file name with a newline in the message
    def check(key, value):
        spec = yaml.safe_load(yaml.safe_dump(base))
        head, _, rest = key.partition(".")
        if rest:
            spec.setdefault(head, {})
            if not isinstance(spec[head], dict):
                spec[head] = {}
            spec[head][rest] = value
        else:
            spec[key] = value
        try:
            parse_spec(spec)
        except SceneError as e:
            assert "\n" not in str(e)

    check()


@pytest.mark.parametrize("address", ["tls://127.0.0.1:8786", "wss://127.0.0.1:8786", "inproc://x"])
def test_an_unsupported_scheduler_scheme_says_what_is_supported_and_why_before_any_work(tmp_path, capsys, address):
    """tls:// (and the other Dask schemes) are refused on the command line in one line that
    names the address, the supported form and the reason, before the spec's cases are run or
    the output directory is made."""
    from rrr4.cli import main
    out = tmp_path / "o"
    assert main(["sweep", str(_spec(tmp_path)), "--scheduler", address, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--scheduler: '{address}' is not allowed" in err, err
    assert "tcp://HOST:PORT" in err and "is not supported: " in err
    assert ("certificate" in err) == (address.startswith(("tls", "wss")))
    assert not out.exists()


def test_warm_cases_reuse_their_structures_and_give_the_rows_of_a_fresh_process(tmp_path):
    """One worker runs four cases (two clearances x two f_min): the equations, stepping and
    controller are built by the first case and reused by the other three, the preload's sign
    choice once per f_min; every row equals, to the last digit, the row of the same case run
    alone in a fresh process (every cache empty)."""
    spec = {"scene": SCENE, "t_end": 0.01, "arms": ["with_preload", "without_preload"],
            "grid": {"joints.radial_clearance": [5.0e-5, 1.0e-4], "actuation.preload.min_force": [10.0, 14.0]}}
    r = sweep(spec, out=tmp_path / "o", workers=1)
    assert r["failed"] == 0 and r["reused"] == {"plant": 3, "controller": 3, "preload": 2}
    parsed = parse_spec(spec)
    for case in parsed.cases:
        _, text = case_scene(parsed.scene, case)
        code = ("import json, sys; from rrr4.studies.sweeps import run_case; "
                "rows, _, reused = run_case(sys.stdin.read(), 'paper_circle', 0.01, "
                f"{list(parsed.arms)!r}, {r['compiled']!r}, {r['options']!r}); print(json.dumps([rows, reused]))")
        out = subprocess.run([sys.executable, "-c", code], input=text, capture_output=True, text=True, check=True)
        fresh, reused = json.loads(out.stdout.splitlines()[-1])
        assert reused == []
        warm = [{k: v for k, v in row.items() if k not in ("case", *case)} for row in r["rows"]
                if all(row[k] == v for k, v in case.items())]
        assert len(warm) == len(fresh) == 2
        for a, b in zip(sorted(warm, key=lambda x: x["arm"]), sorted(fresh, key=lambda x: x["arm"]), strict=True):
            assert a["status"] == "ok" and a.pop("wall_time_s") > 0 and b.pop("wall_time_s") > 0
            assert a == b


def test_a_driven_sweep_runs_the_scene_against_its_ideal_twin_and_reports_its_metrics(tmp_path):
    """The slider-crank (no task body, a crank driver): the arms of `rrr4 run`, its metrics, and
    no placeholder: a metric that does not apply is an empty cell, never 0 or NaN."""
    spec = {"scene": DRIVEN, "t_end": 0.004, "grid": {CLEARANCE_B: [5.0e-4, 2.5e-4]}}
    assert parse_spec(spec).arms == ("with_clearance", "ideal")  # the default arms follow the scene kind
    r = sweep(spec, out=tmp_path / "o", workers=2)
    rows = _rows(r["csv"])
    assert r["failed"] == 0 and len(rows) == 4 and all(row["status"] == "ok" for row in rows)
    assert list(rows[0]) == ["case", CLEARANCE_B, "arm", "status", "error", *DRIVEN_METRICS]
    for row in rows:
        for k, v in row.items():
            assert v.lower() not in ("nan", "inf", "-inf", "0", "0.0", "-0.0"), (row["arm"], k, v)
    clearance = [row for row in rows if row["arm"] == "with_clearance"]
    ideal = [row for row in rows if row["arm"] == "ideal"]
    assert len(clearance) == len(ideal) == 2
    for row in clearance:  # the journal rattles in its bore: impacts, penetration, forces, deviation
        assert int(row["contact_loss_events"]) > 0 and float(row["impacts_per_revolution"]) > 0
        assert 0 < float(row["max_penetration_m"]) < 1e-3
        assert float(row["peak_contact_force_N"]) > 100
        assert 0 < float(row["acceleration_deviation_rms_m_s2"]) < float(row["acceleration_deviation_max_m_s2"])
        assert 0 < float(row["driver_effort_rms_Nm"]) < float(row["driver_effort_peak_Nm"])
    for row in ideal:  # no clearance joint and no twin to deviate from: those cells are empty
        assert all(row[k] == "" for k in ("contact_loss_events", "impacts_per_revolution", "max_penetration_m",
                                          "peak_contact_force_N", "acceleration_deviation_rms_m_s2",
                                          "acceleration_deviation_max_m_s2"))
        assert 0 < float(row["driver_effort_rms_Nm"]) < float(row["driver_effort_peak_Nm"])
    for row in rows:  # a crank driver is revolute: no effort in N
        assert row["driver_effort_peak_N"] == row["driver_effort_rms_N"] == ""
    # the ideal twin does not depend on the clearance; the rattling does
    assert ideal[0]["driver_effort_peak_Nm"] == ideal[1]["driver_effort_peak_Nm"]
    assert clearance[0]["peak_contact_force_N"] != clearance[1]["peak_contact_force_N"]
    assert {f.name for f in r["figures"]} == {"acceleration_deviation_rms_m_s2.png", "impacts_per_revolution.png",
                                              "peak_contact_force_N.png"}


@pytest.mark.parametrize("arms", [["with_preload"], ["with_clearance", "without_preload"]])
def test_an_arm_of_the_other_scene_kind_is_refused_in_one_line_naming_the_allowed_arms(arms):
    spec = {"scene": DRIVEN, "t_end": 0.004, "arms": arms, "grid": {CLEARANCE_B: [5.0e-4]}}
    with pytest.raises(SceneError, match=r"arms: '\w+' is not allowed on a driven scene \(no task body\) "
                                         r"\(choose from: with_clearance, ideal\)$") as e:
        parse_spec(spec)
    assert "\n" not in str(e.value)


def test_a_driven_clearance_arm_alone_is_still_measured_against_its_ideal_twin():
    from rrr4.studies.sweeps import run_case
    spec = parse_spec({"scene": DRIVEN, "t_end": 0.002, "arms": ["with_clearance"], "grid": {CLEARANCE_B: [5.0e-4]}})
    _, text = case_scene(spec.scene, spec.cases[0])
    rows, _, _ = run_case(text, "flores_slider_crank", spec.t_end, spec.arms)
    assert [r["arm"] for r in rows] == ["with_clearance"] and rows[0]["status"] == "ok"
    assert rows[0]["acceleration_deviation_rms_m_s2"] > 0


def test_a_driven_sweep_row_is_what_rrr4_run_reports_for_the_same_case():
    """Impacts, deviations and driver efforts come from the outputs: the sweep keeps every step
    for a driven scene, as `rrr4 run` does, so a row and the study agree to the last digit."""
    from rrr4 import load_scene
    from rrr4.results.metrics import driven_scalar_metrics, driven_window
    from rrr4.studies.study import run_study
    from rrr4.studies.sweeps import run_case
    spec = parse_spec({"scene": DRIVEN, "t_end": 0.004, "grid": {CLEARANCE_B: [5.0e-4]}})
    scene_text = case_scene(spec.scene, spec.cases[0])[1]
    rows, _, _ = run_case(scene_text, "flores_slider_crank", spec.t_end, spec.arms)
    study = run_study(load_scene(DRIVEN), t_end=spec.t_end)
    t_from, revolution = driven_window(study.scene, spec.t_end)
    sims = {name: arm.simulation for name, arm in study.arms.items()}
    for row in rows:
        want = driven_scalar_metrics(sims[row["arm"]], None if row["arm"] == "ideal" else sims["ideal"], t_from,
                                     revolution)
        assert want and {k: row[k] for k in want} == want, row["arm"]


def test_a_scene_with_tables_sweeps_with_their_rows_carried_in_each_case(tmp_path):
    """The cases carry the tables' rows (path.time_table and a load's table as lists), so a
    worker in any directory, or on another machine, reads no file; the rows equal the CSVs'."""
    from rrr4.scene.time_table import read_time_table
    from rrr4.studies.sweeps import run_case
    law = ROOT / "results" / "paper_circle_optimal" / "time_law.csv"
    data = yaml.safe_load((ROOT / "problems" / "paper_circle.yaml").read_text())
    data["path"].update(time_law="table", time_table="law.csv")
    del data["path"]["duration"]
    data["forces"] = [{"type": "load", "body": "platform", "table": "cut.csv"}]
    (tmp_path / "law.csv").write_bytes(law.read_bytes())
    (tmp_path / "cut.csv").write_text("t,fx,fy,tz\n0,0,0,0\n0.005,-1.5,0.5,0.01\n")
    (tmp_path / "tabled.yaml").write_text(yaml.safe_dump(data))
    spec = parse_spec({"scene": str(tmp_path / "tabled.yaml"), "t_end": 0.01, "arms": ["with_preload"],
                       "grid": {"joints.radial_clearance": [1e-4]}})
    scene, text = case_scene(spec.scene, spec.cases[0])
    assert scene.path.time_table == read_time_table(law)
    assert scene.forces[0].table == ((0.0, 0.0, 0.0, 0.0), (0.005, -1.5, 0.5, 0.01))
    rows, _, _ = run_case(text, "tabled", spec.t_end, spec.arms)  # from the test's directory, not the scene's
    assert rows[0]["status"] == "ok", rows


@pytest.mark.parametrize("t_end", [10**400, -(10**400), float("nan")])
def test_a_number_no_float_holds_is_refused_in_one_line(t_end):
    with pytest.raises(SceneError, match=r"^t_end: .* is not allowed \(t_end \[s\] must be a finite number\)$"):
        parse_spec({"scene": str(ROOT / "problems" / "paper_circle.yaml"), "t_end": t_end,
                    "grid": {"joints.radial_clearance": [1e-4]}})
