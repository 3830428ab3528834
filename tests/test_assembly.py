"""Assembly of a graph scene: from no pose guesses, in the named assembly mode
(mechanism.assembly), with angles wrapped; the shipped graph scenes assemble without their
guesses to the configuration their guesses give; bad mode keys are refused in one line."""

import copy
import warnings

import numpy as np
import pytest
import yaml

import rrr4
from rrr4 import Mechanism, SceneError, check_scene
from rrr4.results.summary import scene_summary
from rrr4.scene import parse_scene
from rrr4.trajectory import sample_path
from tests.conftest import ROOT

GRAPH_SCENES = sorted(p for p in (ROOT / "problems").glob("*.yaml")
                      if (yaml.safe_load(p.read_text()).get("mechanism") or {}).get("kind") == "graph")

# a crank-rocker four-bar (Grashof: 0.1 + 0.3 <= 0.25 + 0.2), written without pose guesses
R2, L3, R4, G = 0.1, 0.25, 0.2, 0.3      # crank, coupler, rocker, ground [m]
CRANK0 = np.radians(60.0)                # the driver's initial angle


def _four_bar(mode=None, poses=None):
    bodies = [
        {"name": "crank", "mass": 0.2, "inertia": 2e-4, "points": {"O": [-R2 / 2, 0.0], "A": [R2 / 2, 0.0]}},
        {"name": "coupler", "mass": 0.3, "inertia": 1.5e-3, "points": {"A": [-L3 / 2, 0.0], "B": [L3 / 2, 0.0]}},
        {"name": "rocker", "mass": 0.25, "inertia": 8e-4, "points": {"B": [-R4 / 2, 0.0], "O": [R4 / 2, 0.0]}},
    ]
    for b, p in zip(bodies, () if poses is None else poses, strict=False):
        b["pose"] = list(map(float, p))
    mech = {
        "kind": "graph",
        "ground": {"points": {"O2": [0.0, 0.0], "O4": [G, 0.0]}},
        "bodies": bodies,
        "joints": [
            {"name": "O2", "bodies": ["ground", "crank"], "points": ["O2", "O"]},
            {"name": "A", "bodies": ["crank", "coupler"], "points": ["A", "A"]},
            {"name": "B", "bodies": ["coupler", "rocker"], "points": ["B", "B"]},
            {"name": "O4", "bodies": ["rocker", "ground"], "points": ["O", "O4"]},
        ],
        "drivers": [{"joint": "O2", "initial_deg": float(np.degrees(CRANK0)), "speed_rpm": 600.0}],
        "task": "none",
    }
    if mode is not None:
        mech["assembly"] = mode
    return {"name": "four_bar", "mechanism": mech, "effects": {"gravity": [0.0, 0.0]},
            "path": {"type": "none", "duration": 0.01, "sample_rate": 1000},
            "integrator": {"method": "rk4", "step": 1e-4}}


def _coupler_pin(sign):
    """B (2,) of the four-bar at CRANK0 on the branch whose bend at B, (B - A) x (O4 - B), has `sign`."""
    A = R2 * np.array([np.cos(CRANK0), np.sin(CRANK0)])
    O4 = np.array([G, 0.0])
    d = np.linalg.norm(O4 - A)
    a = (L3**2 - R4**2 + d**2) / (2 * d)
    h = np.sqrt(L3**2 - a**2)
    e = (O4 - A) / d
    for s in (1.0, -1.0):
        B = A + a * e + s * h * np.array([-e[1], e[0]])
        u, v = B - A, O4 - B
        if np.sign(u[0] * v[1] - u[1] * v[0]) == sign:
            return B
    raise AssertionError("no branch with that sign")


def _pin_of(q):
    """B (2,) on the coupler: its reference point plus the rotated local point (L3/2, 0)."""
    x, y, th = q[3:6]
    return np.array([x, y]) + L3 / 2 * np.array([np.cos(th), np.sin(th)])


def _without_guesses(data):
    d = copy.deepcopy(data)
    for b in d["mechanism"]["bodies"]:
        b.pop("pose", None)
    return d


def _start(mech, scene):
    if scene.graph.task is None:
        return mech.driver_targets(0.0)[0]
    return sample_path(scene.path).pose[0][:mech.n_task]


@pytest.mark.parametrize("path", GRAPH_SCENES, ids=[p.stem for p in GRAPH_SCENES])
def test_shipped_graph_scenes_assemble_without_guesses_as_with_them(path, capfd):
    data = yaml.safe_load(path.read_text())
    with_guess = parse_scene(data)
    without = parse_scene(_without_guesses(data))
    assert not np.any(Mechanism.from_scene(without).model.pose_guess)
    a, b = Mechanism.from_scene(with_guess), Mechanism.from_scene(without)
    assert a is not b or not np.any(a.model.pose_guess)  # xyt_table gives all-zero guesses
    target = _start(a, with_guess)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        qa, qb = a.assemble(target), b.assemble(target)
    np.testing.assert_allclose(qb, qa, atol=1e-9)
    assert np.all(np.abs(qb[2::3]) <= np.pi)
    out = capfd.readouterr()
    assert "nan" not in (out.out + out.err).lower()


