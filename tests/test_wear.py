"""Wear of clearance joints (Archard): the worn volume against k W s / H, continuity of the
profile and of the contact on it, the cycle jump's error against its closed form, dry scenes
left as they were, and bad input in one line."""

import copy
import functools
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import rrr4
import rrr4.results.summary
from rrr4 import SceneError
from rrr4.contact.conformal import arc_points, sampling_matrix
from rrr4.contact.wear import (
    depth_at,
    node_angles,
    node_depths,
    profile_volume,
)
from rrr4.dynamics.builder import with_profiles
from rrr4.problem import Problem
from rrr4.scene import parse_scene, read_yaml, set_key
from rrr4.studies.wear import jump_cycles
from tests.conftest import ROOT

JOURNAL = ROOT / "problems" / "wear_journal.yaml"
K, H, L = 1.0e-5, 1.0e9, 0.02          # the scene's wear coefficient, hardness [Pa], bearing length [m]
R_J, C0 = 0.01, 1.0e-4                 # journal radius, radial clearance [m]
W = (2.0 + 0.5e-3) * 9.81              # the sleeve's weight and half the link's [N]
OMEGA = 600.0 / 60.0 * 2.0 * math.pi   # the shaft's speed [rad/s]


def test_journal_under_constant_load_wears_archards_volume():
    """A shaft turning at constant speed under a constant load W (frictionless, so nothing else
    turns): both surfaces wear k W s / H, s = R_J omega t the slid distance, to 1e-6; the bore
    where it is loaded (its top, 90 deg), the shaft evenly all round."""
    sim = rrr4.simulate(JOURNAL, t_end=0.2)
    archard = K * W * R_J * OMEGA * 0.2 / H
    assert abs(np.mean(sim.normal_force) - W) < 1e-4 * W  # the load is what the closed form assumes
    bore, shaft = sim.wear["S"]["bearing"], sim.wear["S"]["journal"]  # the profiles' coefficients
    assert profile_volume(bore, L, R_J + C0) == pytest.approx(archard, rel=1e-6)
    assert profile_volume(shaft, L, R_J) == pytest.approx(archard, rel=1e-6)
    assert np.degrees(node_angles(len(bore))[np.argmax(bore)]) == pytest.approx(90.0)
    assert np.ptp(shaft) < 0.02 * np.max(shaft)  # two revolutions: even all round


def test_profile_interpolation_is_continuous_periodic_and_keeps_the_volume():
    rng = np.random.default_rng(1)
    depths = rng.uniform(0.0, 1e-6, 12)
    grid = np.linspace(-2 * math.pi, 4 * math.pi, 20001)
    assert np.allclose(depth_at(np.ones(12), grid), 1.0, atol=1e-12)  # a partition of unity: the volume is kept
    assert min(depth_at(np.eye(12)[i], grid).min() for i in range(12)) >= 0.0
    w = depth_at(depths, grid)
    assert np.allclose(node_depths(depths), depth_at(depths, node_angles(12)), atol=1e-18)
    slope = np.gradient(w, grid)
    assert np.max(np.abs(np.diff(slope))) < 0.01 * np.max(np.abs(slope))  # the slope is continuous too
    some = np.linspace(0.0, 2 * math.pi, 77)
    assert np.allclose(depth_at(depths, some), depth_at(depths, some + 2 * math.pi), atol=1e-18)
    # the equations read it at the arc's points through a sparse matrix: the same numbers
    s = np.array(sampling_matrix(12))
    assert np.allclose(s.sum(axis=1), 1.0) and np.allclose(s @ depths, depth_at(depths, arc_points(12)), atol=1e-18)


