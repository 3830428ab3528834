"""mechanism.actuators and mechanism.drivers of a graph scene: the joints that carry a motor
(its name and effort limit) or a prescribed motion (its law: :mod:`rrr4.scene.drivers`), at
most one each, never a clearance joint, every name unique among both."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from ...checks import describe, unknown_value
from ...errors import SceneError
from ..drivers import read_driver
from ..field_specs import read_fields
from ..fields import Section
from ..names import read_name
from ..schema import ActuatorSpec, DriverSpec, JointSpec

__all__ = ["read_actuators_and_drivers"]


def read_actuators_and_drivers(sec: Section, joints: list[JointSpec], base: Path = Path()
                               ) -> tuple[list[ActuatorSpec], list[DriverSpec]]:
    """(actuators, drivers) of the mechanism section `sec`; `base`: the scene file's folder."""
    jnames = [x.name for x in joints]
    actuators = []
    for e, joint in _entries(sec, "actuators", jnames):
        actuators.append(ActuatorSpec(read_name(e, default=joint), joint, **read_fields(e, ActuatorSpec, ("limit",))))
        e.done()
    drivers = []
    for e, joint in _entries(sec, "drivers", jnames):  # their motion laws: ..drivers
        revolute = joints[jnames.index(joint)].type == "revolute"
        drivers.append(read_driver(e, read_name(e, default=joint), joint, revolute, base))
    _check_names(sec, actuators, drivers)
    _check_joints(sec, joints, actuators, drivers)
    return actuators, drivers


def _entries(sec: Section, k: str, jnames: list[str]) -> Iterator[tuple[Section, str]]:
    """(the entry, its joint) of each item of the list at key `k` (actuators or drivers)."""
    raw = sec.raw(k, []) or []
    if not isinstance(raw, list):
        raise SceneError(f"{sec.key(k)}: {describe(raw)} is not allowed (a list of {k})")
    for i, r in enumerate(raw):
        e = Section(r, f"{sec.key(k)}[{i}]")
        joint = e.raw("joint")
        if joint not in jnames:
            raise unknown_value(e.key("joint"), "joint", joint, jnames)
        yield e, joint


def _check_names(sec: Section, actuators: list[ActuatorSpec], drivers: list[DriverSpec]) -> None:
    seen: dict[str, str] = {}
    for key, items in (("actuators", actuators), ("drivers", drivers)):
        for i, x in enumerate(items):
            if x.name in seen:
                raise SceneError(f"{sec.key(key)}[{i}].name: {x.name!r} is not allowed (already the name of "
                                 f"{seen[x.name]}; actuator and driver names must be unique)")
            seen[x.name] = f"{sec.key(key)}[{i}]"


def _check_joints(sec: Section, joints: list[JointSpec], actuators: list[ActuatorSpec],
                  drivers: list[DriverSpec]) -> None:
    """At most one actuator or driver on a joint, and none on a clearance joint."""
    busy = [a.joint for a in actuators] + [d.joint for d in drivers]
    for j in joints:
        if busy.count(j.name) > 1:
            raise SceneError(f"{sec.key('actuators')}: joint {j.name!r} is not allowed to carry more than one "
                             "actuator or driver")
        if j.clearance and j.name in busy:
            raise SceneError(f"{sec.key('joints')}: joint {j.name!r} has clearance and an actuator or driver "
                             "(clearance is allowed on passive joints only)")
