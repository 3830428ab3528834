"""Scenes: YAML files read into frozen dataclasses, validated once.

Every problem in a scene raises :class:`SceneError` with the key path, the bad
value and what is allowed, e.g.
``SceneError: effects.contact.law: unknown value 'lankarani' (choose one of: ...)``.
All quantities are SI (m, kg, s, rad, N, N m) unless a key says otherwise
(``*_deg`` keys are in degrees).
"""

from __future__ import annotations

import difflib
import math
import reprlib
from dataclasses import dataclass, field, replace
from pathlib import Path

import yaml

from .errors import SceneError

__all__ = [
    "SceneError", "Scene", "Link", "Chain", "Platform", "Mechanism_", "Material",
    "JointSpec", "ContactEffect", "FrictionEffect", "Effects", "PreloadSettings",
    "Actuation", "PathSpec", "Initial", "IntegratorSettings", "read_scene",
    "parse_scene", "PASSIVE_JOINTS", "Body", "ActuatorSpec", "DriverSpec", "Graph", "GROUND", "choices",
    "expand_nrrr",
]



PATH_TYPES = ("circle", "line", "waypoints", "none")  # none: no task, the drivers set the motion
TIME_LAWS = ("quintic", "cycloidal", "linear")
ACTUATION_MODES = ("torque", "prescribed", "free")  # free: zero actuator torque
MECHANISM_KINDS = ("n-rrr", "graph")
JOINT_TYPES = ("revolute", "prismatic")
GROUND = "ground"


def choices(what: str) -> tuple[str, ...]:
    """The allowed names of a registry, read from the registry itself: 'contact law',
    'friction law', 'integrator', 'error control' (the methods integrator.tolerance applies to),
    'newton', 'coordinates', 'preload method', 'compensation' or 'qp solver'. Imported when a scene is parsed
    (the registries' modules import this one)."""
    if what == "contact law":
        from .contact.normal import NORMAL_LAWS
        return tuple(NORMAL_LAWS)
    if what == "friction law":
        from .contact.friction import FRICTION_LAWS
        return ("none", *FRICTION_LAWS)
    if what == "integrator":
        from .integrators import METHODS
        return tuple(METHODS)
    if what == "error control":  # the methods integrator.tolerance applies to
        from .integrators import METHODS
        from .integrators.implicit import ImplicitIntegrator
        return tuple(k for k, m in METHODS.items() if issubclass(m, ImplicitIntegrator))
    if what == "coordinates":
        from .mechanism.tree import COORDINATES
        return COORDINATES
    if what == "newton":
        from .integrators.implicit import NEWTON
        return NEWTON
    if what == "preload method":
        from .preload.solve import PRELOAD_METHODS
        return ("none", *PRELOAD_METHODS)
    if what == "compensation":
        from .control import COMPENSATIONS
        return COMPENSATIONS
    if what == "qp solver":
        from .preload.qp import QP_OPTIONS
        return tuple(QP_OPTIONS)
    raise KeyError(what)


MATERIALS = {  # name: (Young's modulus [Pa], Poisson ratio)
    "steel": (207e9, 0.3),
    "aluminium": (70e9, 0.33),
    "bronze": (110e9, 0.34),
    "brass": (100e9, 0.34),
}


# ----------------------------------------------------------------------------- dataclasses

@dataclass(frozen=True)
class Link:
    """A slender link; centre of mass at mid-length. length [m], mass [kg], inertia [kg m^2] about the CoM."""
    length: float
    mass: float
    inertia: float


@dataclass(frozen=True)
class Chain:
    """One RRR chain A_i B_i C_i.

    base: (2,) position of A_i [m]; attachment_radius: |C_i - o| [m] (= 0.5 l_i3);
    attachment_angle: angle of C_i in the platform frame [rad];
    working_mode: +1 for the "+acos" branch, -1 for "-acos".
    """
    name: str
    base: tuple[float, float]
    driving: Link
    following: Link
    attachment_radius: float
    attachment_angle: float
    working_mode: int


@dataclass(frozen=True)
class Platform:
    mass: float
    inertia: float


@dataclass(frozen=True)
class Mechanism_:
    """Mechanism data of a scene (the symbolic model is :class:`rrr4.Mechanism`)."""
    platform: Platform
    chains: tuple[Chain, ...]

    @property
    def n_chains(self) -> int:
        return len(self.chains)


@dataclass(frozen=True)
class Material:
    name: str
    youngs_modulus: float
    poisson_ratio: float


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
    journal_radius: float
    radial_clearance: float
    journal_material: Material
    bearing_material: Material
    type: str = "revolute"
    bodies: tuple[str, str] = (GROUND, GROUND)
    points: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    axis: tuple[float, float] = (1.0, 0.0)
    angle: float = 0.0
    journal: int = 1

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
    mass: float
    inertia: float
    points: tuple[tuple[str, tuple[float, float]], ...] = ()
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ActuatorSpec:
    """An actuator on a joint: a torque [N m] on a revolute, a force [N] on a prismatic,
    limited to +-limit."""
    name: str
    joint: str
    limit: float