def test_contact_on_a_worn_profile_is_continuous_and_uses_the_worn_clearance():
    """Sweep the eccentricity's direction around the bore at a fixed |e|: the penetration is the
    deepest overlap max_psi |e| cos(psi - phi) - c0 - w_B(psi) - w_J(psi - theta_J) (numpy's
    interpolation on a fine grid), and the distributed normal force, its direction and the
    penetration are continuous (no jump at the profile's nodes or the quadrature's points)."""
    problem = Problem.from_scene(JOURNAL)
    rng = np.random.default_rng(2)
    worn = {"S": {"bearing": rng.uniform(0, 4e-6, 36), "journal": rng.uniform(0, 2e-6, 36)}}
    eqs = with_profiles(problem.equations(), worn)
    nq, n = eqs.nq, 4001
    psi = np.linspace(0.0, 2 * math.pi, n)
    size = C0 + 5e-6
    q = np.zeros((nq, n))
    shaft, sleeve = (problem.model.rotation_index(b) - 2 for b in ("shaft", "sleeve"))
    q[shaft + 2] = 0.3  # the shaft turned: its profile is read in its own frame
    q[sleeve] = -size * np.cos(psi)  # bore centre = -e (the shaft's centre at the origin)
    q[sleeve + 1] = -size * np.sin(psi)
    f = eqs.acceleration.map(n)
    out = f(q=q, qd=np.zeros((nq, n)), delta_dot0=1e-3, in_contact=1.0, t=0.0)
    pen, fn = np.array(out["penetration"]).ravel(), np.array(out["normal_force"]).ravel()
    fine = np.linspace(-0.5, 0.5, 2001)  # around the line of centres
    expected = np.max(size * np.cos(fine)[None, :] - C0 - depth_at(worn["S"]["bearing"], psi[:, None] + fine)
                      - depth_at(worn["S"]["journal"], psi[:, None] + fine - 0.3), axis=1)
    assert np.max(np.abs(pen - expected)) < 0.03 * 4e-6  # the quadrature points 2.5 deg apart on a rough profile
    slope = sum(np.max(np.abs(np.diff(np.r_[d, d[0]]))) / (2 * math.pi / 36) for d in worn["S"].values())
    assert np.max(np.abs(np.diff(pen))) <= slope * (psi[1] - psi[0]) * (1 + 1e-6)  # no jump, at the nodes either
    assert np.max(np.abs(np.diff(fn))) < 0.02 * np.max(fn)
    force = np.array(out["contact_force"])  # on the journal: along the worn surface's normal, which turns smoothly
    turn = np.diff(np.unwrap(np.arctan2(force[1], force[0])))
    assert np.max(np.abs(turn)) < 0.01


def test_energy_audit_closes_with_friction_over_the_arc():
    """Friction at every point of the arc with its own slip (the shaft turning under the
    sleeve): the audit counts the points' friction power and still closes."""
    data = read_yaml(JOURNAL)
    set_key(data, "effects.friction", {"law": "ambrosio", "coefficient": 0.1, "v0": 1.0e-4, "v1": 2.0e-4})
    rng = np.random.default_rng(4)
    worn = {"S": {"bearing": rng.uniform(0, 3e-6, 36), "journal": rng.uniform(0, 2e-6, 36)}}
    sim = rrr4.simulate(parse_scene(data), t_end=0.02, wear=worn)
    assert sim.energy["dissipated_friction"][-1] > 0.5 * 0.1 * W * R_J * OMEGA * 0.02  # friction did work
    assert sim.energy_audit_residual < 1e-5


def test_energy_audit_closes_on_a_rough_worn_profile():
    """The normal force acts along the gradient of the worn penetration, so it derives from the
    contact potential: the energy audit closes to the integrator's error on a rough profile
    (a force along the line of centres would not: its tangential share is missing)."""
    rng = np.random.default_rng(3)
    worn = {"S": {"bearing": rng.uniform(0, 3e-6, 36), "journal": rng.uniform(0, 2e-6, 36)}}
    sim = rrr4.simulate(JOURNAL, t_end=0.1, wear=worn)
    assert sim.energy_audit_residual < 1e-5
    assert np.ptp(sim.normal_force) > 0.05 * W  # the shaft's rough profile shakes the load: the audit is exercised


LOAD, VOLUME = 637.65, 2.80e-9  # the fixed load [N] and the worn volume [m^3] of the user's measurement
R_B = R_J + C0


def _lune(depth, a):
    """The exact lune [m] at angles a [rad] from the load: the journal's circle (R_J) displaced
    by c0 + depth from the bore's centre, beyond the original bore (R_B)."""
    e = C0 + depth
    return np.maximum(e * np.cos(a) + np.sqrt(R_J**2 - (e * np.sin(a)) ** 2) - R_B, 0.0)


def _lune_depth(volume):
    """The lune's depth [m] whose volume L R_B int w da is `volume` [m^3] (bisection)."""
    a = np.linspace(-math.pi / 2, math.pi / 2, 20001)
    lo, hi = 0.0, 1e-3
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if L * R_B * np.trapezoid(_lune(mid, a), a) < volume else (lo, mid)
    return 0.5 * (lo + hi)


def _half_width(w, a):
    """The angular width [rad] of the groove where it is deeper than half its depth."""
    inside = a[w >= 0.5 * w.max()]
    return inside.max() - inside.min()


