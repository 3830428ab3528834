"""What the scene says about a schema field: its kind, scene default and bounds, declared on
the field itself (``dataclasses.field`` metadata, :mod:`rrr4.scene.schema`), and the one
generic reader that validates a section's fields from them (:func:`read_fields`).

A declaration is read by the :class:`~rrr4.scene.fields.Section` method of its kind with
exactly the declared arguments, so its error messages and the recorded scene reference are
the validation kit's. A field's unit and meaning are in ``reference.yaml`` (one entry per
scene key, the scene reference's table). A rule that ties fields together (a default that
depends on another field, a cross-check) stays with the reader of its section."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from .fields import Section
from .vocabulary import choices

__all__ = ["FieldSpec", "number", "integer", "vector", "choice", "text", "read_fields", "declared"]

_KEY = "scene"  # the metadata key of a declaration


@dataclass(frozen=True)
class FieldSpec:
    """kind: the Section method that reads it ('number', 'integer', 'vector', 'choice',
    'string'); default: the scene default (None: required); rule: that method's keyword
    arguments (bounds, vector length); optional: absent or null reads as None."""
    kind: str
    default: Any = None
    rule: tuple[tuple[str, Any], ...] = ()
    optional: bool = False

    def read(self, sec: Section, k: str, default=None):
        """The value at key `k` of `sec` (`default` replaces the declared one when given)."""
        if self.optional and sec.raw(k) is None:
            return None
        rule = dict(self.rule)
        if self.kind == "choice":  # the choices by their vocabulary name, or the names themselves
            allowed = rule["allowed"]
            return sec.choice(k, choices(allowed) if isinstance(allowed, str) else allowed,
                              self.default if default is None else default)
        if self.kind == "vector":
            return sec.vector(k, rule.pop("n"), self.default if default is None else default, **rule)
        return getattr(sec, self.kind)(k, self.default if default is None else default, **rule)


def _declare(spec: FieldSpec, init) -> Any:
    """A dataclass field carrying `spec`; `init` is its dataclass default (MISSING: none)."""
    return field(default=init, metadata={_KEY: spec})


def number(default=None, *, optional=False, init=dataclasses.MISSING, **rule) -> Any:
    """A number field: `rule` is :meth:`Section.number`'s (positive, nonneg, lo, hi, lo_open, hi_open, big)."""
    return _declare(FieldSpec("number", default, tuple(rule.items()), optional), init)


def integer(default=None, *, init=dataclasses.MISSING, **rule) -> Any:
    """An integer field: `rule` is :meth:`Section.integer`'s (positive)."""
    return _declare(FieldSpec("integer", default, tuple(rule.items())), init)


def vector(n: int, default=None, *, init=dataclasses.MISSING, **rule) -> Any:
    """A list of `n` numbers: `rule` is :meth:`Section.vector`'s (scalar_ok)."""
    return _declare(FieldSpec("vector", default, (("n", n), *rule.items())), init)


def choice(allowed, default=None, *, init=dataclasses.MISSING) -> Any:
    """One name of `allowed`: a vocabulary name (:func:`rrr4.scene.vocabulary.choices`) or the names."""
    return _declare(FieldSpec("choice", default, (("allowed", allowed),)), init)


def text(default=None, *, init=dataclasses.MISSING) -> Any:
    """A string field."""
    return _declare(FieldSpec("string", default), init)


def declared(cls) -> dict[str, FieldSpec]:
    """{field name: its declaration} of the schema dataclass `cls`, in field order."""
    return {f.name: f.metadata[_KEY] for f in dataclasses.fields(cls) if _KEY in f.metadata}


def read_fields(sec: Section, cls, names=None, defaults: dict | None = None) -> dict:
    """{field: value} of the declared fields `names` of `cls` (all, in field order, when None),
    read in that order from `sec`, each key the field's name; `defaults` replaces the declared
    default of a field whose default depends on what was read before."""
    specs = declared(cls)
    defaults = defaults or {}
    return {k: specs[k].read(sec, k, defaults.get(k)) for k in (specs if names is None else names)}
