"""The one layout of the equations' input ``parameters`` (rrr4.dynamics.layout): its slices
cover the vector exactly once, every number Problem.contact_parameters writes sits under
the name of the scene value it is, and the equations are built with the same layout."""

from __future__ import annotations

import numpy as np
import pytest

import rrr4
from rrr4.dynamics.builder import profiles_of, with_profiles
from rrr4.dynamics.layout import CONTACT_GROUPS, GROUPS, parameter_layout
from rrr4.problem import Problem
from rrr4.scene import parse_scene

from .conftest import ROOT
from .test_force_elements import SPRING, oscillator

SCENES = sorted([*ROOT.glob("problems/*.yaml"), *ROOT.glob("problems/hard/*.yaml")])
LOAD = {"type": "load", "body": "mass", "force": [1.0, 0.5], "torque": 0.1}


def _problem(path) -> Problem:
    return Problem.from_scene(rrr4.load_scene(path))


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_the_slices_cover_the_vector_exactly_once(path):
    problem = _problem(path)
    layout = parameter_layout(problem.model, problem.scene.effects, problem.scene.forces, geometry=5)
    assert len(set(layout.names)) == layout.size
    covered = np.zeros(layout.size, int)
    for group in GROUPS:
        covered[layout.slice(group)] += 1
        names = [n.split(".") for n in layout.names if n.split(".")[0] == group]
        if names and len(names[0]) > 2:  # per joint or element: their own slices tile the group's
            inner = np.zeros(layout.size, int)
            for owner in {n[1] for n in names}:
                inner[layout.slice(f"{group}.{owner}")] += 1
            assert np.array_equal(inner, np.isin(np.arange(layout.size), np.arange(layout.size)[layout.slice(group)]))
    assert np.all(covered == 1)
    assert [n.split(".")[0] for n in layout.names] == sorted((n.split(".")[0] for n in layout.names), key=GROUPS.index)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_contact_parameters_are_the_scene_values_named_by_the_layout(path):
    problem = _problem(path)
    layout, v = problem.parameter_layout, problem.contact_parameters
    effects = problem.scene.effects
    assert v.size == layout.contact_size == sum(1 for n in layout.names if n.split(".")[0] in CONTACT_GROUPS)
    value = {n: v[layout.index(n)] for n in layout.names[:v.size]}
    for j in problem.clearance_joints:
        spec = problem.joint(j)
        assert value[f"joints.{j}.journal_radius"] == spec.journal_radius
        assert value[f"joints.{j}.bearing_radius"] == spec.journal_radius + spec.radial_clearance
        if effects.contact.stiffness is not None:
            assert value[f"joints.{j}.stiffness"] == effects.contact.stiffness
        film, wear = effects.lubrication_of(spec), effects.wear_of(spec)
        if film.law != "none":
            assert (value[f"lubrication.{j}.viscosity"], value[f"lubrication.{j}.length"],
                    value[f"lubrication.{j}.threshold"]) == (film.viscosity, film.length, film.threshold)
        for s in wear.worn:
            assert value[f"wear.{j}.hardness"] == wear.hardness
            assert np.all(v[layout.slice(f"profiles.{j}.{s}")] == 0.0) and layout.slice(f"profiles.{j}.{s}").stop \
                - layout.slice(f"profiles.{j}.{s}").start == wear.nodes
    if problem.clearance_joints:
        assert value["contact.friction_coefficient"] == effects.friction.coefficient
        assert value["contact.restitution"] == effects.contact.restitution
    else:
        assert v.size == 0


@pytest.mark.parametrize("name", ["paper_circle_wear", "flores_slider_crank_lubricated"])
def test_the_equations_are_built_with_the_problems_layout(name):
    problem = _problem(ROOT / "problems" / f"{name}.yaml")
    eqs = problem.equations()
    assert eqs.layout == problem.parameter_layout
    assert eqs.parameters.size == eqs.layout.size
    assert eqs.parametric.acceleration.numel_in("parameters") == eqs.layout.size
    assert eqs.stiffness == tuple(problem.joint_stiffness(j) for j in problem.clearance_joints)


def test_force_elements_follow_the_contact_numbers_by_name():
    problem = Problem.from_scene(parse_scene(oscillator([SPRING, LOAD])))
    layout = problem.parameter_layout
    assert layout.contact_size == problem.contact_parameters.size
    p = problem.equation_parameters()
    assert p[layout.index("forces.load1.fx")] == 1.0 and p[layout.index("forces.load1.torque")] == 0.1
    assert p[layout.index("forces.spring.stiffness")] == SPRING["stiffness"]


