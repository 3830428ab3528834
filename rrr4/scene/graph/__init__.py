"""The ``mechanism`` section of a graph scene (``kind: graph``), read into a
:class:`~rrr4.scene.schema.Graph`: its bodies (:mod:`.bodies`), joints (:mod:`.joints`),
actuators and drivers (:mod:`.actuators`), task (:mod:`.task`), the connectivity checks
(:mod:`.connectivity`) and the assembly mode (:mod:`rrr4.scene.assembly`), read in this
order, so a scene with more than one mistake is refused at the first of them."""

from __future__ import annotations

from pathlib import Path

from ..assembly import read_assembly
from ..fields import Section
from ..schema import Graph
from .actuators import read_actuators_and_drivers
from .bodies import read_bodies
from .connectivity import check_floating, check_jointed
from .joints import read_joints
from .task import read_task

__all__ = ["read_graph"]


def read_graph(sec: Section, base: Path = Path()) -> Graph:
    """The Graph of the mechanism section `sec`; `base`: the folder of the scene file (the
    drivers' table files are read relative to it)."""
    bodies, points = read_bodies(sec)
    joints = read_joints(sec, points)
    check_jointed(sec, bodies, joints)
    actuators, drivers = read_actuators_and_drivers(sec, joints, base)
    task, task_point = read_task(sec, points)
    check_floating(sec, bodies, joints, task)
    assembly = read_assembly(sec, joints, points)
    sec.done()
    return Graph(tuple(bodies), tuple(joints), tuple(actuators), tuple(drivers), task, task_point, assembly)
