"""Scenes changed in memory (Scene.with_values) and one way to cache (issue 45, items 2 and 3).

- ``Scene.with_values`` gives the scene its YAML file would give with the same values written
  into it (read back with ``rrr4.load_scene``: a second path through the file); bad input is
  one line; a change made in memory before it is kept, or refused, never lost.
- Robustness, identification and sweeps take a scene built in Python (parsed from a mapping,
  no file) and vary it as it is, not as a file on disk says.
- A geometry sweep of 300 cases in one process keeps its memory flat (RSS after the bounded
  caches are full), and nothing derived from a mechanism keeps it alive once the caches let go.
"""

from __future__ import annotations

import copy
import dataclasses
import gc
import weakref

import numpy as np
import pytest
import yaml

import rrr4
from rrr4.errors import SceneError
from rrr4.identify import identify, resolve_parameters
from rrr4.identify.seated import seated_measurements
from rrr4.mechanism.mechanism import MECHANISMS, NRRRMechanism
from rrr4.scene import parse_scene, set_key
from rrr4.studies.robustness import CASES, perturbed, robustness
from rrr4.studies.sweeps import case_scene, parse_spec, run_case

from .conftest import PAPER, ROOT

SLIDER = ROOT / "problems" / "flores_slider_crank.yaml"
CLEARANCE, FRICTION = "joints.radial_clearance", "effects.friction.coefficient"


