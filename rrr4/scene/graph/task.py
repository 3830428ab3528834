"""mechanism.task of a graph scene: the body whose pose follows the path (3 degrees of
freedom), a point of a body that follows it (2), or none (a driven scene)."""

from __future__ import annotations

from ...checks import unknown_value
from ..fields import Section

__all__ = ["read_task"]


def read_task(sec: Section, points: dict[str, dict]) -> tuple[str | None, tuple[float, float] | None]:
    """(task body or None, task point (x, y) [m] in its frame or None) of the mechanism section
    `sec`; `points`: {'ground', then each body: its named points}."""
    bodies = list(points)[1:]
    task = sec.raw("task")
    if isinstance(task, dict):  # a point of a body: {body: name, point: name or [x, y]}
        t = Section(task, sec.key("task"))
        body, pt = t.raw("body"), t.raw("point")
        if body not in bodies:
            raise unknown_value(t.key("body"), "body", body, bodies)
        if isinstance(pt, str):
            if pt not in points[body]:
                raise unknown_value(t.key("point"), f"point of {body}", pt, list(points[body]) or ["(none)"])
            task_point = points[body][pt]
        else:
            task_point = t.vector("point", 2)
        t.done()
        return body, task_point
    if task in (None, "none"):
        return None, None
    if task not in bodies:
        raise unknown_value(sec.key("task"), "body", task, bodies + ["none"])
    return task, None
