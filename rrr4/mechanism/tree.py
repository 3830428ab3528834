"""Tree coordinates: minimal coordinates p for the ideal joints that form a spanning tree.

Reference-point coordinates (:mod:`rrr4.mechanism.model`) give every body [x, y, theta] and
hold every ideal joint by two constraint rows. Where the ideal joints connect a body to one
already placed (the ground first), the body's pose follows from the placed one and one joint
coordinate, so the joint's rows disappear (the velocity transformation, Nikravesh 1988,
ch. 11; Jalon & Bayo 1994, ch. 3):

- a revolute joint: the body's absolute angle theta is the coordinate, and its reference
  point r = p_placed - A(theta) s (p_placed: the joint point on the placed body);
- a prismatic joint: the slide d along the axis is the coordinate, the body's angle is the
  placed body's plus (or minus) the joint's fixed angle, and p_2 = p_1 + d A(theta_1) u.

A body that no ideal joint reaches from a placed one keeps [x, y, theta] (a free body, e.g.
an n-RRR's following links and platform, held only by clearance joints) and places the
bodies joined to it in turn. The ideal joints left over close loops and stay constraints, as
do drivers. On the 4-RRR the 4 actuated base joints are the tree: 19 coordinates for 27, no
constraint; on Flores's slider-crank the crank, coupler and slider pins and slide: 3 for 9.

:func:`tree_map` returns q(p) as an expression; the equations in p come from the builder
(:mod:`rrr4.dynamics.builder`).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ..scene.vocabulary import GROUND
from .model import Model, rotation

__all__ = ["TreeMap", "tree_map"]

# integrator.coordinates: 'auto' takes the tree wherever it removes a joint


@dataclass(frozen=True)
class TreeMap:
    """p (n,) symbols; q (nq,) = q(p); coordinate (n,) = p as an expression of the symbols
    `q_symbols` (to convert a state); tree_joints eliminated, closures kept (graph order)."""
    p: ca.SX
    q: ca.SX
    q_symbols: ca.SX
    coordinate: ca.SX
    tree_joints: tuple[str, ...]
    closures: tuple[str, ...]


def tree_map(model: Model, geometry=None) -> TreeMap:
    """The tree coordinates of `model` (joint points from the symbols `geometry` if given, see
    :func:`rrr4.mechanism.model.geometry_parameters`). Bodies are placed breadth first from
    the ground through the ideal joints in graph order, then from each free body in body order."""
    ideal = [model.graph.joint(j) for j in model.constrained_joints]
    qs = ca.SX.sym("q", model.nq)
    pose = {GROUND: (ca.DM.zeros(2), 0.0)}
    q = [None] * len(model.body_names)
    syms, coords, tree = [], [], []
    pending = list(model.body_names)

    def place(body, r, th, sym, coordinate):
        pose[body] = (r, th)
        q[model.body_names.index(body)] = ca.vertcat(r, th)
        syms.append(sym)
        coords.append(coordinate)
        pending.remove(body)

    while pending:
        grew = True
        while grew:
            grew = False
            for j in ideal:
                if j.name in tree or (j.bodies[0] in pose) == (j.bodies[1] in pose):
                    continue
                k = 1 if j.bodies[0] in pose else 0  # the child's end of the joint
                child, parent = j.bodies[k], j.bodies[1 - k]
                s = model.local_points(j, geometry)
                r_par, th_par = pose[parent]
                p_par = r_par + rotation(th_par) @ s[1 - k] if parent != GROUND else s[1 - k]
                if j.type == "revolute":
                    th = ca.SX.sym(f"theta_{child}")
                    place(child, p_par - rotation(th) @ s[k], th, th, qs[model.coordinates(child).start + 2])
                else:  # prismatic: p_2 = p_1 + d A(theta_1) u, theta_2 = theta_1 + angle
                    d = ca.SX.sym(f"slide_{j.name}")
                    th = th_par + j.angle if k == 1 else th_par - j.angle
                    u = rotation(th_par if k == 1 else th) @ ca.DM(j.axis)
                    p_child = p_par + d * u if k == 1 else p_par - d * u
                    place(child, p_child - rotation(th) @ s[k], th, d, model.joint_coordinate(qs, j.name, geometry))
                tree.append(j.name)
                grew = True
        if pending:  # a free body: its own [x, y, theta]
            v = ca.SX.sym(f"pose_{pending[0]}", 3)
            place(pending[0], v[:2], v[2], v, qs[model.coordinates(pending[0])])
    tree_joints = tuple(j for j in model.constrained_joints if j in tree)
    closures = tuple(j for j in model.constrained_joints if j not in tree)
    return TreeMap(ca.vertcat(*syms), ca.vertcat(*q), qs, ca.vertcat(*coords), tree_joints, closures)
