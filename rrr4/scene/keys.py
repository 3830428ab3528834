"""Dotted key paths into a scene's YAML data (``mechanism.chains[0].base[1]``): the one way
sweeps, robustness cases and tests read and set a scene value by name."""

from __future__ import annotations

import re

from ..checks import describe
from ..errors import SceneError

__all__ = ["key_steps", "get_key", "set_key"]

_STEP = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


def key_steps(key) -> list:
    """'a.b[0].c' -> ['a', 'b', 0, 'c']; SceneError for a malformed path."""
    if not isinstance(key, str):
        raise SceneError(f"key {describe(key)} is not allowed (a dotted scene key path, list items as [i], e.g. "
                         "mechanism.chains[0].base[1])")
    out: list = []
    for part in key.split("."):
        m = _STEP.match(part)
        if not m:
            raise SceneError(f"key {key!r} is not allowed (a dotted scene key path, list items as [i], e.g. "
                             "mechanism.chains[0].base[1])")
        out.append(m.group(1))
        out += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return out


def get_key(data, key: str):
    """The value at `key` in the mapping `data`, or None where the path does not exist."""
    d = data
    for s in key_steps(key):
        try:
            d = d[s]
        except (KeyError, IndexError, TypeError):
            return None
    return d


def set_key(data, key: str, value) -> None:
    """Set `value` at `key` in the mapping `data` (in place): missing mappings and lists are
    created; SceneError where the path runs through a value that is neither."""
    steps = key_steps(key)
    d = data
    for i, s in enumerate(steps[:-1]):
        nxt = steps[i + 1]
        try:
            d = d[s]
        except KeyError:
            d[s] = [] if isinstance(nxt, int) else {}
            d = d[s]
        except (IndexError, TypeError):
            raise SceneError(f"{key}: the base scene has no {'item' if isinstance(s, int) else 'section'} "
                             f"{s!r} there") from None
    try:
        d[steps[-1]] = value
    except (IndexError, TypeError):
        raise SceneError(f"{key}: the base scene has no item {steps[-1]!r} there") from None