@pytest.mark.parametrize("sign", [1, -1])
def test_four_bar_without_guesses_assembles_in_the_named_mode(sign, capfd):
    scene = parse_scene(_four_bar([{"joint": "B", "bend": "+" if sign > 0 else "-"}]))
    mech = Mechanism.from_scene(scene)
    q = mech.assemble(mech.driver_targets(0.0)[0])
    np.testing.assert_allclose(_pin_of(q), _coupler_pin(sign), atol=1e-12)
    assert np.sign(mech.mode_values(q)[0]) == sign
    assert np.all(np.abs(q[2::3]) <= np.pi)
    assert mech.assembled_branch.startswith(f"B: bend {'+' if sign > 0 else '-'}")
    assert "nan" not in capfd.readouterr().err.lower()
    # the whole motion stays on the branch (the check runs the path from this assembly)
    check_scene(scene)
    Q = mech.path_coordinates(mech.driver_targets(np.linspace(0.0, 0.1, 101)))
    assert np.all(np.sign([mech.mode_values(qk)[0] for qk in Q]) == sign)


def test_a_rough_guess_lands_on_the_named_branch_not_the_one_it_is_near():
    crossed = parse_scene(_four_bar([{"joint": "B", "bend": "-"}]))
    qc = Mechanism.from_scene(crossed).assemble(Mechanism.from_scene(crossed).driver_targets(0.0)[0])
    rough = (qc + np.tile([0.01, -0.01, 0.2], 3)).reshape(3, 3)  # near the crossed branch
    unnamed = Mechanism.from_scene(parse_scene(_four_bar(poses=rough)))
    q0 = unnamed.assemble(unnamed.driver_targets(0.0)[0])
    np.testing.assert_allclose(_pin_of(q0), _coupler_pin(-1), atol=1e-12)  # the guess alone: crossed
    named = Mechanism.from_scene(parse_scene(_four_bar([{"joint": "B", "bend": "+"}], poses=rough)))
    q = named.assemble(named.driver_targets(0.0)[0])
    np.testing.assert_allclose(_pin_of(q), _coupler_pin(1), atol=1e-12)


def test_assembled_angles_are_wrapped():
    scene = parse_scene(_four_bar([{"joint": "B", "bend": "+"}]))
    q = Mechanism.from_scene(scene).assemble(Mechanism.from_scene(scene).driver_targets(0.0)[0])
    far = q.reshape(3, 3) + np.array([0.0, 0.0, -6 * np.pi])  # guesses near -20 rad
    m = Mechanism.from_scene(parse_scene(_four_bar([{"joint": "B", "bend": "+"}], poses=far)))
    q2 = m.assemble(m.driver_targets(0.0)[0])
    assert np.all((q2[2::3] > -np.pi) & (q2[2::3] <= np.pi))
    np.testing.assert_allclose(q2, q, atol=1e-12)
    np.testing.assert_allclose(q2[2], CRANK0, atol=1e-12)  # the crank's angle


def test_a_mode_the_mechanism_cannot_take_is_one_line():
    # bend + with stretch + at B: the four-bar's + branch folds back there (stretch -)
    data = _four_bar([{"joint": "B", "bend": "+"}, {"joint": "B", "stretch": "+"}])
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(data))
    msg = str(err.value)
    assert "\n" not in msg and "named mode" in msg and "bend + at B, stretch + at B" in msg
    assert "B: bend +, stretch -" in msg


def test_check_prints_every_body_assembled_and_the_branch():
    text = scene_summary(parse_scene(_four_bar([{"joint": "B", "bend": "-"}])))
    lines = text.splitlines()
    start = lines.index("assembled at t = 0 (x, y in mm, theta in deg, wrapped to (-180, 180]):")
    body_lines = lines[start + 1:start + 4]
    assert [b.split(":")[0].strip() for b in body_lines] == ["crank", "coupler", "rocker"]
    assert body_lines[0].endswith(f"{np.degrees(CRANK0):+.3f} deg")
    assert lines[start + 4].startswith("  branch: B: bend -") and "named in mechanism.assembly" in lines[start + 4]
    unnamed = scene_summary(parse_scene(_four_bar()))
    assert "none named: mechanism.assembly fixes it" in unnamed


