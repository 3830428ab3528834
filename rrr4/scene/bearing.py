"""A clearance joint's journal and bearing, the keys the n-RRR ``joints`` section and a graph
joint's ``clearance`` share: the fit (journal radius and radial clearance) and the two
materials (a name of :data:`~rrr4.scene.vocabulary.MATERIALS` or their constants)."""

from __future__ import annotations

import difflib

from ..checks import describe
from ..errors import SceneError
from .field_specs import read_fields
from .fields import Section
from .schema import JointSpec, Material
from .vocabulary import MATERIALS

__all__ = ["read_fit", "read_material", "STEEL"]

STEEL = Material("steel", *MATERIALS["steel"])  # the material of a journal or bearing that names none


def read_fit(s: Section) -> tuple[float, float]:
    """(journal_radius, radial_clearance) [m] of `s`, the clearance smaller than the radius."""
    rj, c = read_fields(s, JointSpec, ("journal_radius", "radial_clearance")).values()
    if c >= rj:
        raise SceneError(f"{s.key('radial_clearance')}: {c:g} m is not allowed "
                         f"(must be smaller than the journal radius {rj:g} m)")
    return rj, c


def read_material(v, key: str) -> Material:
    """The material `v` at `key`: a name of MATERIALS, or {name, youngs_modulus, poisson_ratio}."""
    if isinstance(v, str):
        name = v.lower()
        if name not in MATERIALS:
            near = difflib.get_close_matches(name, list(MATERIALS), n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise SceneError(f"{key}: unknown material {describe(v)} "
                             f"(choose one of: {', '.join(MATERIALS)}, or give youngs_modulus and poisson_ratio){hint}")
        return Material(name, *MATERIALS[name])
    s = Section(v, key)
    m = Material(**read_fields(s, Material))
    s.done()
    return m
