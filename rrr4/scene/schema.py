"""The scene schema: frozen dataclasses, all quantities SI (m, kg, s, rad, N, N m) unless a
key says otherwise. Plain data: nothing here knows how a scene is read or simulated."""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

from ..checks import argument, describe
from ..errors import SceneError
from .data import data_describes, set_values, values_changed
from .field_specs import choice, integer, number, text, vector
from .forces import ForceElement
from .time_table import check_time_table
from .vocabulary import GROUND, JOURNAL_STARTS, PATH_TYPES, TIME_LAWS

__all__ = ["Link", "Chain", "Platform", "NRRRSpec", "Material", "JointSpec", "Body", "AssemblyMode", "ActuatorSpec",
           "DriverSpec", "Graph", "ContactEffect", "FrictionEffect", "LubricationEffect", "WearEffect", "Effects",
           "PreloadSettings", "Actuation", "PathSpec", "Initial", "IntegratorSettings", "Scene", "PASSIVE_JOINTS"]

@dataclass(frozen=True)
class Link:
    """A slender link; centre of mass at mid-length. length [m], mass [kg], inertia [kg m^2] about the CoM."""
    length: float = number(positive=True)
    mass: float = number(positive=True)
    inertia: float = number(positive=True)  # mass length^2 / 12 unless given: the reader's


@dataclass(frozen=True)
class Chain:
    """One RRR chain A_i B_i C_i.

    base: (2,) position of A_i [m]; attachment_radius: |C_i - o| [m] (= 0.5 l_i3);
    attachment_angle: angle of C_i in the platform frame [rad];
    working_mode: +1 for the "+acos" branch, -1 for "-acos".
    """
    name: str
    base: tuple[float, float] = vector(2)
    driving: Link
    following: Link
    attachment_radius: float = number(positive=True)  # or chain_defaults': the reader's
    attachment_angle: float
    working_mode: int


@dataclass(frozen=True)
class Platform:
    mass: float = number(positive=True)
    inertia: float = number(positive=True)


@dataclass(frozen=True)
class NRRRSpec:
    """The compact n-RRR form of a scene: platform and chains (the kinematics are :class:`rrr4.Mechanism`)."""
    platform: Platform
    chains: tuple[Chain, ...]

    @property
    def n_chains(self) -> int:
        return len(self.chains)


@dataclass(frozen=True)
class Material:
    name: str = text("custom")
    youngs_modulus: float = number(positive=True, big=True)
    poisson_ratio: float = number(lo=0.0, hi=0.5, hi_open=True)


@dataclass(frozen=True)
class LubricationEffect:
    """The oil film of a lubricated clearance joint (:mod:`rrr4.contact.lubrication`): law
    'none' (dry), 'long-bearing' or 'short-bearing'; viscosity [Pa s], bearing length [m];
    threshold: the eccentricity ratio in (0, 1) above which the dry laws take the load over."""
    law: str = "none"
    viscosity: float = 0.0
    length: float = 0.0
    threshold: float = 0.95


@dataclass(frozen=True)
class WearEffect:
    """Archard wear of a clearance joint (:mod:`rrr4.contact.wear`): the surfaces that wear
    ('none', 'bearing', 'journal' or 'both'), the dimensionless wear coefficient k,
    the hardness H [Pa] of the wearing surface, the bearing length L [m] and the nodes of
    the wear profile over the bearing angle."""
    surfaces: str = "none"
    coefficient: float = 0.0
    hardness: float = 0.0
    length: float = 0.0
    nodes: int = 72

    @property
    def worn(self) -> tuple[str, ...]:
        """The wearing surfaces, in the order ('bearing', 'journal')."""
        return {"none": (), "both": ("bearing", "journal")}.get(self.surfaces, (self.surfaces,))