@dataclass(frozen=True)
class DriverSpec:
    """A joint coordinate prescribed in time: initial + speed t [rad or m, rad/s or m/s]."""
    name: str
    joint: str
    initial: float
    speed: float


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
    law: str
    restitution: float
    exponent: float
    stiffness: float | None
    damping: float


@dataclass(frozen=True)
class FrictionEffect:
    law: str
    coefficient: float
    static_coefficient: float
    v0: float
    v1: float
    stribeck_velocity: float


@dataclass(frozen=True)
class Effects:
    contact: ContactEffect
    friction: FrictionEffect
    gravity: tuple[float, float]


@dataclass(frozen=True)
class PreloadSettings:
    """min_force [N] at every passive joint; weights of the torque norm; NLP terms."""
    method: str
    min_force: float
    weights: tuple[float, ...]
    qp_solver: str
    smoothness_weight: float
    max_turn_rate: float  # [rad/s] of the contact-force direction in each bearing


@dataclass(frozen=True)
class Actuation:
    mode: str
    torque_limit: tuple[float, ...]  # [N m] per actuator, symmetric +-
    preload: PreloadSettings
    kp: float  # [N m/rad]
    kd: float  # [N m s/rad]
    control_rate: float | None = None  # [Hz] sampled controller (zero-order hold); None: continuous
    compensation: str = "none"         # 'clearance': references closed around the predicted journal seats


@dataclass(frozen=True)
class PathSpec:
    """Platform path; geometry in m/rad, duration [s], sample_rate [Hz]."""
    type: str
    duration: float
    time_law: str
    sample_rate: float
    orientation: float = 0.0
    center: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0
    start_angle: float = 0.0
    revolutions: float = 1.0
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    end: tuple[float, float, float] = (0.0, 0.0, 0.0)
    points: tuple[tuple[float, float, float], ...] = ()
    max_condition_number: float = 1.0e3
    min_transmission: float = 0.05


@dataclass(frozen=True)
class Initial:
    """Initial state. platform_velocity [m/s, m/s, rad/s] is added to the path's own start
    velocity. journals: 'centred' starts every journal at its bearing centre; 'seated'
    starts each clearance journal pressed against its bearing wall under the joint's
    initial load (direction and Hertzian penetration from the ideal reaction at t = 0)."""
    platform_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    journals: str = "centred"


@dataclass(frozen=True)
class IntegratorSettings:
    method: str
    step: float  # [s] fixed step, or initial step of adaptive methods
    rtol: float
    atol: float
    gamma: float
    rho_inf: float
    newton_tol: float
    max_newton: int
    refine: int = 1  # sub-steps that re-take a fixed step across a contact onset or loss (1: off)
    newton: str = "simplified"  # implicit methods: reuse the iteration matrix's factors, or 'full'
    tolerance: float | None = None  # [m] implicit methods: local position error per step (adaptive); None: fixed step
    coordinates: str = "auto"  # what the integrator steps: tree coordinates ('auto': wherever a tree exists) or not


@dataclass(frozen=True)
class Scene:
    """A validated scene. mechanism: the compact n-RRR form (None for a graph scene);
    graph: the body/joint graph every scene has (an n-RRR expands into it)."""
    name: str
    description: str
    mechanism: Mechanism_ | None
    graph: Graph
    effects: Effects
    actuation: Actuation
    path: PathSpec
    initial: Initial
    integrator: IntegratorSettings
    source: str = field(default="", compare=False)

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

    def with_joints(self, joints) -> Scene:
        """This scene with joint specs replaced by `joints` (matched by name), e.g. to
        change which joints have clearance."""
        new = {j.name: j for j in joints}
        return replace(self, graph=replace(self.graph, joints=tuple(new.get(j.name, j) for j in self.graph.joints)))


PASSIVE_JOINTS = ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")


# ----------------------------------------------------------------------------- reader

_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 2, 4, 4, 50, 50

# largest magnitude a scene number may have (SI units); larger is a unit mistake or an
# overflow waiting to happen. Material and contact stiffnesses may go up to BIG.
MAX_MAGNITUDE, BIG = 1e6, 1e15
# most path samples / output frames a scene may ask for (each frame holds the full state)
MAX_SAMPLES = 5_000_000


def describe(v) -> str:
    """A bounded rendering of a scene value for messages (never expands a huge or shared
    structure, such as a YAML alias bomb)."""
    s = _REPR.repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


_describe = describe


