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
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from .errors import SceneError

__all__ = [
    "SceneError", "Scene", "Link", "Chain", "Platform", "Mechanism_", "Material",
    "JointSpec", "ContactEffect", "FrictionEffect", "Effects", "PreloadSettings",
    "Actuation", "PathSpec", "Initial", "IntegratorSettings", "load_scene",
    "parse_scene", "PASSIVE_JOINTS", "CONTACT_LAWS", "FRICTION_LAWS",
    "INTEGRATORS", "PRELOAD_METHODS", "QP_SOLVERS",
]



CONTACT_LAWS = ("hertz", "kelvin-voigt", "hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")
FRICTION_LAWS = ("none", "coulomb", "ambrosio", "smooth", "stribeck")
INTEGRATORS = ("bathe", "newmark", "generalized-alpha", "rk4", "erk", "rosenbrock", "cvodes",
               "idas", "rk45", "radau")
PRELOAD_METHODS = ("exact", "qp", "nlp")
QP_SOLVERS = ("qrqp", "osqp", "daqp", "qpoases")
PATH_TYPES = ("circle", "line", "waypoints")
TIME_LAWS = ("quintic", "cycloidal", "linear")
ACTUATION_MODES = ("torque", "prescribed", "free")  # free: zero actuator torque
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
    """A passive joint B_i or C_i. With clearance=False it is an ideal pin."""
    name: str
    clearance: bool
    journal_radius: float
    radial_clearance: float
    journal_material: Material
    bearing_material: Material

    @property
    def bearing_radius(self) -> float:
        return self.journal_radius + self.radial_clearance


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


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    mechanism: Mechanism_
    joints: tuple[JointSpec, ...]  # ordered B1..Bn, C1..Cn
    effects: Effects
    actuation: Actuation
    path: PathSpec
    initial: Initial
    integrator: IntegratorSettings
    source: str = field(default="", compare=False)

    @property
    def clearance_joints(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if j.clearance)

    @property
    def ideal_joints(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if not j.clearance)

    def joint(self, name: str) -> JointSpec:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)


PASSIVE_JOINTS = ("B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4")


# ----------------------------------------------------------------------------- reader

