"""The connectivity of a graph scene: every body has a joint, and a chain of joints reaches
every body from the ground or the task body (whose pose the path sets), so nothing floats."""

from __future__ import annotations

from ...errors import SceneError
from ..fields import Section
from ..schema import Body, JointSpec
from ..vocabulary import GROUND

__all__ = ["check_jointed", "check_floating", "floating_bodies"]


def check_jointed(sec: Section, bodies: list[Body], joints: list[JointSpec]) -> None:
    """SceneError at mechanism.bodies naming the first body that no joint joins."""
    used = {b for j in joints for b in j.bodies}
    for b in bodies:
        if b.name not in used:
            raise SceneError(f"{sec.key('bodies')}: body {b.name!r} is not allowed (it has no joint: "
                             "every body must be connected)")


def check_floating(sec: Section, bodies: list[Body], joints: list[JointSpec], task: str | None) -> None:
    """SceneError at mechanism.joints naming the bodies of a floating sub-mechanism."""
    floating = floating_bodies([b.name for b in bodies], joints, task)
    if floating:
        raise SceneError(f"{sec.key('joints')}: bodies {', '.join(map(repr, floating))} are not allowed to float "
                         "(their joints connect them only to each other, neither to the ground nor to the task "
                         "body, so nothing fixes where they are: join one of them to the ground or to a connected "
                         "body)")


def floating_bodies(bodies: list[str], joints: list[JointSpec], task: str | None) -> list[str]:
    """The bodies that no chain of joints reaches from the ground or the task body (whose pose
    the path sets): a floating sub-mechanism, whose rigid motion nothing fixes."""
    reached, todo = {GROUND, task} - {None}, [GROUND] + ([task] if task else [])
    while todo:
        here = todo.pop()
        for j in joints:
            if here in j.bodies:
                for b in j.bodies:
                    if b not in reached:
                        reached.add(b)
                        todo.append(b)
    return [b for b in bodies if b not in reached]
