"""`Problem`: a scene built once, what every algorithm takes.

Data flows one way: scene -> problem -> solution -> results. A :class:`Problem` is made
from a validated :class:`~rrr4.scene.Scene` (:meth:`Problem.from_scene`, or
:func:`rrr4.build`) and holds

- the immutable graph :class:`~rrr4.mechanism.Model` and the kinematic
  :class:`~rrr4.mechanism.Mechanism` (closed form for an n-RRR, Newton for any graph);
- the structure/parameter split: the numbers that enter compiled Functions as inputs
  (:attr:`contact_parameters`, :meth:`equation_parameters`) and the structure keys that
  name what is built once for every problem of the same structure (:attr:`plant_key`,
  :attr:`controller_key`, :attr:`path_key`, :attr:`preload_key`);
- the equations of motion (:meth:`equations`) and the effort family along a motion
  (:meth:`effort_family`);
- the caches of what is built and compiled for it (:meth:`memo`): per problem, or shared
  by every problem of one structure through :meth:`structure` (the Problem of a structure
  key, itself built once).

Below the front doors (``solve_preload``, ``simulate``, ``codegen``, ``sweep``, the
studies), which accept a Scene or a Problem, every algorithm takes the Problem and reads
the scene's settings through it. Its methods are the one dispatch between the closed-form
n-RRR and a general graph (effort family, path, body and seated coordinates, the assembly
branch); the path's references dispatch once in :func:`rrr4.control.prescribed_references`.
What exists only in closed form is asked with :attr:`Problem.closed_form`, and only for
that: the closed-form controller step and its full set of generated functions, the
scalar preload laws inside it, the transmission angles of the workspace maps, the
robustness cases (which perturb an n-RRR's chains) and the seated model of identification;
any other scene's controller steps on references tabulated along its path
(:func:`rrr4.control.controller_step`).
"""

from __future__ import annotations

import functools
import os
from dataclasses import replace

import casadi as ca
import numpy as np

from .checks import argument, describe, unknown_value
from .contact import V_MIN, joint_stiffness
from .dynamics.builder import BAUMGARTE_OMEGA, INPUTS, Equations, parametric_equations, with_parameters
from .dynamics.elements import element_coordinate, element_forces_function
from .dynamics.family import EffortFamily, graph_family
from .dynamics.inverse import inverse_dynamics_function
from .dynamics.layout import (
    CONTACT_GROUPS,
    LUBRICATION_PARAMETERS,
    WEAR_PARAMETERS,
    ParameterLayout,
    lubricated_joints,
    parameter_layout,
    worn_joints,
)
from .errors import SceneError
from .mechanism import Mechanism, Model, geometry_parameters, load_scene
from .scene import JointSpec, Scene
from .trajectory import trajectory_function

__all__ = ["Problem", "build"]


