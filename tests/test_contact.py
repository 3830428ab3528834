"""Clearance-joint geometry, normal-force and friction laws, and the approach-velocity state."""

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from rrr4 import build, load_scene, simulate
from rrr4.contact import (
    NORMAL_LAWS,
    V_MIN,
    friction_force,
    hysteresis_factor,
    normal_force,
    stiffness_internal_cylinder,
)
from rrr4.mechanism import Mechanism
from rrr4.mechanism.kinematics import joint_points
from rrr4.scene import PASSIVE_JOINTS, FrictionEffect

from .conftest import ROOT

CONSERVATIVE = ROOT / "problems" / "conservative_free.yaml"

# delta = 1e-5 m, K = 1e10 N/m^1.5, n = 1.5: K delta^n = 1e10 * 10^-7.5 = 316.227766 N
D, DD, DD0, K, N, CR = 1e-5, 0.1, 0.5, 1e10, 1.5, 0.8
F_EL = 316.22776601683796


@pytest.mark.parametrize("law, expected", [
    ("hertz", F_EL),
    ("kelvin-voigt", F_EL + 50.0 * 0.1),                          # + D delta_dot, D = 50 N s/m
    ("hunt-crossley", F_EL * (1 + 1.5 * 0.2 * 0.1 / 0.5)),         # chi = 3 (1 - 0.8) / 2 = 0.3
    ("lankarani-nikravesh", F_EL * (1 + 0.27 * 0.1 / 0.5)),        # chi = 3 (1 - 0.64) / 4 = 0.27
    ("flores", F_EL * (1 + 0.4 * 0.1 / 0.5)),                      # chi = 8 (1 - 0.8) / (5 0.8) = 0.4
    ("gonthier", F_EL * (1 + 0.45 * 0.1 / 0.5)),                   # chi = (1 - 0.64) / 0.8 = 0.45
])
def test_normal_law_matches_its_formula_on_hand_values(law, expected):
    got = float(normal_force(law, D, DD, DD0, K, N, CR, 50.0))
    assert got == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("law", sorted(NORMAL_LAWS))
def test_no_law_pulls_and_none_acts_without_penetration(law):
    for delta in (-1e-6, 0.0, 1e-7, 1e-5):
        for ddot in (-100.0, -1.0, -1e-3, 0.0, 1.0):
            f = float(normal_force(law, delta, ddot, V_MIN, K, N, 0.05, 1e4))
            assert f >= 0.0 and math.isfinite(f)
            if delta <= 0:
                assert f == 0.0


def test_restitution_limits_keep_forces_finite():
    assert hysteresis_factor("lankarani-nikravesh", 1.0) == 0.0
    assert hysteresis_factor("flores", 1.0) == 0.0
    for cr in (1e-3, 1e-6, 1e-9):  # Flores chi -> infinity as c_r -> 0, the force stays finite
        f = float(normal_force("flores", D, DD, V_MIN, K, N, cr))
        assert math.isfinite(f) and f > 0


def test_zero_approach_velocity_is_floored_at_v_min():
    """Grazing onset: delta_dot0 = 0 is replaced by v_min, so the force is finite."""
    f = float(normal_force("lankarani-nikravesh", D, DD, 0.0, K, N, CR))
    assert f == pytest.approx(F_EL * (1 + 0.27 * DD / V_MIN), rel=1e-12)


def test_stiffness_of_internal_cylinders_matches_hand_value():
    s = 2 * (1 - 0.3**2) / 207e9
    expected = 4 / (3 * s) * math.sqrt(0.005 * 0.0051 / 0.0001)
    assert stiffness_internal_cylinder(0.005, 0.0051, 207e9, 0.3, 207e9, 0.3) == pytest.approx(expected, rel=1e-12)
    assert expected == pytest.approx(7.66e10, rel=1e-2)


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def _friction(law, mu=0.1, mus=0.15):
    return FrictionEffect(law, mu, mus, 1e-4, 2e-4, 1e-3)


