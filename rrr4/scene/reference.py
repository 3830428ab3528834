"""The scene reference: every key a scene may have, with its type, unit, default, allowed
values and meaning, made from the reader itself.

The keys, their types, defaults and allowed values are *recorded* while the reader reads the
shipped scenes and variants of them (every value of every choice, and a few probes for the
keys that only a present block reads, see :data:`PROBES`), so they cannot drift from what
the reader does. Units and meanings come from ``reference.yaml`` beside this module, one
entry per key; ``tests/test_reference.py`` checks that every recorded key has one and every
entry names a recorded key, and that ``docs/scene-reference.md`` is this module's output::

    python -m rrr4.scene.reference > docs/scene-reference.md
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import yaml

from ..errors import SceneError
from .fields import recording
from .keys import set_key
from .reader import parse_scene, read_yaml

__all__ = ["scene_keys", "descriptions", "reference_markdown", "seed_scenes", "PROBES"]

ROOT = Path(__file__).resolve().parents[2]
# variants of a seed that reach the keys only a present block reads: {seed file: [patches]},
# each patch a mapping of dotted key -> value set on the seed
PROBES = {
    "paper_circle.yaml": [
        {"joints.per_joint.B1": {"radial_clearance": 5e-5, "journal_radius": 0.005, "journal_material": "bronze",
                                 "bearing_material": {"youngs_modulus": 2e11, "poisson_ratio": 0.3},
                                 "lubrication": {"law": "short-bearing", "viscosity": 0.04, "length": 0.02},
                                 "wear": {"surfaces": "both", "coefficient": 1e-4, "hardness": 8e9, "length": 0.01,
                                          "nodes": 36}}},
        {"path.type": "waypoints", "path.points": [[0.25, 0.25, 0.0], [0.26, 0.25, 0.0]]},
        {"path.type": "line", "path.start": [0.25, 0.25, 0.0], "path.end": [0.26, 0.25, 0.0]},
        {"forces": [{"type": "spring_damper", "name": "s", "bodies": ["ground", "platform"],
                     "points": [[-0.3, 0.0], [0.0, 0.0]], "stiffness": 500.0, "damping": 2.0, "free_length": 0.3,
                     "preload": 1.0},
                    {"type": "rotational_spring_damper", "joint": "B1", "stiffness": 0.5, "damping": 0.01,
                     "free_angle": 0.1, "preload": 0.0},
                    {"type": "rotational_spring_damper", "bodies": ["driving_1", "following_1"], "stiffness": 0.5}]},
        {"actuation.control_rate": 1000.0, "integrator.tolerance": 1e-7,
         "joints.journal_material": {"name": "custom", "youngs_modulus": 2e11, "poisson_ratio": 0.3},
         "mechanism.chains[0].driving_link": {"length": 0.25, "mass": 0.4, "inertia": 0.002}},
    ],
    "flores_slider_crank.yaml": [
        {"mechanism.drivers[0]": {"joint": "O", "speed": 10.0}},
        {"mechanism.drivers[0]": {"joint": "O", "time_law": "quintic", "travel_deg": 360.0, "duration": 0.1}},
        {"mechanism.drivers[0]": {"joint": "O", "time_law": "table", "travel_deg": 360.0,
                                  "time_table": [[0.0, 0.0, 0.0], [0.1, 1.0, 20.0]]}},
        {"mechanism.drivers[0]": {"joint": "O", "time_law": "table", "speed_table": [[0.0, 0.0], [0.1, 20.0]]}},
        {"mechanism.drivers[0]": {"joint": "P", "time_law": "linear", "initial": 0.17, "travel": 0.01,
                                  "duration": 0.1}},
        {"mechanism.joints[0].clearance": {"radial_clearance": 5e-4, "journal_radius": 0.01,
                                           "lubrication": {"law": "long-bearing", "viscosity": 0.04,
                                                           "length": 0.02},
                                           "wear": {"surfaces": "bearing", "coefficient": 1e-4, "hardness": 8e9,
                                                    "length": 0.01}}},
    ],
}
_NAMED = (  # free names in key paths -> their placeholder
    (re.compile(r"\.points\.[^.\[\]]+$"), ".points.<name>"),
    (re.compile(r"\.per_joint\.[A-Za-z0-9_]+"), ".per_joint.<joint>"),
)


def seed_scenes() -> list[Path]:
    """The scenes the reference is recorded from: every shipped scene file."""
    return sorted((ROOT / "problems").glob("*.yaml")) + sorted((ROOT / "problems" / "hard").glob("*.yaml"))


def _normal(key: str) -> str:
    key = re.sub(r"\[\d+\]", "[]", key)
    key = re.sub(r"\.p$", "", key)  # a list item or point read through a one-key wrapper
    for pattern, name in _NAMED:
        key = pattern.sub(name, key)
    return key


def _read(data, source: str) -> None:
    """Read `data` as a scene, dropping a key the chosen law refuses and trying again."""
    for _ in range(8):
        try:
            parse_scene(copy.deepcopy(data), source=source)
            return
        except SceneError as e:
            m = re.match(r"^([\w.\[\]]+): not used by law", str(e))
            if not m:
                return
            steps = m.group(1).split(".")
            d = data
            for s in steps[:-1]:
                d = d[s]
            d.pop(steps[-1], None)


def scene_keys() -> dict[str, dict]:
    """Every scene key (list items as ``[]``, free names as ``<name>``) -> {'kind',
    'defaults', 'rule'}, recorded from the reader on the seed scenes, on every value of every
    choice key of each, and on :data:`PROBES`."""
    with recording() as rec:
        for path in seed_scenes():
            data = read_yaml(path)
            variants = [data]
            for patch in PROBES.get(path.name, []):
                v = copy.deepcopy(data)
                for k, val in patch.items():
                    set_key(v, k, copy.deepcopy(val))
                variants.append(v)
            for v in variants:
                _read(v, str(path))
        choices = {k: e["rule"].split(", ") for k, e in rec.items() if e["kind"] == "choice"}
    out: dict[str, dict] = {}
    with recording() as rec2:
        for path in seed_scenes():
            data = read_yaml(path)
            for key, allowed in choices.items():
                for value in allowed:
                    v = copy.deepcopy(data)
                    try:
                        set_key(v, key, value)
                    except SceneError:
                        continue
                    _read(v, str(path))
    for source in (rec, rec2):
        for k, e in source.items():
            n = _normal(k)
            o = out.setdefault(n, {"kind": "value", "defaults": [], "rule": None})
            if e["kind"] != "value":
                o["kind"] = e["kind"]
            o["rule"] = o["rule"] or e["rule"]
            for d in e["defaults"]:
                if d not in o["defaults"]:
                    o["defaults"].append(d)
    return dict(sorted(out.items()))


def descriptions() -> dict[str, dict]:
    """reference.yaml: scene key -> {unit, text; default and type where the reader's own would
    mislead (a default that is a rule, a list as long as the scene's actuators)}."""
    with open(Path(__file__).with_name("reference.yaml"), encoding="utf-8") as f:
        return yaml.safe_load(f)


def _default(entry: dict, doc: dict) -> str:
    if "default" in doc:
        return str(doc["default"])
    ds = [d for d in entry["defaults"] if not isinstance(d, (dict, list)) or d]
    if not ds:
        return "required" if entry["kind"] not in ("value",) else ""
    return " or ".join(f"`{_show(d)}`" for d in ds)


def _show(v) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_show(x) for x in v) + "]"
    return str(v)


def reference_markdown(keys: dict | None = None, docs: dict | None = None) -> str:
    """The scene reference as Markdown: one table per top-level section."""
    keys = scene_keys() if keys is None else keys
    docs = descriptions() if docs is None else docs
    lines = ["# Scene reference", "",
             "Every key a scene file may have. Generated from the scene reader by",
             "`python -m rrr4.scene.reference > docs/scene-reference.md` (the types, defaults and allowed",
             "values are recorded from the reader itself; `tests/test_reference.py` fails when this page",
             "is stale or a key is undocumented). Quantities are SI unless the key says otherwise",
             "(`*_deg` in degrees, `*_rpm` in revolutions per minute). `[]` is any item of a list,",
             "`<name>` any name you choose. A key a scene does not need is refused in one line, naming",
             "the key, the value and what is allowed.", ""]
    sections: dict[str, list[str]] = {}
    for k in keys:
        sections.setdefault(re.split(r"[.\[]", k)[0], []).append(k)
    for top, ks in sections.items():
        lines += [f"## `{top}`", "", "| key | type | unit | default | allowed | meaning |", "|---|---|---|---|---|---|"]
        for k in ks:
            e, d = keys[k], docs.get(k, {})
            kind = "section" if d.get("section") else d.get("type", e["kind"])
            lines.append(f"| `{k}` | {kind} | {d.get('unit', '')} | {_default(e, d) if kind != 'section' else ''} "
                         f"| {e['rule'] or d.get('allowed', '')} | {d.get('text', '')} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(reference_markdown(), end="")
