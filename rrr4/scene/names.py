"""The names a scene gives its items (the scene, bodies, joints, actuators, drivers): letters,
digits, '_' and '-'."""

from __future__ import annotations

from ..checks import describe
from ..errors import SceneError
from .fields import Section

__all__ = ["read_name"]


def read_name(sec: Section, k: str = "name", default=None) -> str:
    """The name at key `k` of `sec` (`default` when absent); one-line SceneError otherwise."""
    v = sec.raw(k, default)
    if not isinstance(v, str) or not v.strip() or not all(ch.isalnum() or ch in "_-" for ch in v):
        raise SceneError(f"{sec.key(k)}: {describe(v)} is not allowed (a name of letters, digits, '_' and '-')")
    return v