class Problem:
    """A scene built once (see the module docstring). Never changes after construction;
    what it builds lazily is cached on it."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self.model: Model = Model.of(scene.graph)
        self._memo: dict = {}

    @staticmethod
    def from_scene(scene: Scene | Problem) -> Problem:
        """The Problem of `scene`: a Scene (built once per scene), a scene file's path (read and
        checked with :func:`rrr4.load_scene`) or a Problem (returned as is). Raises SceneError
        for anything else."""
        if isinstance(scene, Problem):
            return scene
        if isinstance(scene, (str, os.PathLike)):
            scene = load_scene(scene)
        if not isinstance(scene, Scene):
            raise SceneError(f"scene: {describe(scene)} is not allowed (a Scene from rrr4.load_scene, a scene file's "
                             "path, or a Problem from rrr4.build)")
        return _problem(scene)

    def __repr__(self) -> str:
        return f"Problem({self.scene.name!r})"

    # ------------------------------------------------------------------ what the scene says

    @property
    def name(self) -> str:
        return self.scene.name

    @property
    def path(self):
        return self.scene.path

    @property
    def closed_form(self) -> bool:
        """True for an n-RRR scene (closed-form IK, inverse dynamics and controller step)."""
        return self.scene.mechanism is not None

    @functools.cached_property
    def mechanism(self) -> Mechanism:
        """The kinematic mechanism, shared by every problem whose scenes differ only in the
        clearance joints' numbers (radii, clearance, film), which the kinematics does not use."""
        return Mechanism.from_scene(replace(self.scene, graph=_without_clearance_numbers(self.scene.graph)))

    @property
    def gravity(self) -> tuple[float, float]:
        return tuple(float(v) for v in self.scene.effects.gravity)

    @property
    def mode(self) -> str:
        return self.scene.actuation.mode

    @property
    def torque_limit(self) -> tuple[float, ...]:
        """The actuators' effort limits [N m or N] (the graph's, :attr:`rrr4.scene.Scene.torque_limit`)."""
        return self.scene.torque_limit

    @property
    def clearance_joints(self) -> tuple[str, ...]:
        return self.model.clearance_joints

    @property
    def redundancy(self) -> int:
        return self.model.redundancy

    @property
    def has_preload(self) -> bool:
        """True if the scene's controller preloads: redundancy, min_force > 0 and a method other than none."""
        p = self.scene.actuation.preload
        return self.model.redundancy >= 1 and p.min_force > 0 and p.method != "none"

    @property
    def compensates(self) -> bool:
        """True if the controller closes its references around the predicted journal seats."""
        return self.scene.actuation.compensation == "clearance" and bool(self.clearance_joints)

    def joint(self, name: str) -> JointSpec:
        return self.scene.graph.joint(name)

    @functools.cached_property
    def effort_units(self) -> tuple[str, ...]:
        """The unit of each actuator's effort: 'N m' on a revolute joint, 'N' on a prismatic one."""
        return tuple(self.model.effort_unit(j) for j in self.model.actuated_joints)

    @property
    def effort_unit(self) -> str:
        """The actuators' effort unit: 'N m', 'N', or 'N m or N' for a mix (and the null-space
        coordinate's)."""
        return " or ".join(dict.fromkeys(self.effort_units)) or "N m"

    # ------------------------------------------------------------------ parameters

    def joint_stiffness(self, name: str) -> float:
        """K [N/m^n] of clearance joint `name`: the scene's value, else from materials and radii."""
        return joint_stiffness(self.joint(name), self.scene.effects.contact.stiffness)

    @functools.cached_property
    def parameter_layout(self) -> ParameterLayout:
        """The names of the equations' input ``parameters`` (:mod:`rrr4.dynamics.layout`): the
        layout the equations are built with (``Problem.equations().layout``, without geometry)."""
        return parameter_layout(self.model, self.scene.effects, self.scene.forces)

    @functools.cached_property
    def contact_parameters(self) -> np.ndarray:
        """The contact numbers the equations take as inputs, written by name into the groups
        ``joints``, ``contact``, ``lubrication``, ``wear`` and ``profiles`` of
        :attr:`parameter_layout`: per clearance joint (graph order) stiffness [N/m^n], journal
        and bearing radius [m], then restitution, damping and the friction law's coefficients,
        then per lubricated joint viscosity [Pa s], bearing length [m] and threshold, then per
        worn joint its wear coefficient, hardness [Pa] and bearing length [m], then the wear
        profiles' node depths [m] (zeros: unworn); empty without a clearance joint (no contact)."""
        effects = self.scene.effects
        ce, fe = effects.contact, effects.friction
        values = {}
        for j in self.clearance_joints:
            joint = self.joint(j)
            values |= {f"joints.{j}.stiffness": self.joint_stiffness(j),
                       f"joints.{j}.journal_radius": joint.journal_radius,
                       f"joints.{j}.bearing_radius": joint.bearing_radius}
        if self.clearance_joints:
            values |= {"contact.restitution": ce.restitution, "contact.damping": ce.damping,
                       "contact.friction_coefficient": fe.coefficient,
                       "contact.static_coefficient": fe.static_coefficient, "contact.v0": fe.v0,
                       "contact.v1": fe.v1, "contact.stribeck_velocity": fe.stribeck_velocity}
        for j, film in lubricated_joints(self.model, effects):
            values |= {f"lubrication.{j}.{k}": getattr(film, k) for k in LUBRICATION_PARAMETERS}
        for j, wear in worn_joints(self.model, effects):
            values |= {f"wear.{j}.{k}": getattr(wear, k) for k in WEAR_PARAMETERS}
        values |= {n: 0.0 for n in self.parameter_layout.names if n.startswith("profiles.")}  # unworn
        return self.parameter_layout.vector(values, CONTACT_GROUPS)

    @functools.cached_property
    def start_coordinates(self) -> np.ndarray:
        """q (nq,) of the ideal mechanism at t = 0: the task at the path's start, or the drivers
        at their initial values (the pose a spring's default free length is measured in)."""
        target = self.start_target
        zero = np.zeros(len(target))
        return np.asarray(self.body_motion(target, zero, zero)[0], float).ravel()

    @functools.cached_property
    def force_parameters(self) -> np.ndarray:
        """The force elements' numbers the equations take as inputs, 4 per element in scene
        order (:data:`rrr4.scene.forces.FORCE_PARAMETERS`): a spring's stiffness, damping, free
        length or angle (its value in :attr:`start_coordinates` when the scene gives none) and
        preload; a constant load's fx, fy, tz (a tabulated load's are zeros, its table is
        structure). Empty without force elements."""
        out = []
        for e in self.scene.forces:
            free = None
            if e.type != "load" and e.free_length is None:
                free = float(element_coordinate(self.model, e, ca.DM(self.start_coordinates)))
            out += e.values(free)
        return np.array(out, float)

    @functools.cached_property
    def controller_loads(self) -> tuple:
        """The force elements the closed-form controller step of an n-RRR balances: the known
        constant loads on the task body (none for a graph scene, whose references come from
        :meth:`effort_family`)."""
        return tuple(e for e in self.scene.forces if self.closed_form and e.type == "load" and e.known
                     and not e.table and e.bodies[0] == self.model.task)

    @property
    def platform_loads(self) -> tuple:
        """:attr:`controller_loads` as the closed-form inverse dynamics takes them: (point,
        (fx, fy), tz, in_body_frame) each."""
        return tuple((e.points[0], e.force, e.torque, e.frame == "body") for e in self.controller_loads)

    @functools.cached_property
    def element_forces(self):
        """'force_elements' Function (q, qd, t -> Q) of the known time-independent force elements
        (spring-dampers and constant loads) that the effort family balances besides gravity and
        the closed form's :attr:`controller_loads`, or None without any (tabulated loads are not
        in the controller's model). A graph's family balances them all; an n-RRR's closed form
        takes its constant platform loads itself and these on top (:meth:`effort_family`), and
        its controller then steps on tabulated references."""
        taken = self.controller_loads
        return self._forces_function([i for i, e in enumerate(self.scene.forces)
                                      if e.known and not e.table and e not in taken])

    @functools.cached_property
    def known_forces(self):
        """'force_elements' Function (q, qd, t -> Q) of every known time-independent force
        element (spring-dampers, constant loads, the platform's too), or None without any: what
        the effort family balances besides gravity, for a formulation on the graph's equations."""
        return self._forces_function([i for i, e in enumerate(self.scene.forces) if e.known and not e.table])

    @property
    def closed_form_family(self) -> bool:
        """True where the n-RRR's closed-form :meth:`inverse_dynamics` is the whole effort family
        (an n-RRR whose known force elements are constant loads on the platform only); elsewhere
        the family comes from the graph's equations (:meth:`effort_family`, :attr:`known_forces`)."""
        return self.closed_form and self.element_forces is None

    @functools.cached_property
    def plant_forces(self):
        """'force_elements' Function (q, qd, t -> Q) of every force element, as the plant
        feels them (the journals' initial seats take them in), or None without any."""
        return self._forces_function(list(range(len(self.scene.forces))))

    def _forces_function(self, which: list[int]):
        if not which:
            return None
        p = self.force_parameters.reshape(-1, 4)[which].ravel()
        return element_forces_function(self.model, tuple(self.scene.forces[i] for i in which), p)

    def equation_parameters(self, geometry: bool = False) -> np.ndarray:
        """The values of the equations' input ``parameters``: the contact numbers, the force
        elements' (:attr:`force_parameters`), then with `geometry` masses, inertias and joint
        points (:func:`rrr4.mechanism.geometry_parameters`)."""
        return np.r_[self.contact_parameters, self.force_parameters,
                     geometry_parameters(self.scene.graph) if geometry else []]

    # ------------------------------------------------------------------ structure keys

    @functools.cached_property
    def controller_key(self) -> Scene:
        """What the parametric controller step depends on: the scene without its names, path,
        integrator and initial state, without the contact numbers and the actuators' limits,
        and with the controller's numbers (gains, limits, f_min, weights, rate) neutral."""
        s = self.scene
        ce, fe = s.effects.contact, s.effects.friction
        effects = replace(s.effects, contact=replace(ce, restitution=1.0, damping=0.0, stiffness=None),
                          friction=replace(fe, coefficient=0.0, static_coefficient=0.0, v0=1.0, v1=2.0,
                                           stribeck_velocity=1.0), lubrication=_film(s.effects.lubrication),
                          wear=_wear(s.effects.wear))
        actuators = tuple(replace(a, limit=1.0) for a in s.graph.actuators)
        a, n = s.actuation, self.model.n_actuators
        preload = replace(a.preload, min_force=float(a.preload.min_force > 0), weights=(1.0,) * n,
                          qp_solver="qrqp", smoothness_weight=0.0, max_turn_rate=0.0)  # not in a pointwise law
        actuation = replace(a, kp=0.0, kd=0.0, control_rate=None, preload=preload,
                            seat_model=a.seat_model if self.compensates else "quasi_static")
        return replace(s, name="", description="", source="", path=None, integrator=None, initial=None,
                       graph=replace(_without_clearance_numbers(s.graph), actuators=actuators), effects=effects,
                       actuation=actuation, forces=self.controller_loads)

    @functools.cached_property
    def plant_key(self) -> Scene:
        """What the equations of motion depend on (graph, effects, actuation mode), without the
        contact numbers: changing the path, the integrator, the initial state, the controller's
        settings or the names does not rebuild them."""
        s = self.controller_key
        forces = tuple(replace(e, stiffness=1.0, damping=1.0, free_length=0.0, preload=0.0, force=(0.0, 0.0),
                               torque=0.0, known=True) for e in self.scene.forces)  # their numbers are inputs
        return replace(s, actuation=replace(s.actuation, preload=None, kp=0.0, kd=0.0,
                                            control_rate=None, compensation="none",
                                            seat_model="quasi_static"), forces=forces)

    @functools.cached_property
    def geometry_key(self) -> Scene:
        """:attr:`plant_key` without the masses, inertias and joint points either (nor the pose
        guesses and the task point, which the equations do not use)."""
        s = self.plant_key
        g = s.graph
        bodies = tuple(replace(b, mass=1.0, inertia=1.0, pose=(0.0, 0.0, 0.0),
                               points=tuple((name, (0.0, 0.0)) for name, _ in b.points)) for b in g.bodies)
        joints = tuple(replace(j, points=((0.0, 0.0), (0.0, 0.0))) for j in g.joints)
        task_point = None if g.task_point is None else (0.0, 0.0)
        return replace(s, mechanism=None, graph=replace(g, bodies=bodies, joints=joints, task_point=task_point))

    @functools.cached_property
    def path_key(self) -> Scene:
        """What references along the path depend on: the mechanism and the path, not the
        actuation, effects, integrator or initial state."""
        s = self.scene
        return replace(s, name="", description="", source="", integrator=None, initial=None, actuation=None,
                       effects=None, forces=())

    @functools.cached_property
    def preload_key(self) -> Scene:
        """What the pointwise preload along the path depends on (the ideal effort family, the
        preload's settings, so the preload's sign choice): the mechanism with its masses and
        the actuators' limits, the path, gravity and ``actuation.preload``; not the contact,
        friction and lubrication, the clearance joints' numbers, the controller's gains, rate
        and compensation, the integrator or the initial state."""
        s = self.scene
        actuation = replace(s.actuation, kp=0.0, kd=0.0, control_rate=None, compensation="none",
                            seat_model="quasi_static")
        return replace(s, name="", description="", source="", integrator=None, initial=None,
                       graph=_without_clearance_numbers(s.graph),
                       effects=replace(s.effects, contact=None, friction=None, lubrication=None, wear=None),
                       actuation=actuation)

    def structure(self, key: str) -> Problem:
        """The Problem of one of the structure keys ('controller', 'plant', 'geometry',
        'path', 'preload'): shared by every problem of that structure, so what is cached on it (its
        :meth:`memo`) is built once for all of them."""
        return _problem(getattr(self, f"{key}_key"))

    def memo(self, key, build):
        """build() once per problem and key (what is built and compiled for this problem)."""
        if key not in self._memo:
            self._memo[key] = build()
        return self._memo[key]

    def memoized(self, kind: str | None = None) -> list:
        """What :meth:`memo` holds under keys that are tuples starting with `kind` (e.g. 'system'),
        or under any key (None)."""
        return [v for k, v in self._memo.items() if kind is None or isinstance(k, tuple) and k and k[0] == kind]

    # ------------------------------------------------------------------ built things

    def equations(self, v_min: float = V_MIN, baumgarte: float = BAUMGARTE_OMEGA,
                  inputs: str = "contact") -> Equations:
        """The equations of motion with exactly the effects the scene asks for
        (:func:`rrr4.dynamics.builder.build_equations`): the parametric equations are built once
        per structure and options (the structure's Problem shares them); this problem's numbers
        are folded into them once per problem (about 3 ms on the reference scene)."""
        v_min, baumgarte = argument("v_min", v_min), argument("baumgarte", baumgarte, allow_zero=True)
        if inputs not in INPUTS:
            raise unknown_value("inputs", "value", inputs, INPUTS)
        geometry = inputs == "geometry"
        key = self.structure("geometry" if geometry else "plant")
        parametric = key.memo(("parametric", v_min, baumgarte, inputs), lambda: parametric_equations(
            key.model, key.scene.effects, key.mode, v_min=v_min, baumgarte=baumgarte, inputs=inputs,
            forces=key.scene.forces))
        return self.memo(("equations", v_min, baumgarte, inputs),
                         lambda: with_parameters(parametric, self.equation_parameters(geometry)))

    def inverse_dynamics(self, gravity=None):
        """The n-RRR's closed-form 'inverse_dynamics' Function (pose, pose_d, pose_dd ->
        tau_p, tau_n, r_p, r_n) with the scene's gravity and constant loads on the platform
        (:attr:`platform_loads`), or with `gravity` (2,) [m/s^2] and no loads (the inertial part)."""
        if gravity is None:
            return inverse_dynamics_function(self.mechanism, self.gravity, self.platform_loads)
        return inverse_dynamics_function(self.mechanism, gravity)

    def effort_family(self, pose, pose_d, pose_dd, q=None, gravity=None) -> EffortFamily:
        """The affine family of efforts and passive-joint reactions of the ideal mechanism at
        task poses (N, 3) and their rates: the closed form of an n-RRR, else the graph's SVD
        (q: the graph's coordinates at the poses, if known). gravity (2,) [m/s^2]: default
        the scene's, with the force elements the controller knows (an n-RRR: constant loads on
        the platform in closed form, and :attr:`element_forces`: spring-dampers and constant
        loads anywhere);
        a given gravity means the inertial part with that gravity and no force elements."""
        pose, pose_d, pose_dd = (np.atleast_2d(np.asarray(v, float)) for v in (pose, pose_d, pose_dd))
        mech, N = self.mechanism, pose.shape[0]
        elements = self.element_forces if gravity is None else None
        if self.closed_form:
            fam = EffortFamily.from_raw(self.inverse_dynamics(gravity).map(N)(pose.T, pose_d.T, pose_dd.T))
            if elements is None:
                return fam
            # the known elements the closed form does not take: their particular efforts and
            # reactions (the family is linear in the loads; the null space is the same)
            q, qd, _ = (np.array(v).T for v in mech.body_motion_function.map(N)(pose.T, pose_d.T, pose_dd.T))
            external = np.array(elements.map(N)(q.T, qd.T, 0.0)).T
            return fam.plus(graph_family(mech, q, np.zeros_like(q), (0.0, 0.0), external))
        k = mech.n_task
        q = mech.path_coordinates(pose[:, :k]) if q is None else np.asarray(q, float)
        qd, qdd, _, _ = mech.motion(q, pose_d[:, :k], pose_dd[:, :k])
        external = None if elements is None else np.array(elements.map(N)(q.T, np.asarray(qd).T, 0.0)).T
        return graph_family(mech, q, qdd, self.gravity if gravity is None else gravity, external)

    @functools.cached_property
    def branch_hint(self) -> str:
        """'' or one sentence when the scene names no assembly mode and several close at t = 0
        (:meth:`rrr4.Mechanism.branch_hint`): what a failure on the branch taken should add."""
        if self.closed_form:
            return ""
        mech = self.mechanism
        return mech.branch_hint(self.start_target)

    @functools.cached_property
    def assembly_branch(self) -> str:
        """Which assembly the scene takes at t = 0, in words: an n-RRR's chains' working modes,
        else the branch of :attr:`start_coordinates` and whether mechanism.assembly names it."""
        if self.closed_form:
            return "working modes " + " ".join(f"{c.name}:{'+' if c.working_mode > 0 else '-'}"
                                               for c in self.scene.mechanism.chains) + " (the chains' working_mode)"
        mech = self.mechanism
        named = "named in mechanism.assembly" if mech.assembly else \
            "none named: mechanism.assembly fixes it, see the README"
        return f"{mech.branch_text(self.start_coordinates)} ({named})"

    @functools.cached_property
    def start_target(self) -> np.ndarray:
        """The task's coordinates at t = 0 (the path's start), or the drivers' initial values."""
        if self.model.task is not None:
            return np.array(trajectory_function(self.scene.path)(0.0)[0]).ravel()[:self.mechanism.n_task]
        return self.mechanism.driver_targets(0.0)[0]

    def path_coordinates(self, pose, pose_d, pose_dd) -> np.ndarray:
        """q (N, nq) of every body with the task at poses (N, 3) (rates (N, 3) for the closed
        form): the closed form of an n-RRR, else Newton along the poses (continuation)."""
        mech = self.mechanism
        if self.closed_form:
            return np.array(mech.body_motion_function.map(len(pose))(pose.T, pose_d.T, pose_dd.T)[0]).T
        return mech.path_coordinates(pose[:, :mech.n_task])

    def body_motion(self, target, target_d, target_dd):
        """q, qd, qdd (nq,) of every body with the task (or the drivers) at `target` and its
        rates: the closed form of an n-RRR, else Newton and the velocity analysis. A point task
        takes the first two entries of a pose [x, y, theta] and its rates (its body's angle is
        free), as :meth:`rrr4.Mechanism.body_motion` does."""
        mech = self.mechanism
        if self.closed_form:
            return mech.body_motion(target, target_d, target_dd)
        k = mech.n_task
        target, target_d, target_dd = (np.asarray(v, float).ravel()[:k] for v in (target, target_d, target_dd))
        q0 = mech.assemble(target)
        qd0, qdd0, _, _ = (v.ravel() for v in mech.motion(q0, target_d, target_dd))
        return q0, qd0, qdd0

    def seated_coordinates(self, target, offsets, guess) -> np.ndarray:
        """q (nq,) with the task at `target` and each clearance joint opened by its offset
        (nc, 2) [m] (second point minus first): the closed form of an n-RRR, else Newton from `guess`."""
        mech = self.mechanism
        if self.closed_form:  # eccentricities of all passive joints, B1..Bn, C1..Cn
            names = self.model.preload_joints
            ecc = np.zeros((len(names), 2))
            ecc[[names.index(c) for c in self.clearance_joints]] = offsets
            return mech.seated_coordinates(target, ecc)
        return mech.assemble(target, offsets, guess=guess)