class _Section:
    """Reads one mapping of the YAML; remembers which keys were used; rejects unknown ones."""

    def __init__(self, data, path: str):
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise SceneError(f"{path or '<scene>'}: expected a mapping, got {_describe(data)}")
        self.data, self.path, self.used = data, path, set()

    def key(self, k: str) -> str:
        return f"{self.path}.{k}" if self.path else k

    def has(self, k: str) -> bool:
        return k in self.data

    def raw(self, k, default=None):
        self.used.add(k)
        return self.data.get(k, default)

    def section(self, k: str) -> _Section:
        return _Section(self.raw(k), self.key(k))

    def missing(self, k: str, what: str) -> SceneError:
        """The error for a required key that is absent, with the section's nearest key when
        that looks like a misspelling of it."""
        near = difflib.get_close_matches(k, [str(x) for x in self.data if x != k], n=1, cutoff=0.6)
        hint = f"; this section has '{near[0]}': a misspelling of '{k}'?" if near else ""
        return SceneError(f"{self.key(k)}: missing ({what} is required){hint}")

    def number(self, k, default=None, *, positive=False, nonneg=False, lo=None, hi=None,
               lo_open=False, hi_open=False, big=False):
        v = self.raw(k, default)
        key = self.key(k)
        if v is None:
            raise self.missing(k, "a number")
        if isinstance(v, str) and _looks_numeric(v):
            raise SceneError(f"{key}: {_describe(v)} is text, not a number (YAML reads a number in exponent "
                             f"form only with a dot: write {_with_dot(v)})")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{key}: {_describe(v)} is not a number")
        v = float(v)
        if not math.isfinite(v):
            raise SceneError(f"{key}: {v} is not finite (a finite number is required)")
        cap = BIG if big else MAX_MAGNITUDE
        if abs(v) > cap:
            raise SceneError(f"{key}: {v:g} is not allowed (|value| <= {cap:g} in SI units)")
        if positive and v <= 0:
            raise SceneError(f"{key}: {v:g} is not allowed (must be > 0)")
        if nonneg and v < 0:
            raise SceneError(f"{key}: {v:g} is not allowed (must be >= 0)")
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise SceneError(f"{key}: {v:g} is out of range (allowed: {_interval(lo, hi, lo_open, hi_open)})")
        if hi is not None and (v > hi or (hi_open and v == hi)):
            raise SceneError(f"{key}: {v:g} is out of range (allowed: {_interval(lo, hi, lo_open, hi_open)})")
        return v

    def integer(self, k, default=None, *, positive=False):
        v = self.raw(k, default)
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{self.key(k)}: {_describe(v)} is not an integer")
        if positive and v <= 0:
            raise SceneError(f"{self.key(k)}: {v} is not allowed (must be > 0)")
        return v

    def vector(self, k, n, default=None, *, scalar_ok=False):
        v = self.raw(k, default)
        key = self.key(k)
        if v is None:
            raise self.missing(k, f"a list of {n} numbers")
        if scalar_ok and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v] * n
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise SceneError(f"{key}: {_describe(v)} is not allowed (a list of {n} numbers is required)")
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise SceneError(f"{key}[{i}]: {_describe(x)} is not a finite number")
            if abs(x) > MAX_MAGNITUDE:
                raise SceneError(f"{key}[{i}]: {x:g} is not allowed (|value| <= {MAX_MAGNITUDE:g} in SI units)")
            out.append(float(x))
        return tuple(out)

    def string(self, k, default=None):
        v = self.raw(k, default)
        if not isinstance(v, str):
            raise SceneError(f"{self.key(k)}: {_describe(v)} is not a string")
        return v

    def choice(self, k, allowed, default=None):
        v = self.raw(k, default)
        v = v.lower() if isinstance(v, str) else v
        if v is None:
            raise SceneError(f"{self.key(k)}: missing (choose one of: {', '.join(allowed)})")
        if v not in allowed:
            raise unknown_value(self.key(k), "value", v, allowed)
        return v

    def done(self, allowed=None):
        allowed = sorted(set(allowed or ()) | self.used)
        for k in self.data:
            if k not in allowed:
                near = difflib.get_close_matches(str(k), allowed, n=1)
                hint = f"did you mean '{near[0]}'? " if near else ""
                raise SceneError(f"{self.key(str(k))}: unknown key ({hint}"
                                 f"allowed keys: {', '.join(allowed)})")


def _interval(lo, hi, lo_open, hi_open):
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    return f"{left}{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}{right}"


# ----------------------------------------------------------------------------- sections

def _link(sec: _Section, defaults: dict | None, defaults_path: str) -> Link:
    """A link's keys come from the chain's own entry, else from chain_defaults;
    errors name the key where the value was written."""
    dsec = _Section(defaults, defaults_path)

    def get(k, default=None):
        src = sec if sec.has(k) else dsec
        return src.number(k, default, positive=True)

    length, mass = get("length"), get("mass")
    inertia = get("inertia", mass * length**2 / 12.0)
    sec.done(["length", "mass", "inertia"])
    dsec.done(["length", "mass", "inertia"])
    return Link(length, mass, inertia)