@pytest.mark.parametrize("law, v, expected", [
    ("coulomb", 0.3, -0.1 * 20.0),
    ("coulomb", -0.3, 0.1 * 20.0),
    ("ambrosio", 0.5e-4, 0.0),                       # below v0: no friction
    ("ambrosio", 1.5e-4, -0.5 * 0.1 * 20.0),         # halfway: c_d = 0.25 (3 - 1) = 0.5
    ("ambrosio", -1.0, 0.1 * 20.0),                  # above v1: full Coulomb
    ("smooth", 1e-4, -0.1 * 20.0 * math.tanh(1.0)),
    ("stribeck", 1e-3, -(0.1 + 0.05 * math.exp(-1.0)) * 20.0 * math.tanh(10.0)),
])
def test_friction_law_matches_its_formula_on_hand_values(law, v, expected):
    assert float(friction_force(_friction(law), v, 20.0)) == pytest.approx(expected, rel=1e-12, abs=1e-15)


def _one_clearance_scene(name, friction="ambrosio"):
    s = load_scene(CONSERVATIVE)
    joints = tuple(dataclasses.replace(j, clearance=(j.name == name)) for j in s.joints)
    eff = dataclasses.replace(s.effects, contact=dataclasses.replace(s.effects.contact, law="lankarani-nikravesh"),
                              friction=_friction(friction))
    return dataclasses.replace(s.with_joints(joints), effects=eff)


@pytest.mark.parametrize("name", PASSIVE_JOINTS)
def test_contact_forces_obey_newtons_third_law(name):
    """The contact's generalised forces sum to zero force and to the moment of f applied
    at P_J and -f at P_B; the outboard body receives exactly the reported contact force."""
    scene = _one_clearance_scene(name)
    eqs = build(scene).equations()
    mech = Mechanism.from_scene(scene)
    rng = np.random.default_rng(PASSIVE_JOINTS.index(name))
    q0, qd0, _ = mech.body_motion([0.01, -0.005, 0.1], [0.2, -0.1, 1.0])
    io = 6 * (int(name[1]) - 1) + 3 if name[0] == "B" else 6 * mech.n    # outboard body's x index
    q = q0.copy()
    shift = 1.05e-4 * np.array([math.cos(rng.uniform(0, 6.3)), math.sin(rng.uniform(0, 6.3))])
    q[io:io + 2] += shift / np.linalg.norm(shift) * 1.05e-4              # 5 um into the bearing
    qd = qd0 + rng.normal(0, 0.05, qd0.shape)
    z = np.zeros(mech.n)
    args = dict(effort=z, theta_ref=z, theta_d_ref=z, theta_dd_ref=z, delta_dot0=[0.2], in_contact=[1.0])
    Q = -np.array(eqs.residual(q=q, qd=qd, qdd=np.zeros(mech.nq), **{"lambda": np.zeros(eqs.n_constraints)},
                               **args)["dynamics"]).ravel()
    out = eqs.acceleration(q=q, qd=qd, **args)
    f = np.array(out["contact_force"]).ravel()
    assert float(out["penetration"]) > 0 and np.linalg.norm(f) > 1.0
    assert abs(float(out["friction_force"])) > 0
    Qb = Q.reshape(-1, 3)
    assert np.allclose(Qb[:, :2].sum(axis=0), 0.0, atol=1e-9 * np.linalg.norm(f))
    np.testing.assert_allclose(Q[io:io + 2], f, rtol=1e-12)
    # total moment about the origin = (P_J - P_B) x f, P = centre + R n
    pts = {nm: (np.array(ca.evalf(ca.substitute(i, mech._q, q))).ravel(),
                np.array(ca.evalf(ca.substitute(o, mech._q, q))).ravel())
           for nm, i, o in joint_points(mech.data, ca.SX(mech._q))}
    p_in, p_out = pts[name]
    e = p_out - p_in
    n = e / np.linalg.norm(e)
    spec = scene.joint(name)
    lever = (p_out + spec.journal_radius * n) - (p_in + spec.bearing_radius * n)
    moment = sum(Qb[b, 2] + _cross(q[3 * b:3 * b + 2], Qb[b, :2]) for b in range(len(Qb)))
    assert moment == pytest.approx(_cross(lever, f), abs=1e-9 * np.linalg.norm(f))


