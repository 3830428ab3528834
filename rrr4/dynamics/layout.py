"""The layout of the equations' input ``parameters``: one object, named slices.

Every number the equations take as an input rather than as a constant has one name and one
place in the vector, decided here once per structure, in this order (each group empty when
the scene has no such effect):

- ``joints``: per clearance joint (graph order) ``joints.<joint>.stiffness`` [N/m^n],
  ``.journal_radius``, ``.bearing_radius`` [m];
- ``contact``: ``contact.restitution``, ``contact.damping`` and the friction law's
  coefficients (:data:`EFFECT_PARAMETERS`; only with a clearance joint);
- ``lubrication``: per lubricated joint ``lubrication.<joint>.viscosity`` [Pa s],
  ``.length`` [m], ``.threshold``;
- ``wear``: per worn joint ``wear.<joint>.coefficient``, ``.hardness`` [Pa], ``.length`` [m];
- ``profiles``: the node depths [m] of every worn surface, ``profiles.<joint>.<surface>.<i>``
  (:func:`worn_surfaces` order): the wear profile is an input, so updating it compiles nothing;
- ``forces``: 4 per force element (:data:`rrr4.scene.forces.FORCE_PARAMETERS`),
  ``forces.<element>.<number>``;
- ``geometry`` (only with ``inputs='geometry'``): masses, inertias and joint points,
  ``geometry.<i>`` (:func:`rrr4.mechanism.geometry_parameters`).

The groups up to ``profiles`` are the contact numbers (``Problem.contact_parameters``). The
builder's terms read their slices from the layout, ``Problem`` writes the vector by name
(:meth:`ParameterLayout.vector`) and identification overwrites entries by name
(:meth:`ParameterLayout.index`): nobody counts offsets.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..mechanism.model import Model
from ..scene import Effects
from ..scene.forces import FORCE_PARAMETERS

__all__ = ["ParameterLayout", "parameter_layout", "lubricated_joints", "worn_joints", "worn_surfaces", "GROUPS",
           "CONTACT_GROUPS", "JOINT_PARAMETERS", "EFFECT_PARAMETERS", "LUBRICATION_PARAMETERS", "WEAR_PARAMETERS"]

# per clearance joint, then the contact and friction laws' numbers
JOINT_PARAMETERS = ("stiffness", "journal_radius", "bearing_radius")
EFFECT_PARAMETERS = ("restitution", "damping", "friction_coefficient", "static_coefficient", "v0", "v1",
                     "stribeck_velocity")
LUBRICATION_PARAMETERS = ("viscosity", "length", "threshold")  # per lubricated joint
WEAR_PARAMETERS = ("coefficient", "hardness", "length")        # per worn joint
GROUPS = ("joints", "contact", "lubrication", "wear", "profiles", "forces", "geometry")
CONTACT_GROUPS = GROUPS[:5]  # Problem.contact_parameters


def lubricated_joints(model: Model, effects: Effects) -> tuple:
    """((name, LubricationEffect), ...) of the clearance joints with an oil film, graph order."""
    films = ((j, effects.lubrication_of(model.graph.joint(j))) for j in model.clearance_joints)
    return tuple((j, f) for j, f in films if f.law != "none")


def worn_joints(model: Model, effects: Effects) -> tuple:
    """((name, WearEffect), ...) of the clearance joints that wear, graph order."""
    wear = ((j, effects.wear_of(model.graph.joint(j))) for j in model.clearance_joints)
    return tuple((j, w) for j, w in wear if w.worn)


def worn_surfaces(model: Model, effects: Effects) -> tuple:
    """((joint, surface, nodes), ...): the wear profiles, in the order of their node depths."""
    return tuple((j, s, w.nodes) for j, w in worn_joints(model, effects) for s in w.worn)


@dataclass(frozen=True)
class ParameterLayout:
    """The names of the entries of ``parameters``, in order (see the module docstring)."""
    names: tuple[str, ...]

    @functools.cached_property
    def _at(self) -> dict:
        return {name: i for i, name in enumerate(self.names)}

    @property
    def size(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """The entry of `name` (e.g. 'joints.B1.stiffness'); KeyError names the entry."""
        try:
            return self._at[name]
        except KeyError:
            raise KeyError(f"parameters: no entry {name!r}") from None

    def slice(self, prefix: str) -> slice:
        """The contiguous entries whose names start with `prefix` + '.' (a group, 'wear.B1',
        'profiles.B1.bearing'); an empty slice at the right place when there are none."""
        hits = [i for i, n in enumerate(self.names) if n.startswith(prefix + ".")]
        if not hits:
            return slice(self._end(prefix), self._end(prefix))
        if hits != list(range(hits[0], hits[-1] + 1)):
            raise ValueError(f"parameters: the entries of {prefix!r} are not contiguous")
        return slice(hits[0], hits[-1] + 1)

    def _end(self, prefix: str) -> int:
        """Where an empty group would sit: after every entry of the groups before it."""
        group = prefix.split(".")[0]
        before = set(GROUPS[:GROUPS.index(group)]) if group in GROUPS else set(GROUPS)
        return sum(1 for n in self.names if n.split(".")[0] in before)

    @property
    def contact_size(self) -> int:
        """The number of contact numbers (``Problem.contact_parameters``), before the forces'."""
        return self.slice("forces").start

    def vector(self, values: dict, groups: tuple = GROUPS) -> np.ndarray:
        """The entries of `groups` (leading groups of :data:`GROUPS`, e.g. :data:`CONTACT_GROUPS`)
        with `values` (name -> number) at their places: every name of those groups exactly once
        (ValueError naming what is missing or not an entry)."""
        if tuple(groups) != GROUPS[:len(groups)]:
            raise ValueError(f"parameters: groups {groups} are not leading groups of {GROUPS}")
        names = [n for n in self.names if n.split(".")[0] in groups]
        missing = [n for n in names if n not in values]
        unknown = [n for n in values if n not in names]
        if missing or unknown:
            raise ValueError(f"parameters: missing {missing[:3]}, not entries {unknown[:3]}")
        return np.array([values[n] for n in names], float)


def parameter_layout(model: Model, effects: Effects, forces: tuple = (), geometry: int = 0) -> ParameterLayout:
    """The :class:`ParameterLayout` of a structure: its clearance joints, the effects at them,
    the force elements `forces` and `geometry` geometry numbers (0: geometry is constant)."""
    clear = model.clearance_joints
    names = [f"joints.{j}.{k}" for j in clear for k in JOINT_PARAMETERS]
    names += [f"contact.{k}" for k in EFFECT_PARAMETERS] if clear else []
    names += [f"lubrication.{j}.{k}" for j, _ in lubricated_joints(model, effects) for k in LUBRICATION_PARAMETERS]
    names += [f"wear.{j}.{k}" for j, _ in worn_joints(model, effects) for k in WEAR_PARAMETERS]
    names += [f"profiles.{j}.{s}.{i}" for j, s, m in worn_surfaces(model, effects) for i in range(m)]
    names += [f"forces.{e.name}.{k}" for e in forces for k in FORCE_PARAMETERS[e.type]]
    names += [f"geometry.{i}" for i in range(geometry)]
    return ParameterLayout(tuple(names))