@dataclass(frozen=True)
class JointSpec:
    """A joint between two bodies (or a body and 'ground').

    type 'revolute': points (2,) in each body's frame (ground: global) coincide; with
    clearance=True it is a journal in a bearing (Flores): the body bodies[journal] carries
    the journal, the other the bearing. type 'prismatic' (always ideal): the second body
    slides along `axis` (unit, first body's frame) through the first body's point, at the
    fixed relative angle `angle` [rad]. Joint coordinate: theta_2 - theta_1 [rad] for a
    revolute, the slide (p_2 - p_1) . axis [m] for a prismatic.
    """
    name: str
    clearance: bool
    journal_radius: float = number(positive=True)
    radial_clearance: float = number(positive=True)  # smaller than journal_radius: bearing.read_fit
    journal_material: Material
    bearing_material: Material
    type: str = "revolute"
    bodies: tuple[str, str] = (GROUND, GROUND)
    points: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    axis: tuple[float, float] = (1.0, 0.0)
    angle: float = 0.0
    journal: int = 1
    lubrication: LubricationEffect | None = None  # this clearance joint's film; None: the scene's (Effects)
    wear: WearEffect | None = None  # this clearance joint's wear; None: the scene's (Effects)

    @property
    def bearing_radius(self) -> float:
        return self.journal_radius + self.radial_clearance

    @property
    def journal_body(self) -> str:
        return self.bodies[self.journal]

    @property
    def bearing_body(self) -> str:
        return self.bodies[1 - self.journal]


@dataclass(frozen=True)
class Body:
    """A rigid body: mass [kg], inertia [kg m^2] about its centre of mass, named points
    (x, y) [m] in the body frame (origin at the centre of mass), and a pose guess
    [x, y, theta] [m, m, rad] for assembling the mechanism."""
    name: str
    mass: float = number(positive=True)
    inertia: float = number(positive=True)
    points: tuple[tuple[str, tuple[float, float]], ...] = ()
    pose: tuple[float, float, float] = vector(3, [0.0, 0.0, 0.0], init=(0.0, 0.0, 0.0))


@dataclass(frozen=True)
class AssemblyMode:
    """One condition of a graph's assembly mode, at a revolute joint between bodies a and b
    (the joint's order): u = joint point - a reference point of a, v = a reference point of b
    - joint point (reference points in the bodies' frames, global on the ground). measure
    'bend': sign of u x v (+1: v turns counter-clockwise from u); 'stretch': sign of u . v
    (+1: b continues a's line, -1: it folds back). sign +1 or -1."""
    joint: str
    measure: str
    sign: int
    points: tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class ActuatorSpec:
    """An actuator on a joint: a torque [N m] on a revolute, a force [N] on a prismatic,
    limited to +-limit."""
    name: str
    joint: str
    limit: float = number(positive=True)


@dataclass(frozen=True)
class DriverSpec:
    """A joint coordinate prescribed in time [rad or m]. time_law 'constant': initial + speed t
    (speed [rad/s or m/s]). Any other law of :data:`rrr4.scene.vocabulary.DRIVER_LAWS` is a
    path's time law s(t) in [0, 1] over `duration` [s] (or the rows (t, s, s_dot) of
    `time_table`, also what a scene's speed table becomes): initial + travel s(t), resting at
    initial + travel after it; speed is then the mean speed travel / duration (what counts per
    revolution use)."""
    name: str
    joint: str
    initial: float
    speed: float
    time_law: str = "constant"
    travel: float = 0.0
    duration: float = 0.0
    time_table: tuple[tuple[float, float, float], ...] = ()


@dataclass(frozen=True)
class Graph:
    """The planar body/joint graph of a scene: every mechanism is one (an n-RRR expands
    into it). task: the body whose pose follows the path, or None (drivers set the motion);
    task_point: None (the task is the body's pose [x, y, theta], 3 DOF) or a point (x, y) [m]
    in its frame (the task is that point's position, 2 DOF: the path's x and y)."""
    bodies: tuple[Body, ...]
    joints: tuple[JointSpec, ...]
    actuators: tuple[ActuatorSpec, ...]
    drivers: tuple[DriverSpec, ...]
    task: str | None
    task_point: tuple[float, float] | None = None
    assembly: tuple[AssemblyMode, ...] = ()

    @property
    def passive_joints(self) -> tuple[str, ...]:
        """Joints with neither an actuator nor a driver, in graph order."""
        busy = {a.joint for a in self.actuators} | {d.joint for d in self.drivers}
        return tuple(j.name for j in self.joints if j.name not in busy)

    def joint(self, name: str) -> JointSpec:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)