def test_approach_velocity_is_captured_at_onset_held_and_reset():
    scene = _one_clearance_scene("C2", friction="none")
    eqs = build(scene).equations()
    mech = Mechanism.from_scene(scene)
    q0, _, _ = mech.body_motion([0.0, 0.0, 0.0])
    io = 6 * mech.n
    q_in = q0.copy()
    pts = [o - i for _, i, o in joint_points(mech.data, ca.SX(mech._q))]
    e_fun = ca.Function("e", [mech._q], [pts[mech.joint_names.index("C2")]])
    q_in[io] += 1.02e-4                  # platform moved so that the C2 journal is 2 um into its bearing
    assert np.linalg.norm(np.array(e_fun(q_in)).ravel()) > 1e-4
    qd = np.zeros(mech.nq)
    for v, expected in ((0.3, 0.3), (0.0, V_MIN), (-0.2, V_MIN)):
        qd[io] = v                         # delta_dot = v along the normal
        dd0, inc, loss = (float(a) for a in eqs.contact_update(q_in, qd, V_MIN, 0.0))
        assert (dd0, inc, loss) == (pytest.approx(expected), 1.0, 0.0)
    qd[io] = 0.05                          # persistent contact keeps the onset value
    assert float(eqs.contact_update(q_in, qd, 0.3, 1.0)[0]) == pytest.approx(0.3)
    dd0, inc, loss = (float(a) for a in eqs.contact_update(q0, qd, 0.3, 1.0))  # back in free flight
    assert (dd0, inc, loss) == (pytest.approx(V_MIN), 0.0, 1.0)


@pytest.mark.parametrize("law, restitution, clearance", [
    ("flores", 1e-4, 1e-4),          # c_r -> 0 with the Flores law
    ("lankarani-nikravesh", 1.0, 1e-4),
    ("hunt-crossley", 0.9, 1e-6),     # 1 um clearance
])
def test_hard_inputs_stay_finite(law, restitution, clearance):
    s = load_scene(CONSERVATIVE)
    s = dataclasses.replace(
        s.with_joints(tuple(dataclasses.replace(j, radial_clearance=clearance) for j in s.joints)),
        effects=dataclasses.replace(s.effects, contact=dataclasses.replace(s.effects.contact, law=law,
                                                                           restitution=restitution)))
    r = simulate(s, step=2e-6, t_end=0.02)
    assert r.penetration.max() > 0                          # contacts did happen
    for a in (r.q, r.qd, r.contact_force, r.penetration):
        assert np.all(np.isfinite(a))
    assert np.all(r.normal_force >= 0)
    assert r.penetration.max() < 0.1 * clearance + 1e-6


def test_flores_law_with_vanishing_restitution_dissipates_once_the_step_resolves_it():
    """c_r -> 0 makes the Flores damping very stiff: at a 2 us step explicit RK4 stays finite
    (above) but may gain energy; at 0.5 us the run loses energy and its audit closes."""
    s = load_scene(CONSERVATIVE)
    s = dataclasses.replace(s, effects=dataclasses.replace(
        s.effects, contact=dataclasses.replace(s.effects.contact, law="flores", restitution=1e-4)))
    r = simulate(s, step=5e-7, t_end=0.02)
    e = r.energy["total"]
    assert r.energy["dissipated"][-1] > 1e-5 * e[0]
    assert np.all(e <= e[0] * (1 + 1e-9))
    assert r.energy_audit_residual < 1e-5