@functools.cache
def _worn_under_fixed_load(nodes: int, steps: int = 10):
    """The bore's profile after VOLUME of wear under the fixed LOAD on the shaft turning at
    OMEGA (frictionless; the bore wears, the shaft does not): the scene's own equations (the
    conformal contact and its wear rates), the bore held where the contact carries LOAD
    (bisection on its position), the profile advanced in `steps` equal volumes."""
    data = read_yaml(JOURNAL)
    set_key(data, "effects.wear.surfaces", "bearing")
    set_key(data, "effects.wear.nodes", nodes)
    problem = Problem.from_scene(parse_scene(data))
    eqs = problem.equations()
    at, parameters, c = eqs.layout.slice("profiles.S.bearing"), np.array(eqs.parameters), np.zeros(nodes)
    q, qd = np.zeros(eqs.nq), np.zeros(eqs.nq)
    qd[problem.model.rotation_index("shaft")] = OMEGA

    def contact(sink):
        q[problem.model.rotation_index("sleeve") - 1] = -sink  # the bore's centre below the shaft's
        parameters[at] = c
        out = eqs.parametric.acceleration(q=q, qd=qd, delta_dot0=1e-3, in_contact=1.0, t=0.0, parameters=parameters)
        return float(out["normal_force"]), np.array(out["wear_rate"]).ravel()

    for _ in range(steps):
        lo, hi = C0, C0 + 2.0 * c.max() + 1e-5
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if contact(mid)[0] < LOAD else (lo, mid)
        rate = contact(0.5 * (lo + hi))[1]
        c = c + rate * (VOLUME / steps) / profile_volume(rate, L, R_B)
    angles = np.linspace(0.0, math.pi, 18001)  # the top half of the bore, the load at 90 deg
    return c, angles, depth_at(c, angles)


@pytest.mark.parametrize("nodes", [36, 72, 144, 288])
def test_steady_conformal_wear_under_a_fixed_load_is_the_lune(nodes):
    """Under a fixed load the journal sinks into the bore and the wear goes as cos(psi) over
    the contact arc: the worn profile is the lune between the original bore and the journal's
    circle displaced by c0 + depth (the user's case: 637.65 N, k 1e-5, H 1 GPa, L 20 mm, 2.80e-9
    m^3, a 18.5 um deep, 65 deg wide lune). Its depth and its width at half depth, at every node
    count, within 4 % (2.4 % and 3.6 % at 36 nodes, both within 0.5 % from 144 on; wear
    deposited at the one contact direction made it 40 um deep at 36 nodes, 160 um at 144)."""
    c, a, w = _worn_under_fixed_load(nodes)
    assert profile_volume(c, L, R_B) == pytest.approx(VOLUME, rel=1e-9)
    depth = _lune_depth(VOLUME)
    exact = _lune(depth, a - math.pi / 2)
    assert w.max() == pytest.approx(depth, rel=0.04)
    assert _half_width(w, a) == pytest.approx(_half_width(exact, a), rel=0.04)
    assert abs(a[np.argmax(w)] - math.pi / 2) < 0.01  # under the load
    # the whole shape, not two numbers: the B-spline rounds the lune's edges (a kink) over about
    # two node spacings (12 % of the depth there at 36 nodes, 7 % at 72, 2 % at 288)
    assert np.max(np.abs(w - exact)) < 0.15 * depth


def test_the_groove_converges_as_the_profile_is_refined():
    """36, 72, 144, 288 nodes: the depth and the worn arc converge, the differences from the
    finest falling at least fourfold per halving of the node spacing (second order)."""
    runs = [_worn_under_fixed_load(m) for m in (36, 72, 144, 288)]
    depth = [w.max() for _, _, w in runs]
    width = [_half_width(w, a) for _, a, w in runs]
    for values in (depth, width):
        diff = [abs(v - values[-1]) for v in values[:-1]]
        assert diff[0] > 4 * diff[1] and diff[0] > 16 * diff[2] * 0.5
    assert abs(depth[0] - depth[-1]) < 0.03 * depth[-1]


