"""The validation kit of the scene reader: a :class:`Section` reads one YAML mapping, checks
each value it is asked for (type, range, magnitude, choices) and rejects unknown keys, every
error one line with the key path, the value and what is allowed."""

from __future__ import annotations

import csv
import difflib
import io
import math
from contextlib import contextmanager
from pathlib import Path

from ..checks import describe, unknown_value
from ..errors import SceneError
from ..files import read_text

__all__ = ["Section", "MAX_MAGNITUDE", "BIG", "MAX_SAMPLES", "recording", "read_csv_rows"]


# largest magnitude a scene number may have (SI units); larger is a unit mistake or an
# overflow waiting to happen. Material and contact stiffnesses may go up to BIG.
MAX_MAGNITUDE, BIG = 1e6, 1e15
# most path samples / output frames a scene may ask for (each frame holds the full state)
MAX_SAMPLES = 5_000_000
MAX_CSV_BYTES = 256 * 2**20  # largest table file a scene names [bytes]



# the keys read while `recording()` runs: full key path -> what the reader asked of it
_RECORD: dict | None = None


@contextmanager
def recording():
    """Record every key any :class:`Section` reads (or allows) while the block runs, into the
    dict it yields: full key path -> {'kind', 'defaults' (the defaults asked with), 'rule'
    (the range or the choices allowed)}. The scene reference (:mod:`rrr4.scene.reference`) is
    made from it, so its defaults and allowed values are the reader's own."""
    global _RECORD
    outer, _RECORD = _RECORD, {}
    try:
        yield _RECORD
    finally:
        _RECORD = outer


def _note(key: str, kind: str | None = None, default=None, rule: str | None = None) -> None:
    if _RECORD is None:
        return
    e = _RECORD.setdefault(key, {"kind": "value", "defaults": [], "rule": None})
    if kind is not None:
        e["kind"] = kind
    if default is not None and default not in e["defaults"]:
        e["defaults"].append(default)
    if rule is not None:
        e["rule"] = rule


class Section:
    """Reads one mapping of the YAML; remembers which keys were used; rejects unknown ones."""

    def __init__(self, data, path: str):
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise SceneError(f"{path or '<scene>'}: expected a mapping, got {describe(data)}")
        self.data, self.path, self.used = data, path, set()

    def key(self, k: str) -> str:
        return f"{self.path}.{k}" if self.path else k

    def has(self, k: str) -> bool:
        return k in self.data

    def raw(self, k, default=None):
        self.used.add(k)
        _note(self.key(k), default=default)
        return self.data.get(k, default)

    def section(self, k: str) -> Section:
        return Section(self.raw(k), self.key(k))

    def missing(self, k: str, what: str) -> SceneError:
        """The error for a required key that is absent, with the section's nearest key when
        that looks like a misspelling of it."""
        near = difflib.get_close_matches(k, [str(x) for x in self.data if x != k], n=1, cutoff=0.6)
        hint = f"; this section has '{near[0]}': a misspelling of '{k}'?" if near else ""
        return SceneError(f"{self.key(k)}: missing ({what} is required){hint}")

    def number(self, k, default=None, *, positive=False, nonneg=False, lo=None, hi=None,
               lo_open=False, hi_open=False, big=False):
        v = self.raw(k, default)
        key = self.key(k)
        if (positive or nonneg) and lo is None and hi is not None:  # the range says the sign rule too
            lo, lo_open = 0.0, positive
        _note(key, "number", rule=_rule(positive, nonneg, lo, hi, lo_open, hi_open))
        if v is None:
            raise self.missing(k, "a number")
        if isinstance(v, str) and _looks_numeric(v):
            raise SceneError(f"{key}: {describe(v)} is text, not a number (YAML reads a number in exponent "
                             f"form only with a dot and a signed exponent: write {_with_dot(v)})")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{key}: {describe(v)} is not a number")
        v = float(v)
        if not math.isfinite(v):
            raise SceneError(f"{key}: {v} is not finite (a finite number is required)")
        cap = BIG if big else MAX_MAGNITUDE
        if abs(v) > cap:
            raise SceneError(f"{key}: {v:g} is not allowed (|value| <= {cap:g} in SI units)")
        if positive and v <= 0:
            raise SceneError(f"{key}: {v:g} is not allowed (must be > 0)")
        if nonneg and v < 0:
            raise SceneError(f"{key}: {v:g} is not allowed (must be >= 0)")
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise SceneError(f"{key}: {v:g} is out of range (allowed: {_interval(lo, hi, lo_open, hi_open)})")
        if hi is not None and (v > hi or (hi_open and v == hi)):
            raise SceneError(f"{key}: {v:g} is out of range (allowed: {_interval(lo, hi, lo_open, hi_open)})")
        return v

    def integer(self, k, default=None, *, positive=False):
        v = self.raw(k, default)
        _note(self.key(k), "integer", rule="> 0" if positive else None)
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{self.key(k)}: {describe(v)} is not an integer")
        if positive and v <= 0:
            raise SceneError(f"{self.key(k)}: {v} is not allowed (must be > 0)")
        return v

    def vector(self, k, n, default=None, *, scalar_ok=False):
        v = self.raw(k, default)
        key = self.key(k)
        _note(key, f"list of {n} numbers" + (" or one number" if scalar_ok else ""))
        if v is None:
            raise self.missing(k, f"a list of {n} numbers")
        if scalar_ok and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v] * n
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise SceneError(f"{key}: {describe(v)} is not allowed (a list of {n} numbers is required)")
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise SceneError(f"{key}[{i}]: {describe(x)} is not a finite number")
            if abs(x) > MAX_MAGNITUDE:
                raise SceneError(f"{key}[{i}]: {x:g} is not allowed (|value| <= {MAX_MAGNITUDE:g} in SI units)")
            out.append(float(x))
        return tuple(out)

    def string(self, k, default=None):
        v = self.raw(k, default)
        _note(self.key(k), "text")
        if not isinstance(v, str):
            raise SceneError(f"{self.key(k)}: {describe(v)} is not a string")
        return v

    def choice(self, k, allowed, default=None):
        v = self.raw(k, default)
        _note(self.key(k), "choice", rule=", ".join(map(str, allowed)))
        v = v.lower() if isinstance(v, str) else v
        if v is None:
            raise SceneError(f"{self.key(k)}: missing (choose one of: {', '.join(allowed)})")
        if v not in allowed:
            raise unknown_value(self.key(k), "value", v, allowed)
        return v

    def done(self, allowed=None):
        allowed = sorted(set(allowed or ()) | self.used)
        for k in allowed:
            _note(self.key(str(k)))
        for k in self.data:
            if k not in allowed:
                near = difflib.get_close_matches(str(k), allowed, n=1)
                hint = f"did you mean '{near[0]}'? " if near else ""
                raise SceneError(f"{self.key(str(k))}: unknown key ({hint}"
                                 f"allowed keys: {', '.join(allowed)})")


