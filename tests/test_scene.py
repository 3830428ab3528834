"""Scenes load into frozen dataclasses; every bad input names its key, value and what is allowed."""

import copy
import dataclasses
import subprocess
import sys

import pytest
import yaml

from rrr4 import SceneError, check_scene, load_scene
from rrr4.scene import PASSIVE_JOINTS, parse_scene, set_key


def test_reference_scene_holds_design_parameters(paper_scene):
    s = paper_scene
    assert [c.base for c in s.mechanism.chains] == [(-0.3, -0.3), (0.3, -0.3), (0.3, 0.3), (-0.3, 0.3)]
    for c in s.mechanism.chains:
        assert (c.driving.length, c.driving.mass) == (0.25, 0.40)
        assert c.driving.inertia == pytest.approx(0.40 * 0.25**2 / 12, rel=1e-15)
        assert (c.following.length, c.following.mass) == (0.25, 0.30)
        assert c.following.inertia == pytest.approx(0.30 * 0.25**2 / 12, rel=1e-15)
        assert c.attachment_radius == 0.10 and c.working_mode == 1
    assert (s.mechanism.platform.mass, s.mechanism.platform.inertia) == (0.80, 0.004)
    assert s.clearance_joints == PASSIVE_JOINTS
    for j in s.joints:
        assert (j.journal_radius, j.radial_clearance) == (0.005, 1e-4)
        assert (j.journal_material.youngs_modulus, j.journal_material.poisson_ratio) == (207e9, 0.3)
    assert s.effects.contact.restitution == 0.9
    assert (s.effects.friction.law, s.effects.friction.coefficient) == ("ambrosio", 0.1)
    assert s.effects.gravity == (0.0, 0.0)
    assert (s.path.type, s.path.radius, s.path.duration, s.path.time_law) == ("circle", 0.02, 1.0, "quintic")


def test_scene_is_frozen(paper_scene):
    with pytest.raises(dataclasses.FrozenInstanceError):
        paper_scene.name = "x"



BAD = [
    # (key to set, value, text the message must contain)
    ("mechanism.platform.mas", 1.0, "mechanism.platform.mas: unknown key (did you mean 'mass'?"),
    ("effects.contact.law", "lankarani", "effects.contact.law: unknown value 'lankarani'"),
    ("effects.contact.restitution", "high", "effects.contact.restitution: 'high' is not a number"),
    ("mechanism.chain_defaults.driving_link.length", -0.25,
     "mechanism.chain_defaults.driving_link.length: -0.25 is not allowed (must be > 0)"),
    ("mechanism.platform.mass", 0, "mechanism.platform.mass: 0 is not allowed (must be > 0)"),
    ("joints.radial_clearance", 0.005, "joints.radial_clearance: 0.005 m is not allowed (must be smaller than"),
    ("joints.clearance", ["B1", "D2"], "joints.clearance: unknown joint 'D2'"),
    ("integrator.method", "bathee", "did you mean 'bathe'?"),
    ("integrator.newton", "quasi", "integrator.newton: unknown value 'quasi' (choose one of: simplified, full)"),
    ("integrator.newton_tol", -1, "integrator.newton_tol: -1 is not allowed (must be > 0)"),
    ("path.radius", 0.4, "path: leaves the workspace at t ="),
    ("path.max_condition_number", 5.0, "path: passes through a parallel singularity at t ="),
    ("actuation.torque_limit", [1, 2, 3], "actuation.torque_limit: [1, 2, 3] is not allowed (a list of 4 numbers"),
    ("mechanism.chains[1].base", [0.3], "mechanism.chains[1].base: [0.3] is not allowed"),
]


@pytest.mark.parametrize("key,value,expected", BAD, ids=[b[0] for b in BAD])
def test_bad_input_raises_scene_error_naming_the_key(paper_data, key, value, expected):
    set_key(paper_data, key, value)
    with pytest.raises(SceneError) as err:
        check_scene(parse_scene(paper_data))
    assert expected in str(err.value)


