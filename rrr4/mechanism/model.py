"""`Model`: the immutable planar multibody model of a scene's body/joint graph.

Reference-point coordinates (Nikravesh 1988, Computer-Aided Analysis of Mechanical
Systems, ch. 3-4): every body has q_k = [x, y, theta] of its centre of mass, so the mass
matrix is constant and block-diagonal. Body k occupies q[3k : 3k + 3] in the graph's body
order; the ground has no coordinates. This module is the one place that turns body, point
and joint names into coordinate indices.

Joint equations (2 rows each, Nikravesh 1988, sec. 3.4):

- revolute: p_2 - p_1 = 0, with p_k = r_k + A(theta_k) s_k the joint point on body k (for
  a clearance joint the same expression is the gap between journal and bearing centres);
- prismatic: theta_2 - theta_1 - angle = 0 and n_1 . (p_2 - p_1) = 0, n_1 = A(theta_1) E u
  the normal of the slide axis u of body 1.

Joint coordinates: theta_2 - theta_1 [rad] (revolute), u_1 . (p_2 - p_1) [m]
(prismatic). An actuator's generalised force is S^T f with S = d(coordinate)/dq (virtual
work), a driver adds the row coordinate(q) - value(t), its motion law's value
(:meth:`Model.driver_values`).

Reaction convention (project-wide): the reaction of a revolute joint is the force [N,
global frame] that body 1 (inboard) exerts on body 2 (outboard), r = -lambda for the rows
p_2 - p_1.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from ..scene import GROUND, Graph, JointSpec
from ..trajectory import driver_function

__all__ = ["Model", "rotation", "perp", "geometry_parameters"]


def geometry_parameters(graph: Graph) -> np.ndarray:
    """The graph's numbers that the equations of motion take as an input (``geometry``):
    mass [kg] and inertia [kg m^2] of each body (graph order), then both points (x, y) [m]
    of each joint (graph order, each in its body's frame)."""
    return np.array([*(v for b in graph.bodies for v in (b.mass, b.inertia)),
                     *(v for j in graph.joints for p in j.points for v in p)], float)


def rotation(theta):
    """A(theta) (2 x 2) as a function of an SX/MX angle."""
    c, s = ca.cos(theta), ca.sin(theta)
    return ca.blockcat([[c, -s], [s, c]])


def perp(v):
    """E v: the planar vector v rotated by +90 degrees."""
    return ca.vertcat(-v[1], v[0])


class Model:
    """The graph's coordinates, masses, joint equations and clearance sites (symbolic, SX).

    Build with :meth:`of` (cached per graph). Never changes after construction; numeric
    state lives in the callers.
    """

    def __init__(self, graph: Graph):
        self._constraints: dict = {}  # the constraints Functions built, see constraints
        self.graph = graph
        self.body_names = tuple(b.name for b in graph.bodies)
        self.nq = 3 * len(graph.bodies)
        self._start = {b.name: 3 * k for k, b in enumerate(graph.bodies)}
        self._points = {b.name: dict(b.points) for b in graph.bodies}
        self.joint_names = tuple(j.name for j in graph.joints)
        self.actuator_names = tuple(a.name for a in graph.actuators)
        self.actuated_joints = tuple(a.joint for a in graph.actuators)
        self.driver_names = tuple(d.name for d in graph.drivers)
        self.passive_joints = graph.passive_joints
        self.clearance_joints = tuple(j for j in self.passive_joints if graph.joint(j).clearance)
        # joints held by ideal constraints: every joint but the clearance ones, graph order
        self.constrained_joints = tuple(j.name for j in graph.joints if j.name not in self.clearance_joints)
        self.ideal_passive_joints = tuple(j for j in self.passive_joints if j not in self.clearance_joints)
        # passive revolute joints: the ones a preload must keep loaded, B1..Bn, C1..Cn for an n-RRR
        self.preload_joints = tuple(j for j in self.passive_joints if graph.joint(j).type == "revolute")
        self.task = graph.task
        self.task_point = graph.task_point
        # task degrees of freedom: a body's pose (3) or a point's position (2); 0 without a task
        self.task_dof = 0 if graph.task is None else (3 if graph.task_point is None else 2)
        # what the task locates, in words (figures' labels): the task body, or a point on it
        self.task_label = (None if graph.task is None else graph.task if graph.task_point is None
                           else f"task point on {graph.task}")
        self.mass_diagonal = np.array([v for b in graph.bodies for v in (b.mass, b.mass, b.inertia)])
        self.pose_guess = np.array([v for b in graph.bodies for v in b.pose], float)

        q, qd = ca.SX.sym("q", self.nq), ca.SX.sym("qd", self.nq)
        self._q, self._qd = q, qd
        s = ca.vertcat(*[self.joint_coordinate(q, a.joint) for a in graph.actuators]) if graph.actuators \
            else ca.SX(0, 1)
        self.actuator_coordinates_function = ca.Function(
            "actuator_coordinates", [q], [s, ca.jacobian(s, q)], ["q"], ["s", "S"])
        self.task_pose_function = ca.Function("task_pose", [q], [self.task_pose(q) if self.task else ca.SX.zeros(3)],
                                              ["q"], ["pose"])

    @staticmethod
    def of(graph: Graph) -> Model:
        return _model(graph)

    # ------------------------------------------------------------------ indices

    def coordinates(self, body: str) -> slice:
        """Slice of q holding [x, y, theta] of `body`."""
        k = self._start[body]
        return slice(k, k + 3)

    def rotation_index(self, body: str) -> int | None:
        """Index of theta of `body` in q (None for the ground)."""
        return None if body == GROUND else self._start[body] + 2

    @property
    def n_actuators(self) -> int:
        return len(self.graph.actuators)

    @property
    def redundancy(self) -> int:
        """Degree of actuation redundancy: actuators minus task degrees of freedom (>= 0)."""
        return max(self.n_actuators - self.task_dof, 0) if self.task else 0

    def task_pose(self, q):
        """[x, y, theta] of the task: the task body's centre of mass, or its task point, with
        the body's angle (SX/MX q; None without a task)."""
        if self.task is None:
            return None
        r, th = self.body_pose(q, self.task)
        if self.task_point is None:
            return ca.vertcat(r, th)
        return ca.vertcat(self.point(q, self.task, self.task_point), th)

    # ------------------------------------------------------------------ symbolic kinematics

    def body_pose(self, q, body: str):
        """(r (2,), theta) of `body` in q; the ground is (0, 0)."""
        if body == GROUND:
            return ca.DM.zeros(2), 0
        k = self._start[body]
        return q[k:k + 2], q[k + 2]

    def point(self, q, body: str, local) -> ca.SX:
        """Global position (2,) [m] of the body-frame point `local` (2,) (global for the ground)."""
        local = ca.DM(local) if not isinstance(local, (ca.SX, ca.DM)) else local
        if body == GROUND:
            return local
        r, th = self.body_pose(q, body)
        return r + rotation(th) @ local

    def local_points(self, joint: JointSpec, geometry=None):
        """The joint's two points, each in its body's frame (global on the ground): numbers,
        or from the symbols `geometry` (laid out as :func:`geometry_parameters`) if given."""
        if geometry is None:
            return tuple(ca.DM(p) for p in joint.points)
        k = 2 * len(self.body_names) + 4 * self.joint_names.index(joint.name)
        return geometry[k:k + 2], geometry[k + 2:k + 4]

    def joint_points(self, q, joint: JointSpec, geometry=None):
        """(p_1, p_2) global positions of the joint's points on its two bodies (local points
        as :meth:`local_points`)."""
        return tuple(self.point(q, b, p) for b, p in zip(joint.bodies, self.local_points(joint, geometry),
                                                           strict=True))

    def masses(self, geometry=None):
        """(mass diagonal (nq,) [kg, kg, kg m^2], masses (n_bodies,) [kg]): numeric, or from
        the symbols `geometry` (:func:`geometry_parameters`)."""
        if geometry is None:
            return self.mass_diagonal, np.array([b.mass for b in self.graph.bodies])
        m, inertia = geometry[0:2 * len(self.body_names):2], geometry[1:2 * len(self.body_names):2]
        return ca.vertcat(*[v for k in range(len(self.body_names)) for v in (m[k], m[k], inertia[k])]), m

    def joint_equations(self, q, name: str, geometry=None) -> ca.SX:
        """The two constraint rows of joint `name` (zero when the joint is ideal and closed)."""
        j = self.graph.joint(name)
        p1, p2 = self.joint_points(q, j, geometry)
        if j.type == "revolute":
            return p2 - p1
        (_, th1), (_, th2) = self.body_pose(q, j.bodies[0]), self.body_pose(q, j.bodies[1])
        n1 = rotation(th1) @ ca.DM([-j.axis[1], j.axis[0]]) if j.bodies[0] != GROUND else ca.DM([-j.axis[1],
                                                                                                   j.axis[0]])
        return ca.vertcat(th2 - th1 - j.angle, ca.dot(n1, p2 - p1))

    def effort_unit(self, joint: str) -> str:
        """The unit of an effort along joint `joint`'s coordinate (an actuator's or a driver's):
        'N m' on a revolute joint, 'N' on a prismatic one. The one place this rule is written."""
        return "N m" if self.graph.joint(joint).type == "revolute" else "N"

    def joint_coordinate(self, q, name: str, geometry=None) -> ca.SX:
        """theta_2 - theta_1 [rad] (revolute) or the slide u_1 . (p_2 - p_1) [m] (prismatic)."""
        j = self.graph.joint(name)
        (_, th1), (_, th2) = self.body_pose(q, j.bodies[0]), self.body_pose(q, j.bodies[1])
        if j.type == "revolute":
            return th2 - th1
        p1, p2 = self.joint_points(q, j, geometry)
        u1 = rotation(th1) @ ca.DM(j.axis) if j.bodies[0] != GROUND else ca.DM(j.axis)
        return ca.dot(u1, p2 - p1)

    def constraints(self, joints: tuple[str, ...] | None = None, drivers: bool = False) -> ca.Function:
        """Function 'constraints': q, qd -> phi, phi_q, gamma for the named joints (default:
        the ideal ones) and, with drivers=True, one row per driver with its coordinate
        (the caller subtracts the prescribed value). Phi_q qdd = gamma + (driver
        accelerations), gamma = -(Phi_q qd)_q qd. Rows in the order given, 2 per joint.
        Built once per model, joints and drivers (kept on the model)."""
        joints = self.constrained_joints if joints is None else tuple(joints)
        key = (joints, bool(drivers))
        if key not in self._constraints:
            q, qd = self._q, self._qd
            self._constraints[key] = ca.Function("constraints", [q, qd],
                                                 list(self.constraint_terms(q, qd, joints, drivers)), ["q", "qd"],
                                                 ["phi", "phi_q", "gamma"])
        return self._constraints[key]

    def constraint_terms(self, q, qd, joints: tuple[str, ...], drivers: bool = False, geometry=None):
        """(phi, phi_q, gamma) of :meth:`constraints` as expressions of the symbols q, qd (and
        `geometry`, see :func:`geometry_parameters`)."""
        rows = [self.joint_equations(q, j, geometry) for j in joints]
        if drivers:
            rows += [self.joint_coordinate(q, d.joint, geometry) for d in self.graph.drivers]
        phi = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        phi_q = ca.jacobian(phi, q)
        return phi, phi_q, -ca.jtimes(phi_q @ qd, q, qd)

    def driver_values(self, t):
        """(value, rate, acceleration) of every driver at time t (numeric or symbolic): initial +
        speed t, speed, 0 for a constant speed, the driver's time law
        (:func:`rrr4.trajectory.driver_function`) otherwise."""
        d = self.graph.drivers
        if not d:
            return ca.DM(0, 1), ca.DM(0, 1), ca.DM.zeros(0)
        if all(x.time_law == "constant" for x in d):  # the equations of a constant speed, as ever
            return ca.vertcat(*[x.initial + x.speed * t for x in d]), ca.vertcat(*[x.speed for x in d]), \
                ca.DM.zeros(len(d))
        rows = [(x.initial + x.speed * t, x.speed + 0 * t, 0 * t) if x.time_law == "constant" else
                driver_function(x)(t) for x in d]
        return tuple(ca.vertcat(*col) for col in zip(*rows, strict=True))

    # ------------------------------------------------------------------ numeric helpers

    def mass_matrix(self) -> np.ndarray:
        """M (nq x nq) [kg, kg m^2], constant and diagonal."""
        return np.diag(self.mass_diagonal)

    def gravity_forces(self, gravity, geometry=None):
        """Q_g (nq,) [N, N, N m] of an in-plane gravity (2,) [m/s^2] (symbolic with `geometry`)."""
        gx, gy = gravity
        m = self.masses(geometry)[1]
        rows = [v for k in range(len(self.body_names)) for v in (m[k] * gx, m[k] * gy, 0.0)]
        return np.array(rows, float) if geometry is None else ca.vertcat(*rows)

    def body_poses(self, q: np.ndarray, body: str) -> np.ndarray:
        """(N, 3) poses [x, y, theta] of `body` from states q (N, nq)."""
        if body not in self._start:
            raise KeyError(body)
        return np.asarray(q)[:, self.coordinates(body)]


MODELS = 128  # models kept per graph (a geometry sweep makes one per case, and one per structure key)


@functools.lru_cache(maxsize=MODELS)
def _model(graph: Graph) -> Model:
    return Model(graph)