def _loaded(tmp_path, data: dict, name: str):
    """`data` written to a scene file and read back with rrr4.load_scene (the file's path)."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return rrr4.load_scene(path)


def _one_line(e, *parts):
    text = str(e.value)
    assert "\n" not in text, text
    for p in parts:
        assert p in text, (p, text)


@pytest.fixture
def python_scene(paper_data):
    """The reference scene built in Python: its mapping with a friction coefficient and gains no
    file has, parsed without any file."""
    set_key(paper_data, FRICTION, 0.07)
    set_key(paper_data, "actuation.gains.kp", 150.0)
    return parse_scene(paper_data, name="python_built")


# ---------------------------------------------------------------------- Scene.with_values


@pytest.mark.parametrize("values", [
    {CLEARANCE: 1.3e-4},
    {"mechanism.chains[2].base[1]": 0.301, "actuation.preload.min_force": 7.5},
    {"path.radius": 0.015, "integrator.step": 2e-5},
])
def test_with_values_is_the_scene_its_file_gives_with_the_values_written_into_it(paper_data, tmp_path, values):
    scene = rrr4.load_scene(PAPER)
    changed = scene.with_values(values)
    edited = copy.deepcopy(paper_data)
    for k, v in values.items():
        set_key(edited, k, v)
    assert changed == _loaded(tmp_path, edited, "paper_circle")
    assert changed != scene and scene == rrr4.load_scene(PAPER)  # the scene it came from is unchanged
    assert changed.with_values({}) == changed and changed.data_current


def test_a_scene_with_table_files_keeps_their_rows_and_varies_away_from_its_directory(paper_data, tmp_path):
    law = (ROOT / "results" / "paper_circle_optimal" / "time_law.csv").read_bytes()
    paper_data["path"].update(time_law="table", time_table="law.csv")
    del paper_data["path"]["duration"]
    (tmp_path / "law.csv").write_bytes(law)
    scene = _loaded(tmp_path, paper_data, "tabled")
    (tmp_path / "law.csv").unlink()  # nothing is read again
    changed = scene.with_values({CLEARANCE: 1.1e-4})
    assert changed.path.time_table == scene.path.time_table and len(scene.path.time_table) > 2
    assert changed.joint("B1").radial_clearance == 1.1e-4


def test_changes_made_in_memory_are_kept_or_refused_never_lost(paper_scene, tmp_path):
    limited = paper_scene.with_torque_limit(2.5).with_values({CLEARANCE: 1.2e-4})
    assert limited.torque_limit == (2.5,) * 4 and limited.joint("C3").radial_clearance == 1.2e-4
    rows = [(0.0, 0.0, 0.0), (0.5, 0.5, 2.0), (1.0, 1.0, 0.0)]
    tabled = paper_scene.with_time_table(rows).with_values({CLEARANCE: 1.2e-4})
    assert tabled.path.time_table == tuple(rows) and tabled.path.duration == 1.0
    graph = rrr4.load_scene(ROOT / "problems" / "paper_circle_graph.yaml")
    assert graph.with_torque_limit([1.0, 2.0, 3.0, 4.0]).with_values({}).torque_limit == (1.0, 2.0, 3.0, 4.0)
    with pytest.raises(SceneError) as e:  # a replace the data does not know of
        dataclasses.replace(paper_scene, effects=dataclasses.replace(paper_scene.effects, gravity=(0.0, -9.81))
                            ).with_values({CLEARANCE: 1.2e-4})
    _one_line(e, "'paper_circle'", "no longer describes it", "dataclasses.replace", "with_values")
    with pytest.raises(SceneError) as e:
        paper_scene.with_ideal_joints().with_values({})
    _one_line(e, "has no YAML data", "with_joints")


@pytest.mark.parametrize("values, parts", [
    ({CLEARANCE: -1e-4}, ["radial_clearance", "-0.0001"]),
    ({"joints..x": 1}, ["key 'joints..x' is not allowed", "mechanism.chains[0].base[1]"]),
    ({"mechanism.chains[9].base[0]": 0.3}, ["mechanism.chains[9]", "no item 9"]),
    ({"effects.contact.law": "rubber"}, ["effects.contact.law", "rubber"]),
    ([CLEARANCE], ["values:", "is not allowed", "a mapping of dotted scene keys"]),
])
def test_bad_values_end_in_one_line_naming_the_key(paper_scene, values, parts):
    with pytest.raises(SceneError) as e:
        paper_scene.with_values(values)
    _one_line(e, *parts)


def test_the_problem_cache_is_keyed_by_the_scenes_content_only(paper_data, paper_scene):
    python_built = parse_scene(paper_data)  # no file, the same content
    assert python_built.source == "" and paper_scene.source
    assert rrr4.build(python_built) is rrr4.build(paper_scene)
    assert rrr4.build(python_built.with_values({CLEARANCE: 1.05e-4})) is not rrr4.build(paper_scene)


# ---------------------------------------------------------------------- studies on a scene built in Python


def test_robustness_varies_the_scene_in_memory_not_a_file(python_scene, paper_scene):
    for case, change in CASES.items():
        plant = perturbed(python_scene, case)
        assert plant.actuation.kp == 150.0, case  # the in-memory gain, no file's
        if change is None or change[0] != FRICTION:
            assert plant.effects.friction.coefficient == 0.07, case
        twin = perturbed(paper_scene, case)  # the same change on the file's scene
        if change is not None and change[0] != FRICTION:
            key = change[0]
            assert rrr4.scene.get_key(plant.data, key) == rrr4.scene.get_key(twin.data, key), case
    limited = perturbed(paper_scene.with_torque_limit(3.0), "stiffness x3")
    assert limited.torque_limit == (3.0,) * 4  # before: the file's limits
    rows = robustness(python_scene, t_end=0.002)
    assert len(rows) == 2 * len(CASES) and all(np.isfinite(r["platform_error_rms_m"]) for r in rows)


def test_identification_of_a_scene_built_in_python_recovers_the_truth_and_keeps_its_values(python_scene):
    problem = rrr4.build(python_scene)
    keys = [CLEARANCE, FRICTION]
    params = resolve_parameters(problem, keys)
    truth = np.array([1.15e-4, 0.12])
    m = seated_measurements(problem, params, truth, np.linspace(0.0, 1.0, 101))
    res = identify(python_scene, m, keys, method="seated")
    assert np.allclose(res.estimate, truth, rtol=1e-6)
    ident = res.identified
    assert ident.joint("B2").radial_clearance == pytest.approx(truth[0], rel=1e-6)
    assert ident.effects.friction.coefficient == pytest.approx(truth[1], rel=1e-6)
    assert ident.actuation.kp == 150.0 and ident.name == "paper_circle_identified"


def test_a_sweep_over_a_scene_built_in_python_gives_the_rows_of_the_same_scene_from_its_file(
        python_scene, tmp_path):
    grid = {"grid": {CLEARANCE: [8e-5]}, "t_end": 0.002, "arms": ["with_preload", "without_preload"]}
    spec = parse_spec({"scene": python_scene, **grid})
    scene, text = case_scene(spec.scene, spec.cases[0])
    assert scene.actuation.kp == 150.0 and scene.joint("B1").radial_clearance == 8e-5
    path = tmp_path / "python_built.yaml"
    path.write_text(yaml.safe_dump(python_scene.data))
    from_file = parse_spec({"scene": str(path), **grid})
    assert case_scene(from_file.scene, from_file.cases[0])[1] == text  # the same case, to the byte
    assert spec.name == "paper_circle" and from_file.name == "python_built"  # the data's name; the file's stem
    rows, _, _ = run_case(text, spec.name, spec.t_end, spec.arms)
    assert [r["status"] for r in rows] == ["ok", "ok"], rows
    with pytest.raises(SceneError) as e:
        parse_spec({"scene": dataclasses.replace(python_scene, name="renamed"), **grid})
    _one_line(e, "'renamed'", "no longer describes it")


# ---------------------------------------------------------------------- one way to cache


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


def _flat_sweep(case, n: int, warm: int) -> tuple[float, float]:
    """(RSS growth [MB] from case `warm` to case `n`, RSS at `warm`) of n cases in this process."""
    at = None
    for i in range(n):
        case(i)
        if i + 1 == warm:
            gc.collect()
            at = _rss_mb()
    gc.collect()
    return _rss_mb() - at, at


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/statm"), reason="RSS read from /proc (Linux)")
def test_a_geometry_sweep_of_300_cases_in_one_process_keeps_its_memory_flat():
    """Each case moves the slider-crank's rod point (a new graph, model, mechanism and problem)
    and builds its start assembly and branch. Before the caches were bounded and keyed off
    the mechanism, RSS grew about 90 kB a case (18 MB over these 200); now it stays within
    3 MB once the bounded caches are full (after MECHANISMS + 36 cases)."""
    base = rrr4.load_scene(SLIDER)

    def case(i):
        problem = rrr4.build(base.with_values({"mechanism.bodies[1].points.A[0]": -0.06 - 1e-6 * i}))
        assert problem.mechanism.branch_text(problem.start_coordinates).startswith("B: ")

    growth, _ = _flat_sweep(case, 300, MECHANISMS + 36)
    assert growth < 3.0, f"RSS grew {growth:.1f} MB over {300 - MECHANISMS - 36} warm cases"


@pytest.mark.slow
def test_an_nrrr_geometry_sweep_of_300_cases_with_its_effort_family_keeps_its_memory_flat(paper_scene):
    """The same for the reference n-RRR with its closed-form effort family at a few poses
    (about 0.15 s a case): before, RSS grew 0.55 MB a case."""
    pose = np.array([[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [-0.02, 0.0, 0.0]])
    zero = np.zeros_like(pose)

    def case(i):
        problem = rrr4.build(paper_scene.with_values({"mechanism.chains[0].driving_link.length": 0.25 + 1e-6 * i}))
        family = problem.effort_family(pose, zero, zero)
        assert np.all(np.isfinite(family.tau_p))

    growth, _ = _flat_sweep(case, 300, MECHANISMS + 36)
    assert growth < 10.0, f"RSS grew {growth:.1f} MB over {300 - MECHANISMS - 36} warm cases"


def test_nothing_derived_from_a_mechanism_keeps_it_alive(paper_scene):
    """The closed-form inverse dynamics, reactions and actuator motion, and a graph's branch
    function, live on their mechanism (Mechanism.memo): once nobody holds it, it goes."""
    mech = NRRRMechanism(paper_scene.mechanism, paper_scene.graph)
    from rrr4.dynamics.inverse import actuator_motion_function, inverse_dynamics_function, joint_reactions_function
    f = inverse_dynamics_function(mech, (0.0, -9.81))
    assert f is inverse_dynamics_function(mech, [0.0, -9.81])  # built once
    joint_reactions_function(mech)
    actuator_motion_function(mech)
    q = mech.body_motion(np.zeros(3), np.zeros(3), np.zeros(3))[0]
    mech.branch_text(q)
    ref = weakref.ref(mech)
    del mech, f
    gc.collect()
    assert ref() is None


def test_frames_are_keyed_on_the_integrators_settings():
    from rrr4.integrators import METHODS
    a, b = METHODS["bathe"](gamma=0.5), METHODS["bathe"](gamma=0.5)
    assert a.settings_key() == b.settings_key() and hash(a.settings_key()) == hash(b.settings_key())
    assert a.settings_key() != METHODS["bathe"](gamma=0.4).settings_key()
    assert a.settings_key() != METHODS["newmark"]().settings_key()
    a.extra = object()  # a public attribute that is no setting is an error, not a key that only looks alike
    with pytest.raises(TypeError, match="Bathe.extra"):
        a.settings_key()