def _mechanism(sec: _Section) -> Mechanism_:
    psec = sec.section("platform")
    platform = Platform(psec.number("mass", positive=True), psec.number("inertia", positive=True))
    psec.done()
    defaults = sec.raw("chain_defaults", {}) or {}
    if not isinstance(defaults, dict):
        raise SceneError(f"{sec.key('chain_defaults')}: expected a mapping, got {_describe(defaults)}")
    dsec = _Section(defaults, sec.key("chain_defaults"))
    dsec.done(["driving_link", "following_link", "attachment_radius", "working_mode"])
    raw_chains = sec.raw("chains")
    if not isinstance(raw_chains, list) or not 3 <= len(raw_chains) <= 4:
        raise SceneError(f"{sec.key('chains')}: {_describe(raw_chains)} is not allowed "
                         "(a list of 3 or 4 chains is required)")
    chains = []
    for i, raw in enumerate(raw_chains):
        c = _Section(raw, f"{sec.key('chains')}[{i}]")
        name = str(i + 1)
        base = c.vector("base", 2)
        links = [_link(c.section(k), defaults.get(k), dsec.key(k)) for k in ("driving_link", "following_link")]
        radius_default = defaults.get("attachment_radius")
        r = c.number("attachment_radius", radius_default, positive=True)
        ang = math.radians(c.number("attachment_angle_deg"))
        mode_raw = c.raw("working_mode", defaults.get("working_mode", "+"))
        if mode_raw not in ("+", "-", "+acos", "-acos", 1, -1):
            raise SceneError(f"{c.key('working_mode')}: unknown value {_describe(mode_raw)} "
                             "(choose one of: '+', '-')")
        mode = -1 if mode_raw in ("-", "-acos", -1) else 1
        c.done()
        chains.append(Chain(name, base, *links, r, ang, mode))
    sec.done(["kind"])
    return Mechanism_(platform, tuple(chains))