def test_path_through_serial_singularity_is_rejected(paper_data):
    """Chain 1 stretched out: |C1 - A1| = l1 + l2 along a line that turns back there."""
    # C1 lies at o + 0.1 (cos 225, sin 225); A1 at (-0.3, -0.3). Move o towards (+,+) until
    # |C1 - A1| = 0.5 (fully stretched), then stop: the quintic law reaches the end point exactly.
    import numpy as np
    d0 = np.hypot(0.3 - 0.1 / np.sqrt(2), 0.3 - 0.1 / np.sqrt(2))
    s = (0.5 - d0) / np.sqrt(2) * (1 - 1e-9)
    paper_data["path"] = {"type": "line", "start": [0, 0, 0], "end": [s, s, 0], "duration": 1.0}
    with pytest.raises(SceneError, match=r"path: passes through a serial singularity at t = .* chain 1"):
        check_scene(parse_scene(paper_data))


def test_unknown_top_level_key_suggests_nearest(paper_data):
    paper_data["efects"] = paper_data.pop("effects")
    with pytest.raises(SceneError, match=r"efects: unknown key \(did you mean 'effects'\?"):
        parse_scene(paper_data)


def test_waypoint_path_and_three_chain_mechanism_load(paper_data):
    d = copy.deepcopy(paper_data)
    d["mechanism"]["chains"] = d["mechanism"]["chains"][:3]
    d["joints"]["clearance"] = "all"
    d["actuation"]["preload"]["weights"] = 1.0
    d["path"] = {"type": "waypoints", "points": [[0, 0, 0], [0.01, 0.01, 0.05], [0.02, 0, 0]], "duration": 1.0}
    s = parse_scene(d)
    assert s.mechanism.n_chains == 3 and s.clearance_joints == ("B1", "B2", "B3", "C1", "C2", "C3")


def test_cli_prints_one_line_and_exits_nonzero_on_bad_scene(paper_data, tmp_path):
    paper_data["effects"]["contact"]["law"] = "lankarani"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(paper_data))
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(bad)], capture_output=True, text=True)
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "effects.contact.law" in lines[0] and "lankarani-nikravesh" in lines[0]


def test_cli_reports_missing_file_and_bad_yaml(tmp_path):
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(tmp_path / "nope.yaml")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "does not exist" in r.stderr and "Traceback" not in r.stderr
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: [unclosed\n")
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(broken)], capture_output=True, text=True)
    assert r.returncode != 0 and "not valid YAML" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_cli_check_summarises_reference_scene():
    from tests.conftest import PAPER
    r = subprocess.run([sys.executable, "-m", "rrr4.cli", "check", str(PAPER)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "clearance joints (8)" in r.stdout and "worst Jacobian condition number" in r.stdout


def test_load_scene_reads_file(tmp_path, paper_data):
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(paper_data))
    assert load_scene(p).name == "paper_circle"


@pytest.mark.parametrize("section,law,key,value", [
    ("contact", "hertz", "restitution", 0.9),             # Hertz has no dissipation: c_r would be ignored
    ("contact", "kelvin-voigt", "restitution", 0.9),      # its dashpot takes damping, not c_r
    ("contact", "lankarani-nikravesh", "damping", 50.0),  # damping is the Kelvin-Voigt dashpot's
    ("friction", "none", "coefficient", 0.1),
    ("friction", "coulomb", "v0", 1e-4),                  # Coulomb has no regularisation
    ("friction", "smooth", "v1", 2e-4),
    ("friction", "ambrosio", "static_coefficient", 0.2),
    ("friction", "stribeck", "v1", 2e-4),
])
def test_a_key_the_law_does_not_use_is_refused_naming_the_law_and_its_keys(paper_data, section, law, key, value):
    from rrr4.scene.vocabulary import CONTACT_LAW_KEYS, FRICTION_LAW_KEYS
    takes = (CONTACT_LAW_KEYS if section == "contact" else FRICTION_LAW_KEYS)[law]
    given = {"law": law, key: value}
    if section == "friction" and law != "none":
        given.setdefault("coefficient", 0.1)
    paper_data["effects"][section] = given
    with pytest.raises(SceneError) as err:
        parse_scene(paper_data)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"effects.{section}.{key}: not used by law '{law}'")
    assert f"(it takes: {', '.join(('law', *takes))})" in msg
    # the same key under a law that uses it is read
    paper_data["effects"][section] = {"law": next(k for k, v in (CONTACT_LAW_KEYS if section == "contact"
                                                                 else FRICTION_LAW_KEYS).items() if key in v),
                                      key: value, **({"coefficient": 0.1} if section == "friction" else
                                                     {"stiffness": 1e9})}
    parse_scene(paper_data)


