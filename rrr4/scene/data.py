"""The validated YAML data a :class:`~rrr4.scene.Scene` keeps, and the one way to change a
scene in memory by dotted key (:meth:`rrr4.scene.Scene.with_values`).

A scene read from a file or parsed from a mapping keeps that mapping (:attr:`Scene.data`):
a private copy, with the table files it names (``path.time_table``, a driver's
``time_table`` or ``speed_table``, ``forces[i].table``) replaced by the rows read from them,
so the data stands alone (no file is read again, in any directory or on another machine).
Studies that vary a scene (robustness, identification, sweeps) set dotted keys in a copy of
it and validate the result as its file would be; a scene built in Python
(:func:`rrr4.scene.parse_scene` of a mapping) works the same.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from ..checks import describe
from ..errors import SceneError
from .keys import key_steps, set_key
from .tables import inline_tables

__all__ = ["with_data", "values_changed", "changed_data", "data_describes", "set_values"]


def with_data(scene, data, read):
    """`scene` holding a private copy of the mapping `data` it was parsed from, the table
    files named there (relative to the scene file) replaced by their rows
    (:func:`rrr4.scene.tables.inline_tables`), and the function `read` (data, name -> Scene)
    that parsed it, which :meth:`Scene.with_values` calls again (so this module and the
    schema need not import the reader)."""
    out = copy.deepcopy(data)
    inline_tables(out, Path(scene.source).parent if scene.source else Path())
    return replace(scene, data=out, read=read)


def changed_data(scene, values: Mapping) -> dict:
    """A copy of ``scene.data`` with `values` (dotted key -> value) set; SceneError if the
    scene holds no data or the data no longer describes it (a change made with
    ``dataclasses.replace`` after it was read, which would be lost)."""
    if not isinstance(values, Mapping):
        raise SceneError(f"values: {describe(values)} is not allowed (a mapping of dotted scene keys to values, "
                         "e.g. {'joints.radial_clearance': 1.2e-4})")
    for k in values:
        key_steps(k)  # one line naming a malformed key
    if scene.data is None or scene.read is None:
        raise SceneError(f"scene {scene.name!r}: has no YAML data to change (it was built from dataclasses or "
                         "changed with with_joints; read it with rrr4.load_scene or rrr4.scene.parse_scene)")
    if not scene.data_current:
        raise SceneError(f"scene {scene.name!r}: its YAML data no longer describes it (it was changed in memory, "
                         "e.g. with dataclasses.replace, after it was read); change scenes with Scene.with_values")
    return set_values(scene.data, values)


def set_values(data: dict, values: Mapping) -> dict:
    """A deep copy of `data` with `values` (dotted key -> value) set."""
    out = copy.deepcopy(data)
    for k, v in values.items():
        set_key(out, k, copy.deepcopy(v))
    return out


def values_changed(scene, values: Mapping, name: str | None = None):
    """:meth:`rrr4.scene.Scene.with_values` (see there)."""
    data = changed_data(scene, values)
    return scene.read(data, name=scene.name if name is None else name)


def data_describes(scene) -> bool:
    """True if ``scene.data`` read again gives `scene` (name included)."""
    try:
        again = scene.read(scene.data, name=scene.name)
    except SceneError:
        return False
    return again == scene