@dataclass(frozen=True)
class ContactEffect:
    """Normal force F = K delta^n (1 + chi(c_r) delta_dot / delta_dot0), never pulling.

    stiffness None means computed from materials and radii (Lankarani-Nikravesh / Flores).
    damping is the Kelvin-Voigt coefficient [N s/m] (only used by that law).
    """
    law: str = choice("contact law", "lankarani-nikravesh")
    restitution: float = number(0.9, lo=0.0, hi=1.0, lo_open=True)
    exponent: float = number(1.5, positive=True)  # 1.0 with law kelvin-voigt
    stiffness: float | None = number(positive=True, big=True)  # or 'auto' (None): the reader's
    damping: float = number(0.0, nonneg=True)


@dataclass(frozen=True)
class FrictionEffect:
    law: str = choice("friction law", "none")
    coefficient: float = number(nonneg=True)  # 0 with law 'none'
    static_coefficient: float = number(nonneg=True)  # the coefficient unless given
    v0: float = number(1e-4, positive=True)
    v1: float = number(2e-4, positive=True)  # greater than v0
    stribeck_velocity: float = number(1e-3, positive=True)


@dataclass(frozen=True)
class Effects:
    contact: ContactEffect
    friction: FrictionEffect
    gravity: tuple[float, float] = vector(2, [0.0, 0.0])
    lubrication: LubricationEffect = LubricationEffect()  # every clearance joint's, unless the joint says
    wear: WearEffect = WearEffect()  # every clearance joint's, unless the joint says

    def lubrication_of(self, joint: JointSpec) -> LubricationEffect:
        """The film of clearance joint `joint`: its own if it gives one, else the scene's."""
        return self.lubrication if joint.lubrication is None else joint.lubrication

    def wear_of(self, joint: JointSpec) -> WearEffect:
        """The wear of clearance joint `joint`: its own if it gives one, else the scene's."""
        return self.wear if joint.wear is None else joint.wear


@dataclass(frozen=True)
class PreloadSettings:
    """min_force [N] at every passive joint; weights of the torque norm; NLP terms."""
    method: str = choice("preload method", "exact")
    min_force: float = number(5.0, nonneg=True)
    weights: tuple[float, ...]  # one per actuator, each > 0: the reader's
    qp_solver: str = choice("qp solver", "qrqp")
    smoothness_weight: float = number(1e-4, nonneg=True)
    max_turn_rate: float = number(50.0, positive=True)  # [rad/s] of the contact-force direction in each bearing


@dataclass(frozen=True)
class Actuation:
    """The actuation mode and the controller's settings (the actuators' effort limits are
    the graph's, :attr:`Scene.torque_limit`)."""
    mode: str
    preload: PreloadSettings
    kp: float = number(200.0, nonneg=True)  # [N m/rad]
    kd: float = number(5.0, nonneg=True)  # [N m s/rad]
    # [Hz] sampled controller (zero-order hold); None: continuous
    control_rate: float | None = number(positive=True, optional=True, init=None)
    # 'clearance': references closed around the predicted journal seats
    compensation: str = choice("compensation", "none", init="none")
    # how those seats follow friction: 'quasi_static' (the friction angle of the planned slip
    # velocity) or 'rolling' (the journals roll between friction angles as the slip reverses)
    seat_model: str = choice("seat model", "quasi_static", init="quasi_static")