def test_a_profile_is_written_and_read_back_at_its_named_slice():
    eqs = _problem(ROOT / "problems" / "paper_circle_wear.yaml").equations()
    joint, surface, m = eqs.worn[-1]
    worn = with_profiles(eqs, {joint: {surface: np.linspace(0.0, 1e-6, m)}})
    at = eqs.layout.slice(f"profiles.{joint}.{surface}")
    assert np.array_equal(worn.parameters[at], np.linspace(0.0, 1e-6, m))
    assert np.array_equal(np.delete(worn.parameters, np.arange(at.start, at.stop)),
                          np.delete(eqs.parameters, np.arange(at.start, at.stop)))
    assert np.array_equal(profiles_of(worn)[joint][surface], np.linspace(0.0, 1e-6, m))


def test_a_writer_that_misses_or_invents_a_name_is_refused():
    layout = _problem(ROOT / "problems" / "flores_slider_crank_lubricated.yaml").parameter_layout
    values = {n: 1.0 for n in layout.names if n.split(".")[0] in CONTACT_GROUPS}
    assert layout.vector(values, CONTACT_GROUPS).size == layout.contact_size
    with pytest.raises(ValueError, match="missing"):
        layout.vector({k: v for k, v in list(values.items())[1:]}, CONTACT_GROUPS)
    with pytest.raises(ValueError, match="not entries"):
        layout.vector(values | {"contact.viscosity": 1.0}, CONTACT_GROUPS)
    with pytest.raises(KeyError, match="joints.X9.stiffness"):
        layout.index("joints.X9.stiffness")


def test_a_new_effect_is_one_more_term(monkeypatch):
    """The extension point of docs/architecture.md: a viscous damper at each clearance joint,
    torque -c (w_j - w_b), added as one term, changes the dynamics residual by exactly its
    generalised force and power_damping by exactly c (w_j - w_b)^2 (evaluated here from qd)."""
    import casadi as ca

    from rrr4.dynamics import builder
    from rrr4.dynamics.assembly import Term

    c = 0.7  # [N m s/rad]

    class JointDamping(Term):
        def at_joint(self, a, joint):
            torque = -c * (joint.w_j - joint.w_b)
            dQ = ca.SX.zeros(a.model.nq)
            if joint.i_j is not None:
                dQ[joint.i_j] += torque
            if joint.i_b is not None:
                dQ[joint.i_b] -= torque
            a.Q = a.Q + dQ
            a.power_damping += -torque * (joint.w_j - joint.w_b)

    problem = _problem(ROOT / "problems" / "flores_slider_crank.yaml")
    model, effects, p = problem.model, problem.scene.effects, problem.equation_parameters()
    plain = builder.parametric_equations(model, effects, "torque")
    monkeypatch.setattr(builder, "TERMS", (*builder.TERMS, JointDamping))
    damped = builder.parametric_equations(model, effects, "torque")
    assert damped.layout == plain.layout
    rng = np.random.default_rng(3)
    q = problem.start_coordinates  # journals centred: no contact force to drown the damper's
    qd, qdd = (rng.normal(size=model.nq) for _ in range(2))
    nc, n = len(model.clearance_joints), model.n_actuators
    refs = [np.zeros(n)] * 4 + [np.full(nc, 0.05), np.zeros(nc), 0.0]
    lam = np.zeros(plain.n_constraints)
    expected_dQ, expected_power = np.zeros(model.nq), 0.0
    for name in model.clearance_joints:
        spec = model.graph.joint(name)
        i_j, i_b = model.rotation_index(spec.journal_body), model.rotation_index(spec.bearing_body)
        w = (qd[i_j] if i_j is not None else 0.0) - (qd[i_b] if i_b is not None else 0.0)
        for i, sign in ((i_j, 1.0), (i_b, -1.0)):
            if i is not None:
                expected_dQ[i] += -sign * c * w
        expected_power += c * w**2
    r0, r1 = (np.array(e.residual(q, qd, qdd, lam, *refs, p)[0]).ravel() for e in (plain, damped))
    assert np.allclose(r1 - r0, -expected_dQ, rtol=1e-12, atol=1e-9)
    a0, a1 = (e.acceleration(q, qd, *refs, p) for e in (plain, damped))
    k = plain.acceleration.name_out().index("power_damping")
    assert float(a1[k] - a0[k]) == pytest.approx(expected_power, rel=1e-9, abs=1e-12)
    assert expected_power > 0