def _rule(positive, nonneg, lo, hi, lo_open, hi_open) -> str | None:
    if lo is not None or hi is not None:
        return _interval(lo, hi, lo_open, hi_open)
    return "> 0" if positive else ">= 0" if nonneg else None


def _interval(lo, hi, lo_open, hi_open):
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    return f"{left}{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}{right}"



def _looks_numeric(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return v.strip().lower() not in ("nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity")


def _with_dot(v: str) -> str:
    """The YAML 1.1 float spelling of a number in exponent form: 7.7e12 -> 7.7e+12, 1e-4 -> 1.0e-4."""
    m, _, e = v.strip().lower().partition("e")
    e = e if e[:1] in "+-" else "+" + e
    return f"{m if '.' in m else m + '.0'}e{e}" if e.strip("+-") else v


def read_csv_rows(path, key: str, columns: tuple[str, ...], max_rows: int) -> list[tuple[str, ...]]:
    """The cells of `columns` (text) of every row of the CSV file a scene key names (header
    row first; other columns are ignored), at most max_rows + 1 rows (the caller refuses
    more); SceneError naming the key and the file when it is missing, not a regular UTF-8 text
    file (:func:`rrr4.files.read_text`; a byte-order mark is dropped), unreadable as CSV or
    lacks a column."""
    p, wanted = Path(path), ",".join(columns)
    if not p.exists():
        raise SceneError(f"{key}: {p.name!r} is not allowed (no such file beside the scene; a CSV with columns "
                         f"{wanted})")
    text = read_text(p, f"{key}: file", f"a CSV file beside the scene with columns {wanted}", MAX_CSV_BYTES)
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        missing = [c for c in columns if c not in (reader.fieldnames or ())]
        if missing:
            raise SceneError(f"{key}: {p.name!r} lacks the column(s) {', '.join(missing)} (a CSV with columns "
                             f"{wanted})")
        rows = []
        for row in reader:
            rows.append(tuple(row[c] for c in columns))
            if len(rows) > max_rows:
                break
    except csv.Error as e:
        raise SceneError(f"{key}: {p.name!r} is not a readable CSV ({e})") from None
    return rows
