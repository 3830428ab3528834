"""Scenes: the YAML schema as frozen dataclasses (:mod:`.schema`), its reader and validation
(:mod:`.reader`, :mod:`.fields`), the vocabulary of allowed names (:mod:`.vocabulary`), the
n-RRR expansion into a graph (:mod:`.nrrr`), dotted key paths (:mod:`.keys`), the YAML data a
scene keeps and :meth:`Scene.with_values`, the one way to change a scene in memory
(:mod:`.data`), tabulated time laws (:mod:`.time_table`), drivers' motion laws
(:mod:`.drivers`), force elements (:mod:`.forces`) and the table files a scene names,
inlined (:mod:`.tables`).

Imports nothing of the package but :mod:`rrr4.errors` and :mod:`rrr4.checks`.
"""

from ..errors import SceneError
from .fields import MAX_SAMPLES
from .forces import LOAD_TABLE_COLUMNS, ForceElement, read_load_table
from .keys import get_key, key_steps, set_key
from .nrrr import bare_nrrr_graph, expand_nrrr
from .reader import MAX_BYTES, MAX_DEPTH, MAX_NODES, load_yaml, parse_scene, read_scene, read_yaml
from .schema import (
    PASSIVE_JOINTS,
    Actuation,
    ActuatorSpec,
    AssemblyMode,
    Body,
    Chain,
    ContactEffect,
    DriverSpec,
    Effects,
    FrictionEffect,
    Graph,
    Initial,
    IntegratorSettings,
    JointSpec,
    Link,
    LubricationEffect,
    Material,
    NRRRSpec,
    PathSpec,
    Platform,
    PreloadSettings,
    Scene,
    WearEffect,
)
from .tables import inline_tables
from .time_table import TIME_TABLE_COLUMNS, check_time_table, read_time_table, time_table_text
from .vocabulary import GROUND, MATERIALS, choices

__all__ = [
    "SceneError", "Scene", "Link", "Chain", "Platform", "NRRRSpec", "Material", "JointSpec", "ContactEffect",
    "FrictionEffect", "LubricationEffect", "WearEffect", "Effects", "PreloadSettings", "Actuation", "PathSpec",
    "Initial", "IntegratorSettings",
    "Body", "AssemblyMode", "ActuatorSpec", "DriverSpec", "Graph", "GROUND", "MATERIALS", "PASSIVE_JOINTS", "choices",
    "read_scene", "parse_scene", "read_yaml", "load_yaml",
    "expand_nrrr", "bare_nrrr_graph", "get_key", "set_key", "key_steps",
    "MAX_SAMPLES", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES",
    "ForceElement", "LOAD_TABLE_COLUMNS", "read_load_table",
    "TIME_TABLE_COLUMNS", "check_time_table", "read_time_table", "time_table_text", "inline_tables",
]