@dataclass(frozen=True)
class PathSpec:
    """Platform path; geometry in m/rad, duration [s], sample_rate [Hz]."""
    type: str = choice(PATH_TYPES)  # 'none' with no task body: the reader's
    duration: float = number(positive=True)  # the time table's end when it has one: the reader's
    time_law: str = choice(TIME_LAWS, "quintic")
    sample_rate: float = number(1000.0, positive=True)
    orientation: float = number(0.0, init=0.0)
    center: tuple[float, float] = vector(2, init=(0.0, 0.0))  # circle; required there
    radius: float = number(positive=True, init=0.0)  # circle; required there
    start_angle: float = number(0.0, init=0.0)
    revolutions: float = number(1.0, init=1.0)
    start: tuple[float, float, float] = vector(3, init=(0.0, 0.0, 0.0))  # line; required there
    end: tuple[float, float, float] = vector(3, init=(0.0, 0.0, 0.0))  # line; required there
    points: tuple[tuple[float, float, float], ...] = ()
    max_condition_number: float = number(1e3, lo=1.0, lo_open=True, init=1.0e3)
    min_transmission: float = number(0.05, lo=0.0, hi=1.0, hi_open=True, init=0.05)
    # time_law 'table': rows (t [s], s [-], s_dot [1/s]) of rrr4.scene.time_table; () otherwise
    time_table: tuple[tuple[float, float, float], ...] = ()


@dataclass(frozen=True)
class Initial:
    """Initial state. platform_velocity [m/s, m/s, rad/s] is added to the path's own start
    velocity. journals: 'centred' starts every journal at its bearing centre; 'seated'
    starts each clearance journal pressed against its bearing wall under the joint's
    initial load (direction and Hertzian penetration from the ideal reaction at t = 0)."""
    platform_velocity: tuple[float, float, float] = vector(3, [0.0, 0.0, 0.0], init=(0.0, 0.0, 0.0))
    journals: str = choice(JOURNAL_STARTS, "centred", init="centred")