def _film(f):
    """A film's law without its numbers (the law is structure, its numbers are inputs)."""
    return None if f is None else replace(f, viscosity=1.0, length=1.0, threshold=0.5)


def _wear(w):
    """A joint's wear without its numbers (the surfaces and nodes are structure, k, H and L inputs)."""
    return None if w is None else replace(w, coefficient=1.0, hardness=1.0, length=1.0)


def _without_clearance_numbers(graph):
    """`graph` with its clearance joints' journal radius, clearance, film and wear numbers neutral."""
    joints = tuple(replace(j, journal_radius=1.0, radial_clearance=1.0, lubrication=_film(j.lubrication),
                           wear=_wear(j.wear))
                   if j.clearance else j for j in graph.joints)
    return replace(graph, joints=joints)


@functools.lru_cache(maxsize=64)
def _problem(scene: Scene) -> Problem:
    """The Problem of `scene`, built once per scene content: keyed by the scene's equality,
    which leaves out its source file and YAML data (Scene.source, Scene.data), so two equal
    scenes share one Problem (and ``problem.scene`` is the first of them). The 64 most
    recently used are kept."""
    return Problem(scene)


def build(scene: Scene | Problem) -> Problem:
    """The :class:`Problem` of a scene (built once per scene)."""
    return Problem.from_scene(scene)
