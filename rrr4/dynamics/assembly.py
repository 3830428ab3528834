"""What the equation builder's terms add to: the symbols, the sums and the outputs.

A term (:class:`Term`) is one effect of a scene, the way MuJoCo and Exudyn treat scene
items: it reads its numbers from its slice of the input ``parameters``
(:class:`rrr4.dynamics.layout.ParameterLayout`) and adds its generalised force to ``Q``, its
energy to ``potential``, its powers to ``power_damping``, ``power_friction`` or
``power_load`` (work done on the mechanism from outside) and its outputs to ``outputs``
(after the ``acceleration`` Function's common ones; ``tree_outputs``: those that the
tree-coordinate equations give too). At a clearance joint a term may reshape the gap first
(:meth:`Term.shape`: wear deepens it), then add its forces (:meth:`Term.at_joint`); its
:meth:`Term.finish` runs once all joints have been visited. The builder runs its term list
(``rrr4.dynamics.builder.TERMS``, one instance of each per build, so a term may keep what
it gathers over the joints) through these phases in order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from ..contact import ClearanceKinematics
from ..mechanism.model import Model
from ..scene import Effects
from .layout import ParameterLayout

__all__ = ["Assembly", "ClearanceJoint", "Term"]


@dataclass
class ClearanceJoint:
    """One clearance joint while the terms visit it: its geometry, its kinematics ``kin`` (a
    shaping term may change the gap) and what the terms have added: the normal and friction
    force [N], the force on the journal ``f`` (2,) [N], the film's share ``film`` (2,) [N],
    and at a worn joint the quadrature of its contact arc ``arc``
    (:class:`rrr4.dynamics.wear_term.Arc`)."""
    index: int
    name: str
    spec: object
    g_j: ca.SX
    g_b: ca.SX
    i_b: int | None
    i_j: int | None
    r_j: ca.SX
    r_b: ca.SX
    stiffness: ca.SX
    e_dot: ca.SX
    w_b: object
    w_j: object
    kin: ClearanceKinematics
    fn: ca.SX = None
    ft: ca.SX = None
    f: ca.SX = None
    film: ca.SX = None
    arc: object = None


@dataclass
class Assembly:
    """The symbols of one build and the sums its terms add to (see the module docstring)."""
    model: Model
    effects: Effects
    forces: tuple
    layout: ParameterLayout
    P: ca.SX           # the input ``parameters``
    G: ca.SX | None    # its geometry numbers, None when geometry is constant
    v_min: float
    q: ca.SX
    qd: ca.SX
    t: ca.SX
    dd0: ca.SX         # delta_dot0 (nc,)
    inc: ca.SX         # in_contact (nc,)
    Q: ca.SX
    potential: ca.SX = field(default_factory=lambda: ca.SX(0))
    power_damping: ca.SX = field(default_factory=lambda: ca.SX(0))
    power_friction: ca.SX = field(default_factory=lambda: ca.SX(0))
    power_load: ca.SX | None = None
    labels: list = field(default_factory=list)
    joints: list = field(default_factory=list)      # the ClearanceJoints, graph order
    columns: dict = field(default_factory=dict)     # contact outputs by name (the common ones)
    outputs: list = field(default_factory=list)     # (name, expression) after the common outputs
    tree_outputs: list = field(default_factory=list)  # their names that tree_acceleration gives too

    def numbers(self, prefix: str) -> ca.SX:
        """The symbols of the layout's entries under `prefix` (e.g. 'wear.B1')."""
        return self.P[self.layout.slice(prefix)]

    def number(self, name: str) -> ca.SX:
        """The symbol of the layout's entry `name` (e.g. 'joints.B1.stiffness')."""
        return self.P[self.layout.index(name)]


class Term:
    """One effect. Each phase does nothing unless the effect overrides it."""

    def start(self, a: Assembly) -> None:
        """Before the joints: the effect's labels (``Equations.terms``)."""

    def shape(self, a: Assembly, joint: ClearanceJoint) -> None:
        """At each clearance joint, before any force: change the gap (``joint.kin``)."""

    def at_joint(self, a: Assembly, joint: ClearanceJoint) -> None:
        """At each clearance joint: add the forces."""

    def finish(self, a: Assembly) -> None:
        """After the joints: the effect's global forces and its outputs."""
