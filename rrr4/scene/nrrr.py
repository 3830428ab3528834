"""The compact n-RRR form of a scene expanded into the body/joint graph every mechanism is."""

from __future__ import annotations

import math
from dataclasses import replace

from .schema import ActuatorSpec, Body, Graph, JointSpec, Material, NRRRSpec
from .vocabulary import GROUND, MATERIALS

__all__ = ["expand_nrrr", "bare_nrrr_graph"]


def expand_nrrr(m: NRRRSpec, joints: tuple[JointSpec, ...], torque_limit) -> Graph:
    """The body/joint graph of an n-RRR: bodies driving_i, following_i (i = 1..n) and
    platform, in this order (q = [q_11, q_12, ..., q_n1, q_n2, q_o], Zhang & Zhang 2017);
    joints A1..An (ground - driving, actuated), B1..Bn, C1..Cn with the clearance settings
    of `joints` (B1..Bn, C1..Cn); the platform is the task body."""
    bodies, js, acts = [], [], []
    spec = {j.name: j for j in joints}
    for i, c in enumerate(m.chains, start=1):
        h1, h2 = 0.5 * c.driving.length, 0.5 * c.following.length
        bodies += [Body(f"driving_{i}", c.driving.mass, c.driving.inertia, (("A", (-h1, 0.0)), ("B", (h1, 0.0)))),
                   Body(f"following_{i}", c.following.mass, c.following.inertia,
                        (("B", (-h2, 0.0)), ("C", (h2, 0.0))))]
    attach = tuple((f"C{i}", (c.attachment_radius * math.cos(c.attachment_angle),
                              c.attachment_radius * math.sin(c.attachment_angle)))
                   for i, c in enumerate(m.chains, start=1))
    bodies.append(Body("platform", m.platform.mass, m.platform.inertia, attach))
    steel = Material("steel", *MATERIALS["steel"])
    for i, c in enumerate(m.chains, start=1):
        h1 = 0.5 * c.driving.length
        js.append(JointSpec(f"A{i}", False, 0.005, 1e-4, steel, steel, bodies=(GROUND, f"driving_{i}"),
                            points=(tuple(c.base), (-h1, 0.0))))
        acts.append(ActuatorSpec(f"A{i}", f"A{i}", float(torque_limit[i - 1])))
    for i, c in enumerate(m.chains, start=1):
        h1, h2 = 0.5 * c.driving.length, 0.5 * c.following.length
        js.append(replace(spec[f"B{i}"], bodies=(f"driving_{i}", f"following_{i}"), points=((h1, 0.0), (-h2, 0.0))))
    for i, c in enumerate(m.chains, start=1):
        h2 = 0.5 * c.following.length
        js.append(replace(spec[f"C{i}"], bodies=(f"following_{i}", "platform"), points=((h2, 0.0), attach[i - 1][1])))
    return Graph(tuple(bodies), tuple(js), tuple(acts), (), "platform")




def bare_nrrr_graph(m: NRRRSpec) -> Graph:
    """The graph of an n-RRR without clearance (kinematics only)."""
    steel = Material("steel", *MATERIALS["steel"])
    n = m.n_chains
    joints = tuple(JointSpec(f"{p}{i + 1}", False, 0.005, 1e-4, steel, steel) for p in "BC" for i in range(n))
    return expand_nrrr(m, joints, (1.0,) * n)