def _describe(v) -> str:
    s = repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


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

    def number(self, k, default=None, *, positive=False, nonneg=False, lo=None, hi=None,
               lo_open=False, hi_open=False):
        v = self.raw(k, default)
        key = self.key(k)
        if v is None:
            raise SceneError(f"{key}: missing (a number is required)")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SceneError(f"{key}: {_describe(v)} is not a number")
        v = float(v)
        if not math.isfinite(v):
            raise SceneError(f"{key}: {v} is not finite (a finite number is required)")
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
        if scalar_ok and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v] * n
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise SceneError(f"{key}: {_describe(v)} is not allowed (a list of {n} numbers is required)")
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise SceneError(f"{key}[{i}]: {_describe(x)} is not a finite number")
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
        if v not in allowed:
            near = difflib.get_close_matches(str(v), allowed, n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise SceneError(f"{self.key(k)}: unknown value {_describe(v)} "
                             f"(choose one of: {', '.join(allowed)}){hint}")
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
    sec.done()
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
    m = Material("custom", s.number("youngs_modulus", positive=True),
                 s.number("poisson_ratio", lo=0.0, hi=0.5, hi_open=True))
    s.done()
    return Material(s.data.get("name", "custom"), m.youngs_modulus, m.poisson_ratio)


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
            near = difflib.get_close_matches(str(j), names, n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise SceneError(f"{sec.key('clearance')}: unknown joint {_describe(j)} "
                             f"(choose from: {', '.join(names)}){hint}")
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
            near = difflib.get_close_matches(str(j), names, n=1)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            raise SceneError(f"{sec.key('per_joint')}.{j}: unknown joint (choose from: {', '.join(names)}){hint}")
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


def _effects(sec: _Section) -> Effects:
    c = sec.section("contact")
    law = c.choice("law", CONTACT_LAWS, "lankarani-nikravesh")
    cr = c.number("restitution", 0.9, lo=0.0, hi=1.0, lo_open=True)
    exponent = c.number("exponent", 1.0 if law == "kelvin-voigt" else 1.5, positive=True)
    k = c.raw("stiffness", "auto")
    if k == "auto" or k is None:
        stiffness = None
    else:
        stiffness = c.number("stiffness", positive=True)
    damping = c.number("damping", 0.0, nonneg=True)
    c.done()
    f = sec.section("friction")
    flaw = f.choice("law", FRICTION_LAWS, "none")
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


def _actuation(sec: _Section, n: int) -> Actuation:
    mode = sec.choice("mode", ACTUATION_MODES, "torque")
    limits = sec.vector("torque_limit", n, 1e3, scalar_ok=True)
    for i, v in enumerate(limits):
        if v <= 0:
            raise SceneError(f"{sec.key('torque_limit')}[{i}]: {v:g} N m is not allowed (must be > 0)")
    p = sec.section("preload")
    method = p.choice("method", PRELOAD_METHODS, "exact")
    fmin = p.number("min_force", nonneg=True, default=5.0)
    weights = p.vector("weights", n, 1.0, scalar_ok=True)
    for i, v in enumerate(weights):
        if v <= 0:
            raise SceneError(f"{p.key('weights')}[{i}]: {v:g} is not allowed (must be > 0)")
    qp = p.choice("qp_solver", QP_SOLVERS, "qrqp")
    smooth = p.number("smoothness_weight", 1e-4, nonneg=True)
    turn = p.number("max_turn_rate", 50.0, positive=True)
    p.done()
    gains = sec.section("gains")
    kp = gains.number("kp", 200.0, nonneg=True)
    kd = gains.number("kd", 5.0, nonneg=True)
    gains.done()
    sec.done()
    return Actuation(mode, limits, PreloadSettings(method, fmin, weights, qp, smooth, turn), kp, kd)


def _path(sec: _Section) -> PathSpec:
    kind = sec.choice("type", PATH_TYPES)
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
        method=sec.choice("method", INTEGRATORS, "bathe"),
        step=sec.number("step", 1e-5, positive=True),
        rtol=sec.number("rtol", 1e-8, positive=True),
        atol=sec.number("atol", 1e-10, positive=True),
        gamma=sec.number("gamma", 0.5, lo=0.0, hi=1.0, lo_open=True, hi_open=True),
        rho_inf=sec.number("rho_inf", 0.0, lo=0.0, hi=1.0),
        newton_tol=sec.number("newton_tol", 1e-10, positive=True),
        max_newton=sec.integer("max_newton", 20, positive=True),
        refine=sec.integer("refine", 1, positive=True),
    )
    sec.done()
    return s


def _initial(sec: _Section) -> Initial:
    v = Initial(sec.vector("platform_velocity", 3, [0.0, 0.0, 0.0]),
                sec.choice("journals", ("centred", "seated"), "centred"))
    sec.done()
    return v


def parse_scene(data, name: str = "scene", source: str = "", check_path: bool = True) -> Scene:
    """Build a :class:`Scene` from a parsed YAML mapping (raises SceneError)."""
    top = _Section(data, "")
    mech = _mechanism(top.section("mechanism"))
    scene = Scene(
        name=top.string("name", name),
        description=top.string("description", ""),
        mechanism=mech,
        joints=_joints(top.section("joints"), mech.n_chains),
        effects=_effects(top.section("effects")),
        actuation=_actuation(top.section("actuation"), mech.n_chains),
        path=_path(top.section("path")),
        initial=_initial(top.section("initial")),
        integrator=_integrator(top.section("integrator")),
        source=source,
    )
    top.done()
    if check_path:
        from .mechanism.workspace import check_path as _check
        _check(scene)
    return scene


def load_scene(path) -> Scene:
    """Read and validate a YAML scene file. Raises :class:`SceneError`."""
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"scene file '{path}' does not exist")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise SceneError(f"{path}: not valid YAML{where} ({getattr(e, 'problem', e)})") from None
    return parse_scene(data, name=p.stem, source=str(p))