def _material(v, key) -> Material:
    if isinstance(v, str):
        name = v.lower()
        if name not in MATERIALS:
            near = difflib.get_close_matches(name, list(MATERIALS), n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise SceneError(f"{key}: unknown material {_describe(v)} "
                             f"(choose one of: {', '.join(MATERIALS)}, or give youngs_modulus and poisson_ratio){hint}")
        return Material(name, *MATERIALS[name])
    s = _Section(v, key)
    m = Material(s.string("name", "custom"), s.number("youngs_modulus", positive=True, big=True),
                 s.number("poisson_ratio", lo=0.0, hi=0.5, hi_open=True))
    s.done()
    return m


def _joints(sec: _Section, n_chains: int) -> tuple[JointSpec, ...]:
    names = tuple(f"B{i}" for i in range(1, n_chains + 1)) + tuple(f"C{i}" for i in range(1, n_chains + 1))
    cl = sec.raw("clearance", [])
    if cl == "all":
        cl = list(names)
    if cl in (None, "none"):
        cl = []
    if not isinstance(cl, list):
        raise SceneError(f"{sec.key('clearance')}: {_describe(cl)} is not allowed "
                         f"(a list of joint names from {', '.join(names)}, 'all' or 'none')")
    for j in cl:
        if j not in names:
            raise unknown_value(sec.key("clearance"), "joint", j, names)
    if len(set(cl)) != len(cl):
        raise SceneError(f"{sec.key('clearance')}: {_describe(cl)} names a joint twice")
    base = {
        "journal_radius": sec.raw("journal_radius", 0.005),
        "radial_clearance": sec.raw("radial_clearance", 1e-4),
        "journal_material": sec.raw("journal_material", "steel"),
        "bearing_material": sec.raw("bearing_material", "steel"),
    }
    per = sec.raw("per_joint", {}) or {}
    if not isinstance(per, dict):
        raise SceneError(f"{sec.key('per_joint')}: expected a mapping of joint name to settings")
    for j in per:
        if j not in names:
            raise unknown_value(f"{sec.key('per_joint')}.{j}", "joint", j, names)
    out = []
    for name in names:
        has_own = name in per
        merged = dict(base)
        merged.update(per.get(name) or {})
        key = sec.key(f"per_joint.{name}") if has_own else sec.path
        s = _Section(merged, key)
        rj = s.number("journal_radius", positive=True)
        c = s.number("radial_clearance", positive=True)
        if c >= rj:
            raise SceneError(f"{s.key('radial_clearance')}: {c:g} m is not allowed "
                             f"(must be smaller than the journal radius {rj:g} m)")
        mj = _material(s.raw("journal_material"), s.key("journal_material"))
        mb = _material(s.raw("bearing_material"), s.key("bearing_material"))
        s.done()
        out.append(JointSpec(name, name in cl, rj, c, mj, mb))
    sec.done()
    return tuple(out)


# ----------------------------------------------------------------------------- the graph

def unknown_value(key: str, what: str, v, allowed) -> SceneError:
    """The one-line error for a value outside `allowed`, with the nearest choice (ignoring
    case first, then by spelling) as a did-you-mean."""
    allowed = [str(a) for a in allowed]
    same = [a for a in allowed if a.lower() == str(v).lower()]
    near = same or difflib.get_close_matches(str(v), allowed, n=1) or \
        difflib.get_close_matches(str(v).lower(), [a.lower() for a in allowed], n=1)
    hint = f"; did you mean '{near[0]}'?" if near else ""
    return SceneError(f"{key}: unknown {what} {_describe(v)} (choose one of: {', '.join(allowed)}){hint}")


_unknown = unknown_value


def argument(key: str, v, *, positive: bool = True, allow_zero: bool = False) -> float:
    """An API argument as a finite float (> 0 by default; >= 0 with allow_zero), or a
    one-line SceneError naming it."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise SceneError(f"{key}: {_describe(v)} is not allowed (a number is required)") from None
    if not math.isfinite(x) or (positive and not (x > 0 or (allow_zero and x == 0))):
        rule = ">= 0" if allow_zero else "> 0"
        raise SceneError(f"{key}: {_describe(v)} is not allowed (must be a finite number {rule})")
    return x


def _name(sec: _Section, k: str = "name", default=None) -> str:
    v = sec.raw(k, default)
    if not isinstance(v, str) or not v.strip() or not all(ch.isalnum() or ch in "_-" for ch in v):
        raise SceneError(f"{sec.key(k)}: {_describe(v)} is not allowed (a name of letters, digits, '_' and '-')")
    return v


def _points(sec: _Section, k: str) -> tuple[tuple[str, tuple[float, float]], ...]:
    raw = sec.raw(k, {}) or {}
    if not isinstance(raw, dict):
        raise SceneError(f"{sec.key(k)}: expected a mapping of point name to [x, y] in m, got {_describe(raw)}")
    ps = _Section(raw, sec.key(k))
    return tuple((str(name), ps.vector(name, 2)) for name in raw)


def _clearance(v, key: str, bodies: tuple[str, str]) -> dict:
    s = _Section(v, key)
    journal = s.raw("journal", bodies[1])
    if journal not in bodies or journal == GROUND:
        raise _unknown(s.key("journal"), "body", journal, [b for b in bodies if b != GROUND])
    rj = s.number("journal_radius", positive=True)
    c = s.number("radial_clearance", positive=True)
    if c >= rj:
        raise SceneError(f"{s.key('radial_clearance')}: {c:g} m is not allowed "
                         f"(must be smaller than the journal radius {rj:g} m)")
    out = {"clearance": True, "journal_radius": rj, "radial_clearance": c, "journal": bodies.index(journal),
           "journal_material": _material(s.raw("journal_material", "steel"), s.key("journal_material")),
           "bearing_material": _material(s.raw("bearing_material", "steel"), s.key("bearing_material"))}
    s.done()
    return out


def _graph(sec: _Section) -> Graph:
    ground = dict(_points(sec.section("ground"), "points"))
    sec.section("ground").done(["points"])
    raw_bodies = sec.raw("bodies")
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise SceneError(f"{sec.key('bodies')}: {_describe(raw_bodies)} is not allowed (a list of bodies is required)")
    bodies, points = [], {GROUND: ground}
    for i, raw in enumerate(raw_bodies):
        b = _Section(raw, f"{sec.key('bodies')}[{i}]")
        name = _name(b)
        if name in points:
            raise SceneError(f"{b.key('name')}: {name!r} is not allowed (names a body twice, or the ground)")
        pts = _points(b, "points")
        bodies.append(Body(name, b.number("mass", positive=True), b.number("inertia", positive=True), pts,
                           b.vector("pose", 3, [0.0, 0.0, 0.0])))
        points[name] = dict(pts)
        b.done()
    names = [GROUND] + [b.name for b in bodies]

    raw_joints = sec.raw("joints")
    if not isinstance(raw_joints, list) or not raw_joints:
        raise SceneError(f"{sec.key('joints')}: {_describe(raw_joints)} is not allowed (a list of joints is required)")
    joints, used = [], set()
    for i, raw in enumerate(raw_joints):
        j = _Section(raw, f"{sec.key('joints')}[{i}]")
        name = _name(j)
        if any(x.name == name for x in joints):
            raise SceneError(f"{j.key('name')}: {name!r} names a joint twice")
        kind = j.choice("type", JOINT_TYPES, "revolute")
        pair = j.raw("bodies")
        if not isinstance(pair, list) or len(pair) != 2:
            raise SceneError(f"{j.key('bodies')}: {_describe(pair)} is not allowed (a list of two body names)")
        for b in pair:
            if b not in names:
                raise _unknown(j.key("bodies"), "body", b, names)
        if pair[0] == pair[1]:
            raise SceneError(f"{j.key('bodies')}: {_describe(pair)} is not allowed (two different bodies)")
        raw_pts = j.raw("points", [[0.0, 0.0], [0.0, 0.0]])
        if not isinstance(raw_pts, list) or len(raw_pts) != 2:
            raise SceneError(f"{j.key('points')}: {_describe(raw_pts)} is not allowed "
                             "(two points, one per body: a point name or [x, y] in m)")
        pts = []
        for k, (b, pt) in enumerate(zip(pair, raw_pts, strict=True)):
            if isinstance(pt, str):
                if pt not in points[b]:
                    raise _unknown(f"{j.key('points')}[{k}]", f"point of {b}", pt, list(points[b]) or ["(none)"])
                pts.append(points[b][pt])
            else:
                pts.append(_Section({"p": pt}, f"{j.key('points')}[{k}]").vector("p", 2))
        extra = {}
        if kind == "prismatic":
            axis = j.vector("axis", 2, [1.0, 0.0])
            norm = math.hypot(*axis)
            if not norm > 1e-12:
                raise SceneError(f"{j.key('axis')}: {list(axis)} is not allowed (a direction of non-zero length)")
            extra = {"axis": (axis[0] / norm, axis[1] / norm), "angle": math.radians(j.number("angle_deg", 0.0))}
            if j.has("clearance"):
                raise SceneError(f"{j.key('clearance')}: not allowed on a prismatic joint (revolute clearance only)")
        cl = {"clearance": False, "journal_radius": 0.005, "radial_clearance": 1e-4,
              "journal_material": Material("steel", *MATERIALS["steel"]),
              "bearing_material": Material("steel", *MATERIALS["steel"])}
        if kind == "revolute" and j.raw("clearance") is not None:
            cl.update(_clearance(j.raw("clearance"), j.key("clearance"), tuple(pair)))
        j.done()
        joints.append(JointSpec(name, type=kind, bodies=tuple(pair), points=tuple(pts), **cl, **extra))
        used.update(pair)
    for b in bodies:
        if b.name not in used:
            raise SceneError(f"{sec.key('bodies')}: body {b.name!r} is not allowed (it has no joint: "
                             "every body must be connected)")
    jnames = [x.name for x in joints]

    def refs(k: str, what: str):
        raw = sec.raw(k, []) or []
        if not isinstance(raw, list):
            raise SceneError(f"{sec.key(k)}: {_describe(raw)} is not allowed (a list of {what})")
        for i, r in enumerate(raw):
            e = _Section(r, f"{sec.key(k)}[{i}]")
            joint = e.raw("joint")
            if joint not in jnames:
                raise _unknown(e.key("joint"), "joint", joint, jnames)
            yield e, joint

    actuators = []
    for e, joint in refs("actuators", "actuators"):
        actuators.append(ActuatorSpec(_name(e, default=joint), joint, e.number("limit", positive=True)))
        e.done()
    drivers = []
    for e, joint in refs("drivers", "drivers"):
        jt = joints[jnames.index(joint)]
        if e.has("speed_rpm"):
            speed = e.number("speed_rpm") * 2 * math.pi / 60
            if jt.type != "revolute":
                raise SceneError(f"{e.key('speed_rpm')}: not allowed on a prismatic joint (give speed in m/s)")
        else:
            speed = e.number("speed")
        initial = math.radians(e.number("initial_deg", 0.0)) if jt.type == "revolute" else e.number("initial", 0.0)
        drivers.append(DriverSpec(_name(e, default=joint), joint, initial, speed))
        e.done()
    seen: dict[str, str] = {}
    for key, items in (("actuators", actuators), ("drivers", drivers)):
        for i, x in enumerate(items):
            if x.name in seen:
                raise SceneError(f"{sec.key(key)}[{i}].name: {x.name!r} is not allowed (already the name of "
                                 f"{seen[x.name]}; actuator and driver names must be unique)")
            seen[x.name] = f"{sec.key(key)}[{i}]"
    busy = [a.joint for a in actuators] + [d.joint for d in drivers]
    for j in joints:
        if busy.count(j.name) > 1:
            raise SceneError(f"{sec.key('actuators')}: joint {j.name!r} is not allowed to carry more than one "
                             "actuator or driver")
        if j.clearance and j.name in busy:
            raise SceneError(f"{sec.key('joints')}: joint {j.name!r} has clearance and an actuator or driver "
                             "(clearance is allowed on passive joints only)")
    task, task_point = sec.raw("task"), None
    if isinstance(task, dict):  # a point of a body: {body: name, point: name or [x, y]}
        t = _Section(task, sec.key("task"))
        body, pt = t.raw("body"), t.raw("point")
        if body not in names[1:]:
            raise _unknown(t.key("body"), "body", body, names[1:])
        if isinstance(pt, str):
            if pt not in points[body]:
                raise _unknown(t.key("point"), f"point of {body}", pt, list(points[body]) or ["(none)"])
            task_point = points[body][pt]
        else:
            task_point = t.vector("point", 2)
        t.done()
        task = body
    elif task in (None, "none"):
        task = None
    elif task not in names[1:]:
        raise _unknown(sec.key("task"), "body", task, names[1:] + ["none"])
    sec.done()
    return Graph(tuple(bodies), tuple(joints), tuple(actuators), tuple(drivers), task, task_point)


def expand_nrrr(m: Mechanism_, joints: tuple[JointSpec, ...], torque_limit) -> Graph:
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


def _effects(sec: _Section) -> Effects:
    c = sec.section("contact")
    law = c.choice("law", choices("contact law"), "lankarani-nikravesh")
    cr = c.number("restitution", 0.9, lo=0.0, hi=1.0, lo_open=True)
    exponent = c.number("exponent", 1.0 if law == "kelvin-voigt" else 1.5, positive=True)
    k = c.raw("stiffness", "auto")
    if k == "auto" or k is None:
        stiffness = None
    else:
        stiffness = c.number("stiffness", positive=True, big=True)
    damping = c.number("damping", 0.0, nonneg=True)
    c.done()
    f = sec.section("friction")
    flaw = f.choice("law", choices("friction law"), "none")
    mu = f.number("coefficient", 0.0 if flaw == "none" else None, nonneg=True)
    mus = f.number("static_coefficient", mu, nonneg=True)
    v0 = f.number("v0", 1e-4, positive=True)
    v1 = f.number("v1", 2e-4, positive=True)
    if v1 <= v0:
        raise SceneError(f"{f.key('v1')}: {v1:g} m/s is not allowed (must be greater than v0 = {v0:g} m/s)")
    vs = f.number("stribeck_velocity", 1e-3, positive=True)
    f.done()
    g = sec.vector("gravity", 2, [0.0, 0.0])
    sec.done()
    return Effects(ContactEffect(law, cr, exponent, stiffness, damping),
                   FrictionEffect(flaw, mu, mus, v0, v1, vs), g)


def _actuation(sec: _Section, n: int, graph: Graph | None = None) -> Actuation:
    """n actuators; for a graph scene their limits come from mechanism.actuators, and the
    mode defaults to 'free' when there is no task to track."""
    if graph is None:
        mode = sec.choice("mode", ACTUATION_MODES, "torque")
        limits = sec.vector("torque_limit", n, 1e3, scalar_ok=True)
        for i, v in enumerate(limits):
            if v <= 0:
                raise SceneError(f"{sec.key('torque_limit')}[{i}]: {v:g} N m is not allowed (must be > 0)")
    else:
        mode = sec.choice("mode", ACTUATION_MODES, "torque" if graph.task and n else "free")
        if mode != "free" and (graph.task is None or n == 0):
            raise SceneError(f"{sec.key('mode')}: {mode!r} is not allowed without "
                             f"{'a task (mechanism.task)' if graph.task is None else 'actuators'} to track the "
                             "path (choose 'free'; drivers prescribe their joints in every mode)")
        dof = 3 if graph.task_point is None else 2
        if mode != "free" and n < dof:
            raise SceneError(f"{sec.key('mode')}: {mode!r} is not allowed with {n} actuator(s) for a task of {dof} "
                             f"degrees of freedom (the path cannot be tracked: give at least {dof} actuators, or "
                             "choose 'free')")
        limits = tuple(a.limit for a in graph.actuators)
    p = sec.section("preload")
    method = p.choice("method", choices("preload method"), "exact")
    fmin = p.number("min_force", nonneg=True, default=5.0)
    weights = p.vector("weights", n, 1.0, scalar_ok=True)
    for i, v in enumerate(weights):
        if v <= 0:
            raise SceneError(f"{p.key('weights')}[{i}]: {v:g} is not allowed (must be > 0)")
    qp = p.choice("qp_solver", choices("qp solver"), "qrqp")
    smooth = p.number("smoothness_weight", 1e-4, nonneg=True)
    turn = p.number("max_turn_rate", 50.0, positive=True)
    p.done()
    gains = sec.section("gains")
    kp = gains.number("kp", 200.0, nonneg=True)
    kd = gains.number("kd", 5.0, nonneg=True)
    gains.done()
    rate = sec.number("control_rate", positive=True) if sec.raw("control_rate") is not None else None
    compensation = sec.choice("compensation", choices("compensation"), "none")
    sec.done()
    return Actuation(mode, limits, PreloadSettings(method, fmin, weights, qp, smooth, turn), kp, kd, rate,
                     compensation)


def _path(sec: _Section, task: bool = True) -> PathSpec:
    kind = sec.choice("type", PATH_TYPES, None if task else "none")
    if (kind == "none") == task:
        raise SceneError(f"{sec.key('type')}: {kind!r} is not allowed "
                         + ("(the task body follows a path: circle, line or waypoints)" if task else
                            "(no task body: the drivers set the motion; use 'none' with duration and sample_rate)"))
    common = dict(
        type=kind,
        duration=sec.number("duration", positive=True),
        time_law=sec.choice("time_law", TIME_LAWS, "quintic"),
        sample_rate=sec.number("sample_rate", 1000.0, positive=True),
        max_condition_number=sec.number("max_condition_number", 1e3, lo=1.0, lo_open=True),
        min_transmission=sec.number("min_transmission", 0.05, lo=0.0, hi=1.0, hi_open=True),
    )
    if common["duration"] * common["sample_rate"] < 2:
        raise SceneError(f"{sec.key('sample_rate')}: {common['sample_rate']:g} Hz is too low "
                         f"(need at least 2 samples over duration {common['duration']:g} s)")
    if kind == "circle":
        spec = PathSpec(**common, center=sec.vector("center", 2), radius=sec.number("radius", positive=True),
                        start_angle=sec.number("start_angle", 0.0), revolutions=sec.number("revolutions", 1.0),
                        orientation=sec.number("orientation", 0.0))
    elif kind == "line":
        spec = PathSpec(**common, start=sec.vector("start", 3), end=sec.vector("end", 3))
    elif kind == "none":
        spec = PathSpec(**common)
    else:
        pts = sec.raw("points")
        if not isinstance(pts, list) or len(pts) < 2:
            raise SceneError(f"{sec.key('points')}: {_describe(pts)} is not allowed "
                             "(a list of at least 2 poses [x, y, theta] is required)")
        points = tuple(_Section({"p": p}, f"{sec.key('points')}[{i}]").vector("p", 3) for i, p in enumerate(pts))
        spec = PathSpec(**common, points=points)
    sec.done()
    return spec


def _integrator(sec: _Section) -> IntegratorSettings:
    s = IntegratorSettings(
        method=sec.choice("method", choices("integrator"), "bathe"),
        step=sec.number("step", 1e-5, positive=True),
        rtol=sec.number("rtol", 1e-8, positive=True),
        atol=sec.number("atol", 1e-10, positive=True),
        gamma=sec.number("gamma", 0.5, lo=0.0, hi=1.0, lo_open=True, hi_open=True),
        rho_inf=sec.number("rho_inf", 0.0, lo=0.0, hi=1.0),
        newton_tol=sec.number("newton_tol", 1e-10, positive=True),
        max_newton=sec.integer("max_newton", 20, positive=True),
        refine=sec.integer("refine", 1, positive=True),
        newton=sec.choice("newton", choices("newton"), "simplified"),
        tolerance=sec.number("tolerance", positive=True) if sec.raw("tolerance") is not None else None,
        coordinates=sec.choice("coordinates", choices("coordinates"), "auto"),
    )
    if s.tolerance is not None and s.method not in choices("error control"):
        raise SceneError(f"{sec.key('tolerance')}: {s.tolerance:g} is not allowed with method '{s.method}' (error "
                         f"control is for {', '.join(choices('error control'))}; the adaptive methods take rtol, atol)")
    sec.done()
    return s


def _initial(sec: _Section) -> Initial:
    v = Initial(sec.vector("platform_velocity", 3, [0.0, 0.0, 0.0]),
                sec.choice("journals", ("centred", "seated"), "centred"))
    sec.done()
    return v


def parse_scene(data, name: str = "scene", source: str = "") -> Scene:
    """Build a :class:`Scene` from a parsed YAML mapping (raises SceneError).

    Validates the data only; :func:`rrr4.load_scene` also checks the scene against its
    model (assembly, workspace, singularities)."""
    top = _Section(data, "")
    msec = top.section("mechanism")
    kind = msec.choice("kind", MECHANISM_KINDS, "n-rrr")
    if kind == "n-rrr":
        mech = _mechanism(msec)
        joints = _joints(top.section("joints"), mech.n_chains)
        actuation = _actuation(top.section("actuation"), mech.n_chains)
        graph = expand_nrrr(mech, joints, actuation.torque_limit)
    else:
        mech, graph = None, _graph(msec)
        if top.has("joints"):
            raise SceneError("joints: not allowed with mechanism.kind 'graph' (give each joint's clearance in "
                             "mechanism.joints)")
        actuation = _actuation(top.section("actuation"), len(graph.actuators), graph)
    scene = Scene(
        name=_name(top, "name", name),
        description=top.string("description", ""),
        mechanism=mech,
        graph=graph,
        effects=_effects(top.section("effects")),
        actuation=actuation,
        path=_path(top.section("path"), graph.task is not None),
        initial=_initial(top.section("initial")),
        integrator=_integrator(top.section("integrator")),
        source=source,
    )
    top.done()
    p = scene.path
    if p.duration * p.sample_rate > MAX_SAMPLES:
        raise SceneError(f"path.sample_rate: {p.sample_rate:g} Hz over {p.duration:g} s is not allowed (at most "
                         f"{MAX_SAMPLES:g} samples)")
    if scene.integrator.step > p.duration:
        raise SceneError(f"integrator.step: {scene.integrator.step:g} s is not allowed (must not exceed "
                         f"path.duration = {p.duration:g} s)")
    return scene


def _looks_numeric(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return v.strip().lower() not in ("nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity")


def _with_dot(v: str) -> str:
    m, _, e = v.strip().lower().partition("e")
    return f"{m if '.' in m else m + '.0'}e{e}" if e else v


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a mapping with a key given twice (PyYAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                hash(key)
            except TypeError:
                continue  # PyYAML reports unhashable keys itself
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {_describe(key)} appears twice (first at line {seen[key] + 1})",
                    key_node.start_mark)
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def read_yaml(path, what: str = "scene"):
    """The data of a YAML file (`what` names it in errors: 'scene', 'sweep spec'), with the
    file checks: it exists, is a regular UTF-8 text file, valid YAML, no key given twice, not
    empty. Raises :class:`SceneError`."""
    p = Path(path)
    if not p.exists():
        raise SceneError(f"{what} file '{path}' does not exist")
    if p.is_dir():
        raise SceneError(f"{what} file '{path}' is a directory (a YAML {what} file is required)")
    if not p.is_file():
        raise SceneError(f"{what} file '{path}' is not a regular file (a YAML {what} file is required)")
    try:
        raw = p.read_bytes()
    except OSError as e:
        raise SceneError(f"{what} file '{path}' cannot be read ({e.strerror})") from None
    if b"\0" in raw:
        raise SceneError(f"{what} file '{path}' is binary (a YAML text file is required)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise SceneError(f"{what} file '{path}' is not UTF-8 text (invalid byte at offset {e.start})") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise SceneError(f"{path}: not valid YAML{where} ({getattr(e, 'problem', e)})") from None
    if data is None:
        raise SceneError(f"{what} file '{path}' is empty (a {what} mapping is required"
                         + (": mechanism, path, ...)" if what == "scene" else ")"))
    return data


def read_scene(path) -> Scene:
    """Read and validate a YAML scene file (data only, see :func:`parse_scene`). Raises :class:`SceneError`."""
    p = Path(path)
    data = read_yaml(p)
    return parse_scene(data, name=p.stem, source=str(p))
