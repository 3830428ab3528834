"""The scene fields declared on the schema (rrr4.scene.field_specs) and the parts of the graph
reader (rrr4.scene.graph), against references written here by hand: the documented defaults,
the messages, and which bodies of a small graph float."""

from __future__ import annotations

import dataclasses

import pytest

from rrr4.errors import SceneError
from rrr4.scene import schema
from rrr4.scene.field_specs import declared, read_fields
from rrr4.scene.fields import Section
from rrr4.scene.graph.connectivity import floating_bodies
from rrr4.scene.vocabulary import choices

CLASSES = [getattr(schema, n) for n in schema.__all__ if dataclasses.is_dataclass(getattr(schema, n))]


def test_a_declared_default_is_the_dataclass_default_where_both_exist():
    # a Scene built in Python and one read from a file that leaves the key out must agree
    checked = 0
    for cls in CLASSES:
        specs = declared(cls)
        for f in dataclasses.fields(cls):
            spec = specs.get(f.name)
            if spec is None or spec.default is None or f.default is dataclasses.MISSING:
                continue
            want = tuple(spec.default) if isinstance(spec.default, list) else spec.default
            assert f.default == want, f"{cls.__name__}.{f.name}: dataclass {f.default!r}, scene {spec.default!r}"
            checked += 1
    assert checked >= 12


def test_every_declared_choice_is_a_vocabulary_with_its_default_in_it():
    n = 0
    for cls in CLASSES:
        for name, spec in declared(cls).items():
            if spec.kind == "choice":
                allowed = dict(spec.rule)["allowed"]
                names = choices(allowed) if isinstance(allowed, str) else allowed
                assert spec.default is None or spec.default in names, f"{cls.__name__}.{name}"
                n += 1
    assert n >= 10


def test_an_empty_integrator_section_reads_the_documented_defaults():
    # docs/scene-reference.md, integrator section
    got = read_fields(Section({}, "integrator"), schema.IntegratorSettings)
    assert got == {"method": "bathe", "step": 1e-5, "rtol": 1e-8, "atol": 1e-10, "gamma": 0.5, "rho_inf": 0.0,
                   "newton_tol": 1e-10, "max_newton": 20, "refine": 1, "newton": "simplified", "tolerance": None,
                   "coordinates": "auto"}


@pytest.mark.parametrize("cls, section, data, message", [
    (schema.IntegratorSettings, "integrator", {"gamma": 1.0},
     "integrator.gamma: 1 is out of range (allowed: (0, 1))"),
    (schema.IntegratorSettings, "integrator", {"max_newton": 0},
     "integrator.max_newton: 0 is not allowed (must be > 0)"),
    (schema.IntegratorSettings, "integrator", {"tolerance": -1.0},
     "integrator.tolerance: -1 is not allowed (must be > 0)"),
    (schema.Platform, "mechanism.platform", {"inertia": 0.1},
     "mechanism.platform.mass: missing (a number is required)"),
    (schema.Material, "joints.journal_material", {"youngs_modulus": 2e11, "poisson_ratio": 0.5},
     "joints.journal_material.poisson_ratio: 0.5 is out of range (allowed: [0, 0.5))"),
    (schema.Initial, "initial", {"journals": "loose"},
     "initial.journals: unknown value 'loose' (choose one of: centred, seated)"),
])
def test_a_declared_field_refuses_a_bad_value_in_one_line(cls, section, data, message):
    with pytest.raises(SceneError) as e:
        read_fields(Section(data, section), cls)
    assert str(e.value) == message


def test_a_later_field_can_take_its_default_from_an_earlier_one():
    f = Section({"coefficient": 0.3}, "effects.friction")
    mu = read_fields(f, schema.FrictionEffect, ("coefficient",))["coefficient"]
    got = read_fields(f, schema.FrictionEffect, ("static_coefficient", "v0"), {"static_coefficient": mu})
    assert got == {"static_coefficient": 0.3, "v0": 1e-4}


def _joint(a: str, b: str) -> schema.JointSpec:
    steel = schema.Material("steel", 2.07e11, 0.29)
    return schema.JointSpec(f"{a}{b}", False, 0.005, 1e-4, steel, steel, bodies=(a, b))


def test_floating_bodies_are_those_no_joint_chain_reaches_from_the_ground_or_the_task():
    # ground - A - B, and C - D joined only to each other; E joined to D
    joints = [_joint("ground", "A"), _joint("A", "B"), _joint("C", "D"), _joint("D", "E")]
    bodies = ["A", "B", "C", "D", "E"]
    assert floating_bodies(bodies, joints, None) == ["C", "D", "E"]
    assert floating_bodies(bodies, joints, "B") == ["C", "D", "E"]
    assert floating_bodies(bodies, joints, "E") == []  # the path fixes E, and through it D and C