def test_the_cycle_jump_error_shrinks_with_the_jump():
    """Per-cycle wear dw/dN = r / (1 + w / b) (the wear slows as the profile deepens) has the
    closed form w(N) = b (sqrt(1 + 2 r N / b) - 1); cycle jumping is explicit Euler in N, so
    its error falls in proportion to the jump."""
    r, b, N = np.array([1e-9, 2e-9, 0.5e-9]), 2e-6, 100000
    exact = b * (np.sqrt(1 + 2 * r * N / b) - 1)

    def cycle(profiles):
        w = np.zeros(3) if profiles is None else profiles["J"]["bearing"]
        return {"J": {"bearing": r / (1 + w / b)}}, {"w": w.copy()}

    errors = []
    for f in (0.04, 0.02, 0.01, 0.005):
        profiles, at, jumps, records = jump_cycles(cycle, {"J": 1e-4}, N, f)
        assert at[-1] == N and jumps.sum() == N and len(records) == len(at)
        change = np.diff([rec["w"] for rec in records], axis=0)
        assert np.max(change) <= f * 1e-4 * (1 + 1e-9)  # each jump changes the profile by at most f c
        errors.append(np.max(np.abs(profiles["J"]["bearing"] - exact)) / exact.max())
    assert all(a > b for a, b in zip(errors, errors[1:], strict=False))
    assert 1.6 < errors[-2] / errors[-1] < 2.4  # first order
    assert errors[-1] < 0.01


def test_dry_scene_equations_are_unchanged():
    dry = Problem.from_scene(ROOT / "problems" / "flores_slider_crank.yaml").equations()
    assert dry.worn == () and "wear_rate" not in dry.acceleration.name_out()
    assert not any("wear" in t for t in dry.terms)
    assert dry.acceleration.n_instructions() == 626  # as before wear existed (tests/test_lubrication.py)


def _unworn_journal(pressed: float, nodes: int = 36):
    """The normal force [N] of the wear scene (conformal contact) and of the same scene without
    wear (the dry point law K delta^1.5), the bore pressed `pressed` [m] beyond the clearance."""
    data = read_yaml(JOURNAL)
    set_key(data, "effects.wear.nodes", nodes)
    worn = Problem.from_scene(parse_scene(data))
    set_key(data, "effects.wear", "none")
    plain = Problem.from_scene(parse_scene(data))
    q, qd = np.zeros(worn.equations().nq), np.zeros(worn.equations().nq)
    q[worn.model.rotation_index("sleeve") - 1] = -(C0 + pressed)  # the bore pressed on the shaft from above
    qd[worn.model.rotation_index("shaft")] = OMEGA
    args = dict(q=q, qd=qd, delta_dot0=1e-3, in_contact=1.0, t=0.01)
    return [float(p.equations().acceleration(**args)["normal_force"]) for p in (worn, plain)]


@pytest.mark.parametrize("pressed", [3e-7, 1e-6, 3e-6])
def test_the_unworn_conformal_contact_has_the_dry_laws_stiffness(pressed):
    """The elastic layer's modulus is chosen so that on an unworn bore its force over the arc,
    K_w L R_B sqrt(2 / c0) (4/3) delta^1.5, is the dry law's K delta^1.5 (delta << c0): the
    sum over the quadrature points holds it to 2 % from the 4.4 deg wide contact of the scene's
    own 20 N (delta = 0.3 um) to 550 N."""
    conformal, dry = _unworn_journal(pressed)
    assert dry > 10.0
    assert conformal == pytest.approx(dry, rel=0.02)


def test_a_joint_overrides_the_scenes_wear_and_the_numbers_are_inputs_not_structure():
    data = read_yaml(ROOT / "problems" / "paper_circle_wear.yaml")
    data["joints"].setdefault("per_joint", {})["B1"] = {"wear": {"surfaces": "none"}}
    p = Problem.from_scene(parse_scene(data))
    eqs = p.equations()
    assert [t for t in eqs.terms if "wear" in t] == ["wear (Archard, bearing) at B2 B3 B4 C1 C2 C3 C4"]
    assert [j for j, _, _ in eqs.worn] == ["B2", "B3", "B4", "C1", "C2", "C3", "C4"]
    set_key(data, "effects.wear.coefficient", 2.6e-4)
    q = Problem.from_scene(parse_scene(data))
    assert q.equations().parametric is eqs.parametric  # one structure: a sweep over k compiles once
    k = eqs.profile_start - 3  # the last worn joint's wear coefficient
    assert q.contact_parameters[k] == 2.6e-4 and p.contact_parameters[k] == 1.3e-4
    lines = rrr4.results.summary.contact_lines(rrr4.results.summary.contact_numbers(q))
    assert [line.split(":")[0] for line in lines if line.startswith("wear")] == [
        f"wear at {j}" for j in ("B2", "B3", "B4", "C1", "C2", "C3", "C4")]
    assert "wear at B2: Archard on bearing, k = 0.00026, H = 8e+09 Pa, length 0.01 m, 36 profile coefficients" in lines


def test_a_profile_update_compiles_nothing():
    p = Problem.from_scene(JOURNAL)
    eqs = p.equations()
    other = with_profiles(eqs, {"S": {"bearing": np.full(36, 1e-6)}})
    assert other.parametric is eqs.parametric
    assert np.all(other.parameters[eqs.profile_start:eqs.profile_start + 36] == 1e-6)


