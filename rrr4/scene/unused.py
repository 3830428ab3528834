"""Settings that would do nothing in the scene they are given in, refused by name: a user who
writes them believes they act (issue 41). A per-joint wear or film on a passive joint without
clearance, a scene-wide wear or film in a scene without any clearance joint, and a seat model
in a driven scene (no controller, so no compensated references whose seats it would move)."""

from __future__ import annotations

from ..errors import SceneError
from .schema import LubricationEffect, Scene, WearEffect

__all__ = ["check_joint_override", "check_unused"]


def check_joint_override(key: str, name: str, film: LubricationEffect | None, wear: WearEffect | None,
                         clearance: list[str]) -> None:
    """SceneError at `key` (joints.per_joint.<name>) when the joint gives its own wear or
    lubrication but has no clearance in this scene (it would be dropped)."""
    if name in clearance:
        return
    what = "wear" if wear is not None and wear.surfaces != "none" else \
        "lubrication" if film is not None and film.law != "none" else None
    if what is not None:
        raise SceneError(f"{key}.{what}: not allowed (joint {name} has no clearance in this scene, so nothing there "
                         f"wears or is oiled; joints.clearance is [{', '.join(clearance) or 'none'}]: add {name} to it "
                         f"or remove {key}.{what})")


def check_unused(scene: Scene, actuation: dict) -> None:
    """SceneError naming the key of a setting `scene` would ignore (see the module docstring);
    `actuation`: the scene file's actuation mapping as written (which keys were given)."""
    clear = [j.name for j in scene.graph.joints if j.clearance]
    if not clear:
        for what, given in (("wear", scene.effects.wear.surfaces != "none"),
                            ("lubrication", scene.effects.lubrication.law != "none")):
            if given:
                raise SceneError(f"effects.{what}: not allowed in a scene without clearance joints (nothing wears or "
                                 "is oiled: every joint is ideal); give joints clearance or remove it")
    if scene.graph.task is None and isinstance(actuation, dict) and "seat_model" in actuation:
        raise SceneError(f"actuation.seat_model: {actuation['seat_model']!r} is not used in a driven scene (the "
                         "drivers set the motion: no controller, no compensated references whose journal seats it "
                         "would model); remove it")