@dataclass(frozen=True)
class IntegratorSettings:
    method: str = choice("integrator", "bathe")
    step: float = number(1e-5, positive=True)  # [s] fixed step, or initial step of adaptive methods
    rtol: float = number(1e-8, positive=True)
    atol: float = number(1e-10, positive=True)
    gamma: float = number(0.5, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    rho_inf: float = number(0.0, lo=0.0, hi=1.0)
    newton_tol: float = number(1e-10, positive=True)
    max_newton: int = integer(20, positive=True)
    # sub-steps that re-take a fixed step across a contact onset or loss (1: off)
    refine: int = integer(1, positive=True, init=1)
    # implicit methods: reuse the iteration matrix's factors, or 'full'
    newton: str = choice("newton", "simplified", init="simplified")
    # [m] implicit methods: local position error per step (adaptive); None: fixed step
    tolerance: float | None = number(positive=True, optional=True, init=None)
    # what the integrator steps: tree coordinates ('auto': wherever a tree exists) or not
    coordinates: str = choice("coordinates", "auto", init="auto")


@dataclass(frozen=True)
class Scene:
    """A validated scene. mechanism: the compact n-RRR form (None for a graph scene);
    graph: the body/joint graph every scene has (an n-RRR expands into it)."""
    name: str
    description: str = text("")
    mechanism: NRRRSpec | None
    graph: Graph
    effects: Effects
    actuation: Actuation
    path: PathSpec
    initial: Initial
    integrator: IntegratorSettings
    forces: tuple[ForceElement, ...] = ()  # spring-dampers and loads (rrr4.scene.forces); () for none
    source: str = field(default="", compare=False)
    # the YAML mapping it was read from, table files inlined (rrr4.scene.data); None when
    # built from dataclasses. Read-only: change a scene with with_values.
    data: dict | None = field(default=None, compare=False, repr=False)
    # what read it from its data (rrr4.scene.parse_scene), which with_values calls again
    read: Callable | None = field(default=None, compare=False, repr=False)

    def with_values(self, values: Mapping, name: str | None = None) -> Scene:
        """This scene with the YAML values at dotted keys replaced (``{'joints.radial_clearance':
        1.2e-4, 'mechanism.chains[0].base[1]': 0.31}``, list items as ``[i]``), read and
        validated again as its file would be (data checks only; :func:`rrr4.load_scene` also
        checks the mechanism against its model). The one way studies change a scene in memory:
        it works for a scene read from a file and for one parsed from a mapping in Python
        (:func:`rrr4.scene.parse_scene`), and keeps earlier in-memory changes made through
        :meth:`with_torque_limit` and :meth:`with_time_table`. name: the new scene's name when
        its data names none (default this one's). Raises SceneError in one line (a bad key or
        value; a scene without data, or changed with ``dataclasses.replace`` since it was read)."""
        return values_changed(self, values, name)

    @functools.cached_property
    def data_current(self) -> bool:
        """True if :attr:`data` read again gives this scene (False after a change made with
        ``dataclasses.replace``, which :meth:`with_values` would lose; checked once)."""
        return self.data is not None and self.read is not None and data_describes(self)

    def _with_data_values(self, values: dict) -> dict | None:
        """:attr:`data` with `values` set in a copy (None stays None): the YAML side of an
        in-memory change, so the data keeps describing the scene."""
        return None if self.data is None else set_values(self.data, values)

    @property
    def joints(self) -> tuple[JointSpec, ...]:
        """The passive joints (no actuator, no driver) in graph order: B1..Bn, C1..Cn for an n-RRR."""
        passive = set(self.graph.passive_joints)
        return tuple(j for j in self.graph.joints if j.name in passive)

    @property
    def clearance_joints(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if j.clearance)

    @property
    def ideal_joints(self) -> tuple[str, ...]:
        """Passive joints without clearance."""
        return tuple(j.name for j in self.joints if not j.clearance)

    def joint(self, name: str) -> JointSpec:
        return self.graph.joint(name)

    @property
    def torque_limit(self) -> tuple[float, ...]:
        """The actuators' effort limits [N m or N], symmetric +-, in graph order (an n-RRR's
        ``actuation.torque_limit``, a graph's ``actuators[].limit``): one source, the graph."""
        return tuple(a.limit for a in self.graph.actuators)

    def with_torque_limit(self, limits) -> Scene:
        """This scene with the actuators' effort limits replaced (one value for all, or one each)."""
        n = len(self.graph.actuators)
        values = [limits] * n if isinstance(limits, (int, float)) and not isinstance(limits, bool) else limits
        try:
            values = tuple(argument("torque_limit", v) for v in values)
        except TypeError:
            values = ()
        if len(values) != n:
            raise SceneError(f"torque_limit: {describe(limits)} is not allowed (one number > 0, or a list of {n})")
        acts = tuple(replace(a, limit=v) for a, v in zip(self.graph.actuators, values, strict=True))
        keys = ({"actuation.torque_limit": list(values)} if self.mechanism is not None else
                {f"mechanism.actuators[{i}].limit": v for i, v in enumerate(values)})
        return replace(self, graph=replace(self.graph, actuators=acts), data=self._with_data_values(keys))

    def with_time_table(self, rows) -> Scene:
        """This scene with its path followed by the time table `rows` (t [s], s, s_dot [1/s];
        checked as :func:`rrr4.scene.check_time_table` does): time_law 'table', the duration
        the table's. E.g. ``scene.with_time_table(law.table)`` for an optimal time law."""
        table = check_time_table(rows)
        data = self._with_data_values({"path.time_law": "table", "path.time_table": [list(r) for r in table],
                                       "path.duration": table[-1][0]})
        return replace(self, path=replace(self.path, time_law="table", time_table=table, duration=table[-1][0]),
                       data=data)

    def with_ideal_joints(self) -> Scene:
        """This scene with every joint ideal (the ideal twin of a clearance mechanism)."""
        return self.with_joints(tuple(replace(j, clearance=False) for j in self.graph.joints))

    def with_joints(self, joints) -> Scene:
        """This scene with joint specs replaced by `joints` (matched by name), e.g. to
        change which joints have clearance. The result holds no YAML data (joint specs have
        no one place in it), so :meth:`with_values` refuses it."""
        new = {j.name: j for j in joints}
        return replace(self, graph=replace(self.graph, joints=tuple(new.get(j.name, j) for j in self.graph.joints)),
                       data=None)


PASSIVE_JOINTS = ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")