def test_every_shipped_scene_gives_only_keys_its_laws_use():
    """The committed scenes load under the per-law key check (they were written before it)."""
    from tests.conftest import ROOT
    scenes = [p for p in (ROOT / "problems").rglob("*.yaml") if "sweeps" not in p.parts]
    assert len(scenes) >= 15
    for p in scenes:
        load_scene(p)


def test_check_prints_every_derived_contact_number(paper_scene):
    """stiffness: auto is computed from the materials and radii (Lankarani-Nikravesh), the
    hysteresis factor from c_r, and v_min and the friction law's parameters are the ones the
    equations take: rrr4 check prints each of them."""
    from rrr4 import build
    from rrr4.contact import V_MIN, stiffness_internal_cylinder
    from rrr4.results.summary import contact_numbers, scene_summary
    problem = build(paper_scene)
    k = stiffness_internal_cylinder(0.005, 0.0051, 207e9, 0.3, 207e9, 0.3)
    n = contact_numbers(problem)
    assert n["stiffness_N_per_m^n"] == {j: pytest.approx(k) for j in paper_scene.clearance_joints}
    assert n["hysteresis_factor"] == pytest.approx(0.75 * (1 - 0.9**2)) and n["v_min_m_s"] == V_MIN
    assert n["friction"] == {"law": "ambrosio", "coefficient": 0.1, "v0_m_s": 1e-4, "v1_m_s": 2e-4}
    # the equations take the same numbers (the per-joint stiffness is their first input per joint)
    assert problem.contact_parameters[0] == pytest.approx(k)
    text = scene_summary(problem)
    assert f"{k:.4g} N/m^1.5" in text and "chi = 0.1425" in text and f"v_min = {V_MIN:g} m/s" in text
    assert "v0 = 0.0001 m/s, v1 = 0.0002 m/s" in text


@pytest.mark.parametrize("contact", [{"law": "kelvin-voigt"}, {"law": "hertz", "exponent": 1.0},
                                     {"law": "lankarani-nikravesh", "exponent": 2.0, "stiffness": "auto"}])
def test_auto_stiffness_only_with_the_exponent_it_is_derived_for(paper_data, contact):
    paper_data["effects"]["contact"] = contact
    with pytest.raises(SceneError, match=r"effects\.contact\.stiffness: 'auto' is not allowed with exponent"):
        parse_scene(paper_data)
    paper_data["effects"]["contact"] = {**contact, "stiffness": 1e9}
    assert parse_scene(paper_data).effects.contact.stiffness == 1e9


@pytest.mark.parametrize("law", ["smooth", "stribeck"])
def test_a_transition_speed_above_the_unused_v1_default_is_read(paper_data, law):
    """v1 is the ambrosio law's alone: a smooth or Stribeck law with v0 above v1's default
    (2e-4 m/s) is read, not refused for an ordering with a number it does not use; ambrosio's
    own v1 below its v0 is still refused in one line."""
    paper_data["effects"]["friction"] = {"law": law, "coefficient": 0.1, "v0": 1e-3}
    assert parse_scene(paper_data).effects.friction.v0 == 1e-3
    paper_data["effects"]["friction"] = {"law": "ambrosio", "coefficient": 0.1, "v0": 1e-3}
    with pytest.raises(SceneError, match=r"^effects\.friction\.v1: 0\.0002 m/s is not allowed \(must be greater"):
        parse_scene(paper_data)
