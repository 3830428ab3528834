"""The table files a scene names, written into its YAML as rows: path.time_table,
mechanism.drivers[].time_table and .speed_table, and forces[].table (CSV files relative to the scene file).
A sweep's cases and a saved result's copy of the scene carry them so, and parse in any
directory or on another machine without the files."""

from __future__ import annotations

from pathlib import Path

from ..errors import SceneError
from .fields import read_csv_rows
from .forces import read_load_table
from .time_table import MAX_TABLE_ROWS, read_time_table

__all__ = ["inline_tables"]


def inline_tables(data: dict, folder: Path) -> bool:
    """Replace in the scene YAML mapping `data` every table file it names (relative to
    `folder`, the scene file's directory) by its checked rows; True when something changed.
    SceneError naming the key and the file when one cannot be read."""
    changed = False
    path = data.get("path")
    if isinstance(path, dict) and isinstance(path.get("time_table"), str):
        path["time_table"] = [list(r) for r in read_time_table(folder / path["time_table"], "path.time_table")]
        changed = True
    mech = data.get("mechanism")
    drivers = mech.get("drivers") if isinstance(mech, dict) else None
    for i, d in enumerate(drivers if isinstance(drivers, list) else []):
        if isinstance(d, dict) and isinstance(d.get("time_table"), str):
            d["time_table"] = [list(r) for r in read_time_table(folder / d["time_table"],
                                                                 f"mechanism.drivers[{i}].time_table")]
            changed = True
        if isinstance(d, dict) and isinstance(d.get("speed_table"), str):  # checked when the scene is read
            key = f"mechanism.drivers[{i}].speed_table"
            rows = read_csv_rows(folder / d["speed_table"], key, ("t", "speed"), MAX_TABLE_ROWS)
            d["speed_table"] = [[_number(x, key) for x in r] for r in rows]
            changed = True
    forces = data.get("forces")
    for i, e in enumerate(forces if isinstance(forces, list) else []):
        if isinstance(e, dict) and isinstance(e.get("table"), str):
            e["table"] = [list(r) for r in read_load_table(folder / e["table"], f"forces[{i}].table")]
            changed = True
    return changed


def _number(text: str, key: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise SceneError(f"{key}: {text!r} is not allowed (a number)") from None
