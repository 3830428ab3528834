"""Argument checks and bounded messages for every layer: the one-line errors that name the
key, the value and what is allowed (imports nothing of the package but errors)."""

from __future__ import annotations

import difflib
import math
import reprlib

from .errors import SceneError

__all__ = ["describe", "unknown_value", "argument"]

_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 2, 4, 4, 50, 50


def describe(v) -> str:
    """A bounded rendering of a value for messages (never expands a huge or shared
    structure, such as a YAML alias bomb)."""
    s = _REPR.repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


def unknown_value(key: str, what: str, v, allowed) -> SceneError:
    """The one-line error for a value outside `allowed`, with the nearest choice (ignoring
    case first, then by spelling) as a did-you-mean."""
    allowed = [str(a) for a in allowed]
    same = [a for a in allowed if a.lower() == str(v).lower()]
    near = same or difflib.get_close_matches(str(v), allowed, n=1) or \
        difflib.get_close_matches(str(v).lower(), [a.lower() for a in allowed], n=1)
    hint = f"; did you mean '{near[0]}'?" if near else ""
    return SceneError(f"{key}: unknown {what} {describe(v)} (choose one of: {', '.join(allowed)}){hint}")


def argument(key: str, v, *, positive: bool = True, allow_zero: bool = False) -> float:
    """An API argument as a finite float (> 0 by default; >= 0 with allow_zero), or a
    one-line SceneError naming it."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise SceneError(f"{key}: {describe(v)} is not allowed (a number is required)") from None
    if not math.isfinite(x) or (positive and not (x > 0 or (allow_zero and x == 0))):
        rule = ">= 0" if allow_zero else "> 0"
        raise SceneError(f"{key}: {describe(v)} is not allowed (must be a finite number {rule})")
    return x