@pytest.mark.parametrize("key,value,says", [
    ("surfaces", "top", "effects.wear.surfaces: unknown value 'top'"),
    ("coefficient", 0.0, "effects.wear.coefficient: 0 is not allowed (must be > 0)"),
    ("coefficient", 2.0, "effects.wear.coefficient: 2 is out of range"),
    ("hardness", -1.0, "effects.wear.hardness: -1 is not allowed (must be > 0)"),
    ("length", "abc", "effects.wear.length: 'abc' is not a number"),
    ("nodes", 3, "effects.wear.nodes: 3 is not allowed (an integer from 8 to 720)"),
    ("nodes", 12.5, "effects.wear.nodes: 12.5 is not an integer"),
    ("depth", 1.0, "effects.wear.depth: unknown key"),
])
def test_bad_wear_is_refused_in_one_line(key, value, says):
    data = copy.deepcopy(read_yaml(JOURNAL))
    set_key(data, f"effects.wear.{key}", value)
    with pytest.raises(SceneError) as err:
        parse_scene(data)
    assert str(err.value).startswith(says) and "\n" not in str(err.value)


def test_kelvin_voigt_with_wear_is_refused_in_one_line():
    data = read_yaml(JOURNAL)
    set_key(data, "effects.contact", {"law": "kelvin-voigt", "exponent": 1.5, "stiffness": "auto", "damping": 100.0})
    with pytest.raises(SceneError) as err:
        Problem.from_scene(parse_scene(data)).equations()
    assert str(err.value).startswith("effects.contact.law: 'kelvin-voigt' is not allowed with effects.wear")
    assert "\n" not in str(err.value)


def test_bad_profiles_are_refused_in_one_line():
    eqs = Problem.from_scene(JOURNAL).equations()
    with pytest.raises(SceneError, match=r"^wear: unknown worn surface 'S.rim'"):
        with_profiles(eqs, {"S": {"rim": np.zeros(36)}})
    with pytest.raises(SceneError, match=r"^wear: the profile of S.bearing is not allowed \(36 finite"):
        with_profiles(eqs, {"S": {"bearing": -np.ones(36)}})


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "rrr4.cli", "wear", *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


@pytest.mark.parametrize("args,says", [
    (["--cycles", "0"], "--cycles"),
    (["--cycles", "1.5"], "cycles: 1.5 is not allowed"),
    (["--cycles", "10", "--max-change", "2"], "max_change: 2 is not allowed"),
    (["--cycles", "10", "--max-change", "-0.1"], "--max-change"),
])
def test_bad_wear_arguments_are_one_line(args, says):
    r = _cli(str(JOURNAL), *args)
    assert r.returncode == 2 and says in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_scene_without_wear_is_refused_in_one_line():
    r = _cli(str(ROOT / "problems" / "flores_slider_crank.yaml"), "--cycles", "10")
    assert r.returncode == 2 and "effects.wear: 'none' is not allowed for rrr4 wear" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_rrr4_wear_jumps_many_cycles_to_archards_volume(tmp_path):
    """10^4 revolutions under a constant load: the worn volume per cycle does not change, so
    each surface has worn 10^4 times a revolution's k W s / H. The groove's shape does (it
    widens toward the lune as it deepens), so the jumps are no longer exact in the profile:
    their error is 0.66 % of the deepest depth. The shaft turns at 6000 rpm instead of the
    scene's 600 (a revolution's volume does not depend on the speed without friction; ten times
    fewer steps a cycle)."""
    import yaml
    data = yaml.safe_load(JOURNAL.read_text())
    data["mechanism"]["drivers"][0]["speed_rpm"] = 6000.0
    fast = tmp_path / "wear_journal_6000rpm.yaml"
    fast.write_text(yaml.safe_dump(data))
    r = _cli(str(fast), "--cycles", "10000", "--out", str(tmp_path / "w"))
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "w" / "summary.json").read_text())
    arm = summary["arms"]["with_clearance"]
    archard = 2 * K * W * R_J * 2 * math.pi * 10000 / H  # both surfaces
    assert arm["worn_volume_m3"] == pytest.approx(archard, rel=1e-5)
    assert summary["jump_error"]["profile_error"] < 0.02
    assert {p.name for p in (tmp_path / "w").iterdir()} >= {"wear_profiles.png", "wear_history.png", "history.csv",
                                                              "profiles.csv", "report.md", "summary.json"}