BAD_MODES = [
    ("not a list", {"joint": "B", "bend": "+"}, "mechanism.assembly: {'bend': '+', 'joint': 'B'} is not allowed"),
    ("unknown joint", [{"joint": "C", "bend": "+"}],
     "mechanism.assembly[0].joint: unknown revolute joint 'C'"),
    ("bad sign", [{"joint": "B", "bend": "up"}],
     "mechanism.assembly[0].bend: 'up' is not allowed (one of: '+', '-')"),
    ("both measures", [{"joint": "B", "bend": "+", "stretch": "-"}],
     "both bend and stretch are given (exactly one of bend or stretch is allowed"),
    ("no measure", [{"joint": "B"}], "neither is given (exactly one of bend or stretch is allowed"),
    ("unknown key", [{"joint": "B", "bend": "+", "sign": 1}], "mechanism.assembly[0]"),
    ("unknown point", [{"joint": "B", "bend": "+", "points": ["A", "Q"]}],
     "mechanism.assembly[0].points[1]: unknown point of rocker 'Q'"),
    ("its own point", [{"joint": "B", "bend": "+", "points": ["B", "O"]}],
     "mechanism.assembly[0].points[0]: [0.125, 0.0] is not allowed (it is B's own point on coupler"),
    ("named twice", [{"joint": "B", "bend": "+"}, {"joint": "B", "bend": "-"}],
     "mechanism.assembly[1].joint: 'B' is not allowed (its bend is already named)"),
]


@pytest.mark.parametrize("what,mode,expected", BAD_MODES, ids=[b[0] for b in BAD_MODES])
def test_bad_assembly_keys_are_refused_in_one_line(what, mode, expected):
    with pytest.raises(SceneError) as err:
        parse_scene(_four_bar(mode))
    msg = str(err.value)
    assert "\n" not in msg and expected in msg, msg


def test_a_body_with_several_other_joints_needs_its_reference_point():
    data = yaml.safe_load((ROOT / "problems" / "redundant_five_bar.yaml").read_text())
    data["mechanism"]["assembly"] = [{"joint": "B3", "bend": "-"}]
    with pytest.raises(SceneError) as err:
        parse_scene(data)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith("mechanism.assembly[0].points: missing; distal_3 has 3 joints besides B3") or \
        msg.startswith("mechanism.assembly[0].points: missing; distal_3 has 2 joints besides B3"), msg


def test_a_mode_the_motion_does_not_keep_is_refused_in_one_line():
    """The slider-crank's stretch at the crank pin A is + at 0 deg and - at 90 deg: not a
    branch's property; the slider's side of the pin (stretch + at B against the slide) is."""
    data = yaml.safe_load((ROOT / "problems" / "flores_slider_crank_ideal.yaml").read_text())
    data["path"]["duration"] = 0.012  # one crank revolution at 5000 rpm
    check_scene(parse_scene(data))
    data["mechanism"]["assembly"] = [{"joint": "A", "stretch": "+"}]
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(data))
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("mechanism.assembly[0]: stretch + at A does not hold along the motion")


TASK_SCENES = [p for p in GRAPH_SCENES if parse_scene(yaml.safe_load(p.read_text())).graph.task is not None
               and parse_scene(yaml.safe_load(p.read_text())).graph.actuators]


@pytest.mark.parametrize("path", TASK_SCENES, ids=[p.stem for p in TASK_SCENES])
def test_forward_kinematics_without_guesses_lands_on_the_pose(path, capfd):
    """fk with no guess (no pose guesses in the scene either) finds the pose whose IK gave the
    actuator coordinates, on the named mode, at the path's samples, without NaN warnings."""
    scene = parse_scene(_without_guesses(yaml.safe_load(path.read_text())))
    mech = Mechanism.from_scene(scene)
    poses = sample_path(scene.path).pose[::250, :mech.n_task]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for pose in poses:
            got = mech.fk(mech.ik(np.r_[pose, np.zeros(3 - len(pose))]))
            np.testing.assert_allclose(got[:mech.n_task], pose, atol=1e-9)
    out = capfd.readouterr()
    assert "nan" not in (out.out + out.err).lower()


def test_forward_kinematics_of_coordinates_no_closure_takes_is_one_line():
    scene = parse_scene(_without_guesses(yaml.safe_load((ROOT / "problems" / "redundant_five_bar.yaml").read_text())))
    mech = Mechanism.from_scene(scene)
    theta = mech.ik(np.r_[sample_path(scene.path).pose[0, :2], 0.0])
    theta[2] += 1.0  # the third (redundant) actuator disagrees with the other two
    with pytest.raises(rrr4.KinematicsError, match="forward kinematics found no closure") as e:
        mech.fk(theta)
    assert "\n" not in str(e.value)
