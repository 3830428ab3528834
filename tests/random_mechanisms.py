"""Random planar mechanisms for the property tests, with what the tests check them by.

A mechanism is drawn assembled: every body's pose first (random positions and angles, the
body frames not aligned with the links, centres of mass off the joint line), then joints
that close at those poses. So the drawn poses are an assembly, and Newton starts there.

Two families, each with revolute or prismatic (actuated) joints at the ground, clearance at
a random subset of the passive revolute joints, random masses and inertias, gravity, and
force elements (a translational spring-damper with preload, a rotational one on a joint, a
constant load with a torque, known to the controller):

- ``body``: a platform carried by 3 or 4 chains (R or P at the ground, then R R), the
  platform's pose the task (3 DOF; 4 chains: one degree of redundancy);
- ``point``: a five-bar whose two distal links are pinned together, and a third chain
  pinned to the first distal link elsewhere (2 DOF, one degree of redundancy), the task a
  point of the first distal link off its centre of mass.

The references below share no code with rrr4: positions of body points from the
coordinates, energies and virtual work in numpy.
"""

from __future__ import annotations

import math

import numpy as np


def _unit(a):
    return np.array([math.cos(a), math.sin(a)])


def _rot(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


class _Builder:
    def __init__(self, rng):
        self.rng = rng
        self.bodies, self.joints, self.actuators, self.ground = [], [], [], {}
        self.pose = {}  # name -> (r (2,), theta)

    def body(self, name, centre, angle, points):
        """A body with its centre of mass at `centre`, frame angle `angle` and named global points."""
        rng = self.rng
        R = _rot(angle)
        local = {k: (R.T @ (np.asarray(p) - centre)).round(12).tolist() for k, p in points.items()}
        mass = float(rng.uniform(0.1, 1.0))
        self.bodies.append({"name": name, "mass": mass, "inertia": float(mass * rng.uniform(5e-4, 8e-3)),
                            "points": local, "pose": [float(centre[0]), float(centre[1]), float(angle)]})
        self.pose[name] = (np.asarray(centre, float), float(angle))

    def link(self, name, a, b):
        """A link between global points a and b (named a, b), its centre of mass off the line."""
        rng = self.rng
        along, off = rng.uniform(0.3, 0.7), rng.uniform(-0.03, 0.03)
        d = b - a
        centre = a + along * d + off * np.array([-d[1], d[0]]) / np.linalg.norm(d)
        self.body(name, centre, float(rng.uniform(-math.pi, math.pi)), {"a": a, "b": b})

    def base(self, i, at, rod, prismatic):
        """The first body of chain i, its point 'b' at global `at`, with a revolute or prismatic
        actuated joint to the ground, away from the chain's singular poses: the elbow bent by
        30 to 150 deg against the next link's direction `rod`, or the rail at most 66 deg off it."""
        rng = self.rng
        turn = rng.uniform(np.pi / 6, 5 * np.pi / 6) * rng.choice([-1, 1])
        if prismatic:
            axis = _unit(rod + rng.uniform(-1.15, 1.15))
            g = at - rng.uniform(-0.1, 0.1) * axis
            angle = float(rng.uniform(-math.pi, math.pi))
            centre = at + rng.uniform(-0.03, 0.03, 2)
            self.body(f"base_{i}", centre, angle, {"b": at})
            self.ground[f"G{i}"] = g.tolist()
            self.joints.append({"name": f"A{i}", "type": "prismatic", "bodies": ["ground", f"base_{i}"],
                                "points": [f"G{i}", "b"], "axis": axis.tolist(), "angle_deg": math.degrees(angle)})
        else:
            a = at - float(rng.uniform(0.12, 0.25)) * _unit(rod + turn)
            self.link(f"base_{i}", a, at)
            self.ground[f"G{i}"] = a.tolist()
            self.joints.append({"name": f"A{i}", "bodies": ["ground", f"base_{i}"], "points": [f"G{i}", "a"]})
        self.actuators.append({"name": f"A{i}", "joint": f"A{i}", "limit": 1.0e4})

    def chain(self, i, end, prismatic):
        """Chain i: base -B- distal link ending at global point `end` (its point 'b')."""
        rng = self.rng
        rod = rng.uniform(-math.pi, math.pi)  # the distal link's direction, from its B to `end`
        mid = end - float(rng.uniform(0.12, 0.25)) * _unit(rod)
        self.base(i, mid, rod, prismatic)
        self.link(f"distal_{i}", mid, end)
        self.joint(f"B{i}", f"base_{i}", "b", f"distal_{i}", "a")

    def joint(self, name, b1, p1, b2, p2):
        j = {"name": name, "bodies": [b1, b2], "points": [p1, p2]}
        if self.rng.uniform() < 0.5:
            j["clearance"] = {"journal_radius": 0.005, "radial_clearance": 1.0e-4}
        self.joints.append(j)


def random_mechanism(seed: int, family: str, chains: int = 4) -> dict:
    """The scene data (a dict for ``rrr4.scene.parse_scene``) of a random mechanism of the
    family 'body' (chains: 3 or 4) or 'point' (see the module docstring), and the drawn
    poses as each body's assembly guess."""
    rng = np.random.default_rng(seed)
    b = _Builder(rng)
    prismatic = rng.uniform(size=chains) < 0.3
    if family == "body":
        centre, angle = rng.uniform(-0.05, 0.05, 2), float(rng.uniform(-math.pi, math.pi))
        spread = rng.uniform(0.04, 0.08)
        corners = {f"C{i}": centre + spread * _unit(angle + 2 * math.pi * i / chains + rng.uniform(-0.3, 0.3))
                   for i in range(chains)}
        b.body("platform", centre + rng.uniform(-0.01, 0.01, 2), angle, {**corners})
        for i in range(chains):
            b.chain(i, corners[f"C{i}"], prismatic[i])
            b.joint(f"C{i}", f"distal_{i}", "b", "platform", f"C{i}")
        task = "platform"
        r, th = b.pose["platform"]
        start = [float(r[0]), float(r[1]), th]
    else:
        p = rng.uniform(-0.05, 0.05, 2)
        b.chain(0, p, prismatic[0])
        b.chain(1, p, prismatic[1])
        b.joint("P", "distal_0", "b", "distal_1", "b")
        # the third chain is pinned to distal_0 at a point q off its line; the task point t elsewhere on it
        r0, th0 = b.pose["distal_0"]
        R0 = _rot(th0)
        q = r0 + R0 @ rng.uniform(-0.06, 0.06, 2)
        t = r0 + R0 @ rng.uniform(-0.06, 0.06, 2)
        body0 = b.bodies[[x["name"] for x in b.bodies].index("distal_0")]
        body0["points"]["q"] = (R0.T @ (q - r0)).round(12).tolist()
        body0["points"]["t"] = (R0.T @ (t - r0)).round(12).tolist()
        b.chain(2, q, prismatic[2])
        b.joint("Q", "distal_0", "q", "distal_2", "b")
        task = {"body": "distal_0", "point": "t"}
        start = [float(t[0]), float(t[1]), 0.0]
    forces = _forces(rng, b)
    return {"name": f"random_{family}_{seed}", "mechanism": {"kind": "graph", "ground": {"points": b.ground},
                                                            "bodies": b.bodies, "joints": b.joints,
                                                            "actuators": b.actuators, "task": task},
            "forces": forces, "effects": {"gravity": rng.uniform(-10, 10, 2).round(6).tolist()},
            "actuation": {"mode": "torque", "preload": {"method": "none", "min_force": 0.0}},
            "path": {"type": "line", "start": start, "end": [start[0] + 1e-3, start[1], start[2]], "duration": 1.0}}


def _forces(rng, b: _Builder) -> list:
    names = [x["name"] for x in b.bodies]
    one, two = rng.choice(names, 2, replace=False)
    passive = [j["name"] for j in b.joints if j.get("type", "revolute") == "revolute" and j["name"][0] != "A"]
    return [
        {"type": "spring_damper", "name": "spring", "bodies": ["ground", str(one)],
         "points": [rng.uniform(-0.3, 0.3, 2).round(6).tolist(), rng.uniform(-0.05, 0.05, 2).round(6).tolist()],
         "stiffness": float(rng.uniform(10, 500)), "damping": float(rng.uniform(0, 5)),
         "free_length": float(rng.uniform(0.1, 0.3)), "preload": float(rng.uniform(-5, 5))},
        {"type": "rotational_spring_damper", "name": "torsion", "joint": str(rng.choice(passive)),
         "stiffness": float(rng.uniform(0.1, 2)), "damping": float(rng.uniform(0, 0.05)),
         "free_angle": float(rng.uniform(-1, 1)), "preload": float(rng.uniform(-0.2, 0.2))},
        {"type": "load", "name": "load", "body": str(two), "point": rng.uniform(-0.05, 0.05, 2).round(6).tolist(),
         "force": rng.uniform(-20, 20, 2).round(6).tolist(), "torque": float(rng.uniform(-1, 1)),
         "frame": str(rng.choice(["ground", "body"]))},
    ]


# ---------------------------------------------------------------- independent references (numpy)


class Bodies:
    """Positions, coordinates of the actuators and springs, and virtual work of a scene's
    bodies from coordinates q (3 per body, [x, y, theta] of each centre of mass, in the
    graph's body order), by hand from the scene's numbers (``Scene.graph``, ``Scene.forces``;
    a spring's free length from ``Problem.force_parameters`` where the scene leaves it to the
    initial pose)."""

    def __init__(self, scene, force_parameters):
        g = scene.graph
        self.names = [b.name for b in g.bodies]
        self.mass = np.array([b.mass for b in g.bodies])
        self.inertia = np.array([b.inertia for b in g.bodies])
        self.joints = {j.name: j for j in g.joints}
        self.actuators = [self.joints[a.joint] for a in g.actuators]
        self.gravity = np.array(scene.effects.gravity, float)
        self.forces = list(zip(scene.forces, np.asarray(force_parameters).reshape(-1, 4), strict=True))

    def pose(self, q, body):
        if body == "ground":
            return np.zeros(2), 0.0
        k = 3 * self.names.index(body)
        return q[k:k + 2], q[k + 2]

    def point(self, q, body, local):
        """Global position of the body-frame point `local` (global for the ground)."""
        r, th = self.pose(q, body)
        return r + _rot(th) @ np.asarray(local, float)

    def actuator_coordinates(self, q):
        out = []
        for j in self.actuators:
            (b1, b2), (p1, p2) = j.bodies, j.points
            th1 = self.pose(q, b1)[1]
            if j.type == "revolute":
                out.append(self.pose(q, b2)[1] - th1)
            else:
                out.append(float(_rot(th1) @ np.asarray(j.axis) @ (self.point(q, b2, p2) - self.point(q, b1, p1))))
        return np.array(out)

    def element_coordinates(self, q):
        """Each spring-damper's length or angle (loads have none)."""
        out = []
        for e, _ in self.forces:
            a, b = e.bodies[0], e.bodies[-1]
            if e.type == "spring_damper":
                out.append(np.linalg.norm(self.point(q, b, e.points[1]) - self.point(q, a, e.points[0])))
            elif e.type == "rotational_spring_damper":
                out.append(self.pose(q, b)[1] - self.pose(q, a)[1])
        return np.array(out)

    def generalised_work(self, q, dq, qdd, s, sd, ds, known_only=False):
        """Virtual work on a displacement dq of the coordinates of inertia (-M qdd), gravity and
        the constant force elements (s, sd, ds: the springs' coordinates, their rates and their
        change; with known_only, the elements the controller knows): the sum over bodies of
        (F - m a) . dr + (tz - I alpha) dtheta."""
        w = 0.0
        for i, _ in enumerate(self.names):
            dr, dth = dq[3 * i:3 * i + 2], dq[3 * i + 2]
            w += self.mass[i] * (self.gravity - qdd[3 * i:3 * i + 2]) @ dr - self.inertia[i] * qdd[3 * i + 2] * dth
        k = 0
        for e, (k_or_fx, c_or_fy, s0_or_tz, f0) in self.forces:
            if e.type == "load":
                if e.table or (known_only and not e.known):
                    continue
                i, th = self.names.index(e.bodies[0]), self.pose(q, e.bodies[0])[1]
                f = np.array([k_or_fx, c_or_fy])
                f = _rot(th) @ f if e.frame == "body" else f
                arm = _rot(th) @ np.asarray(e.points[0], float)  # the point moves by dr + dtheta x arm
                dp = dq[3 * i:3 * i + 2] + dq[3 * i + 2] * np.array([-arm[1], arm[0]])
                w += f @ dp + s0_or_tz * dq[3 * i + 2]
            else:
                w += -(k_or_fx * (s[k] - s0_or_tz) + f0 + c_or_fy * sd[k]) * ds[k]
                k += 1
        return w
