"""The scene reader: YAML files read into a validated :class:`~rrr4.scene.schema.Scene`.

Every problem raises :class:`SceneError` with the key path, the bad value and what is
allowed, e.g. ``SceneError: effects.contact.law: unknown value 'lankarani' (choose one of: ...)``.
All quantities are SI (m, kg, s, rad, N, N m) unless a key says otherwise (``*_deg`` keys
are in degrees).
"""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from ..checks import describe, unknown_value
from ..errors import SceneError
from ..files import read_text, shown
from .bearing import read_fit, read_material
from .data import with_data
from .field_specs import read_fields
from .fields import MAX_SAMPLES, Section
from .forces import read_forces
from .graph import read_graph
from .lubrication import read_lubrication
from .names import read_name
from .nrrr import expand_nrrr
from .schema import (
    Actuation,
    Chain,
    ContactEffect,
    Effects,
    FrictionEffect,
    Graph,
    Initial,
    IntegratorSettings,
    JointSpec,
    Link,
    NRRRSpec,
    PathSpec,
    Platform,
    PreloadSettings,
    Scene,
)
from .time_table import check_time_table, read_time_table
from .unused import check_joint_override, check_unused
from .vocabulary import (
    ACTUATION_MODES,
    CONTACT_LAW_KEYS,
    FRICTION_LAW_KEYS,
    MECHANISM_KINDS,
    choices,
)
from .wear import read_wear

__all__ = ["read_scene", "parse_scene", "read_yaml", "load_yaml", "MAX_BYTES", "MAX_DEPTH", "MAX_NODES"]


def _link(sec: Section, defaults: dict | None, defaults_path: str) -> Link:
    """A link's keys come from the chain's own entry, else from chain_defaults;
    errors name the key where the value was written."""
    dsec = Section(defaults, defaults_path)

    def get(k, default=None):
        src = sec if sec.has(k) else dsec
        return read_fields(src, Link, (k,), {k: default})[k]

    length, mass = get("length"), get("mass")
    inertia = get("inertia", mass * length**2 / 12.0)
    sec.done(["length", "mass", "inertia"])
    dsec.done(["length", "mass", "inertia"])
    return Link(length, mass, inertia)


def _mechanism(sec: Section) -> NRRRSpec:
    psec = sec.section("platform")
    platform = Platform(**read_fields(psec, Platform))
    psec.done()
    defaults = sec.raw("chain_defaults", {}) or {}
    if not isinstance(defaults, dict):
        raise SceneError(f"{sec.key('chain_defaults')}: expected a mapping, got {describe(defaults)}")
    dsec = Section(defaults, sec.key("chain_defaults"))
    dsec.done(["driving_link", "following_link", "attachment_radius", "working_mode"])
    raw_chains = sec.raw("chains")
    if not isinstance(raw_chains, list) or not 3 <= len(raw_chains) <= 4:
        raise SceneError(f"{sec.key('chains')}: {describe(raw_chains)} is not allowed "
                         "(a list of 3 or 4 chains is required)")
    chains = []
    for i, raw in enumerate(raw_chains):
        c = Section(raw, f"{sec.key('chains')}[{i}]")
        name = str(i + 1)
        base = read_fields(c, Chain, ("base",))["base"]
        links = [_link(c.section(k), defaults.get(k), dsec.key(k)) for k in ("driving_link", "following_link")]
        radius_default = defaults.get("attachment_radius")
        r = read_fields(c, Chain, ("attachment_radius",), {"attachment_radius": radius_default})["attachment_radius"]
        ang = math.radians(c.number("attachment_angle_deg"))
        mode_raw = c.raw("working_mode", defaults.get("working_mode", "+"))
        if mode_raw not in ("+", "-", "+acos", "-acos", 1, -1):
            raise SceneError(f"{c.key('working_mode')}: unknown value {describe(mode_raw)} "
                             "(choose one of: '+', '-')")
        mode = -1 if mode_raw in ("-", "-acos", -1) else 1
        c.done()
        chains.append(Chain(name, base, *links, r, ang, mode))
    sec.done(["kind"])
    return NRRRSpec(platform, tuple(chains))


def _joints(sec: Section, n_chains: int) -> tuple[JointSpec, ...]:
    names = tuple(f"B{i}" for i in range(1, n_chains + 1)) + tuple(f"C{i}" for i in range(1, n_chains + 1))
    cl = sec.raw("clearance", [])
    if cl == "all":
        cl = list(names)
    if cl in (None, "none"):
        cl = []
    if not isinstance(cl, list):
        raise SceneError(f"{sec.key('clearance')}: {describe(cl)} is not allowed "
                         f"(a list of joint names from {', '.join(names)}, 'all' or 'none')")
    for j in cl:
        if j not in names:
            raise unknown_value(sec.key("clearance"), "joint", j, names)
    if len(set(cl)) != len(cl):
        raise SceneError(f"{sec.key('clearance')}: {describe(cl)} names a joint twice")
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
        s = Section(merged, key)
        rj, c = read_fit(s)
        mj = read_material(s.raw("journal_material"), s.key("journal_material"))
        mb = read_material(s.raw("bearing_material"), s.key("bearing_material"))
        film = read_lubrication(s.raw("lubrication"), s.key("lubrication")) if s.has("lubrication") else None
        wear = read_wear(s.raw("wear"), s.key("wear")) if s.has("wear") else None
        check_joint_override(key, name, film, wear, cl)
        s.done()
        out.append(JointSpec(name, name in cl, rj, c, mj, mb, lubrication=film, wear=wear))
    sec.done()
    return tuple(out)


def _only_law_keys(sec: Section, law: str, keys_of: dict) -> None:
    """Refuse a key of `sec` that some law of `keys_of` uses but `law` does not (it would be
    accepted and ignored)."""
    takes = keys_of[law]
    others = {k for keys in keys_of.values() for k in keys} - set(takes)
    for k in sec.data:
        if k in others:
            raise SceneError(f"{sec.key(k)}: not used by law '{law}' (it takes: {', '.join(('law', *takes))}); "
                             "remove it or choose a law that uses it")


def _contact(c: Section) -> ContactEffect:
    law = read_fields(c, ContactEffect, ("law",))["law"]
    _only_law_keys(c, law, CONTACT_LAW_KEYS)
    got = read_fields(c, ContactEffect, ("restitution", "exponent"),
                      {"exponent": 1.0} if law == "kelvin-voigt" else None)
    k = c.raw("stiffness", "auto")
    auto = k == "auto" or k is None  # the Hertz stiffness from the radii and materials
    got.update(read_fields(c, ContactEffect, ("damping",) if auto else ("stiffness", "damping")))
    if auto and got["exponent"] != 1.5:
        raise SceneError(f"{c.key('stiffness')}: 'auto' is not allowed with exponent {got['exponent']:g} (auto is the "
                         "Hertz line-contact stiffness from the radii and materials, in N/m^1.5, for exponent 1.5 "
                         f"only: give stiffness in N/m^{got['exponent']:g}, or exponent 1.5)")
    c.done()
    return ContactEffect(law, stiffness=got.pop("stiffness", None), **got)


def _friction(f: Section) -> FrictionEffect:
    law = read_fields(f, FrictionEffect, ("law",))["law"]
    _only_law_keys(f, law, FRICTION_LAW_KEYS)
    got = read_fields(f, FrictionEffect, ("coefficient",), {"coefficient": 0.0} if law == "none" else None)
    got.update(read_fields(f, FrictionEffect, ("static_coefficient", "v0", "v1"),
                           {"static_coefficient": got["coefficient"]}))
    if "v1" in FRICTION_LAW_KEYS[law] and got["v1"] <= got["v0"]:  # v1 only where the law has it
        raise SceneError(f"{f.key('v1')}: {got['v1']:g} m/s is not allowed (must be greater than v0 = "
                         f"{got['v0']:g} m/s)")
    got.update(read_fields(f, FrictionEffect, ("stribeck_velocity",)))
    f.done()
    return FrictionEffect(law, **got)


def _effects(sec: Section) -> Effects:
    contact, friction = _contact(sec.section("contact")), _friction(sec.section("friction"))
    g = read_fields(sec, Effects, ("gravity",))["gravity"]
    film = read_lubrication(sec.raw("lubrication"), sec.key("lubrication"))
    wear = read_wear(sec.raw("wear"), sec.key("wear"))
    sec.done()
    return Effects(contact, friction, g, film, wear)


def _actuation(sec: Section, n: int, graph: Graph | None = None) -> tuple[Actuation, tuple[float, ...]]:
    """(the actuation, the n actuators' limits): an n-RRR's from actuation.torque_limit, a
    graph scene's from mechanism.actuators; the mode defaults to 'free' when there is no task
    to track."""
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
    got = read_fields(p, PreloadSettings, ("method", "min_force"))
    weights = p.vector("weights", n, 1.0, scalar_ok=True)
    for i, v in enumerate(weights):
        if v <= 0:
            raise SceneError(f"{p.key('weights')}[{i}]: {v:g} is not allowed (must be > 0)")
    got.update(read_fields(p, PreloadSettings, ("qp_solver", "smoothness_weight", "max_turn_rate")))
    p.done()
    gains = sec.section("gains")
    control = read_fields(gains, Actuation, ("kp", "kd"))
    gains.done()
    # seat_model: where references are compensated
    control.update(read_fields(sec, Actuation, ("control_rate", "compensation", "seat_model")))
    sec.done()
    return Actuation(mode, PreloadSettings(weights=weights, **got), **control), limits


CIRCLE = ("center", "radius", "start_angle", "revolutions", "orientation")  # a circle's keys, read in this order


def _time_table(sec: Section, law: str, task: bool, base: Path) -> tuple:
    """path.time_table: the rows (t, s, s_dot) of time_law 'table' (a CSV file beside the
    scene or the rows themselves), () with any other law."""
    if law == "table" and not task:
        raise SceneError(f"{sec.key('time_law')}: 'table' is not allowed in a driven scene (no task body follows "
                         "the path: the drivers set the motion, and a time table has no path progress to time)")
    if law != "table":
        if sec.raw("time_table") is not None:
            raise SceneError(f"{sec.key('time_table')}: not allowed with time_law {law!r} (only with time_law: "
                             "table)")
        return ()
    raw = sec.raw("time_table")
    if raw is None:
        raise SceneError(f"{sec.key('time_table')}: missing (time_law 'table' reads a CSV file with columns "
                         "t,s,s_dot, relative to the scene file, or a list of [t, s, s_dot] rows)")
    if isinstance(raw, list):  # the rows themselves (a sweep's cases carry their table so)
        return check_time_table(raw, sec.key("time_table"))
    return read_time_table(base / sec.string("time_table"), sec.key("time_table"))


def _path(sec: Section, task: bool = True, base: Path = Path()) -> PathSpec:
    kind = read_fields(sec, PathSpec, ("type",), None if task else {"type": "none"})["type"]
    if (kind == "none") == task:
        raise SceneError(f"{sec.key('type')}: {kind!r} is not allowed "
                         + ("(the task body follows a path: circle, line or waypoints)" if task else
                            "(no task body: the drivers set the motion; use 'none' with duration and sample_rate)"))
    law = read_fields(sec, PathSpec, ("time_law",))["time_law"]
    table = _time_table(sec, law, task, base)
    if table and sec.raw("duration") is None:
        duration = table[-1][0]
    else:
        duration = read_fields(sec, PathSpec, ("duration",))["duration"]
        if table and abs(duration - table[-1][0]) > 1e-9 * duration:
            raise SceneError(f"{sec.key('duration')}: {duration:g} s is not allowed (the time table ends at "
                             f"{table[-1][0]:.9g} s; leave duration out or give that)")
    common = dict(
        type=kind,
        duration=duration,
        time_law=law,
        time_table=table,
        **read_fields(sec, PathSpec, ("sample_rate", "max_condition_number", "min_transmission")),
    )
    if common["duration"] * common["sample_rate"] < 2:
        raise SceneError(f"{sec.key('sample_rate')}: {common['sample_rate']:g} Hz is too low "
                         f"(need at least 2 samples over duration {common['duration']:g} s)")
    if kind == "circle":
        spec = PathSpec(**common, **read_fields(sec, PathSpec, CIRCLE))
    elif kind == "line":
        spec = PathSpec(**common, **read_fields(sec, PathSpec, ("start", "end")))
    elif kind == "none":
        spec = PathSpec(**common)
    else:
        pts = sec.raw("points")
        if not isinstance(pts, list) or len(pts) < 2:
            raise SceneError(f"{sec.key('points')}: {describe(pts)} is not allowed "
                             "(a list of at least 2 poses [x, y, theta] is required)")
        points = tuple(Section({"p": p}, f"{sec.key('points')}[{i}]").vector("p", 3) for i, p in enumerate(pts))
        spec = PathSpec(**common, points=points)
    sec.done()
    return spec


def _integrator(sec: Section) -> IntegratorSettings:
    s = IntegratorSettings(**read_fields(sec, IntegratorSettings))
    if s.tolerance is not None and s.method not in choices("error control"):
        raise SceneError(f"{sec.key('tolerance')}: {s.tolerance:g} is not allowed with method '{s.method}' (error "
                         f"control is for {', '.join(choices('error control'))}; the adaptive methods take rtol, atol)")
    sec.done()
    return s


def _initial(sec: Section) -> Initial:
    v = Initial(**read_fields(sec, Initial))
    sec.done()
    return v


def parse_scene(data, name: str = "scene", source: str = "") -> Scene:
    """Build a :class:`Scene` from a parsed YAML mapping (raises SceneError).

    Validates the data only; :func:`rrr4.load_scene` also checks the scene against its
    model (assembly, workspace, singularities)."""
    top = Section(data, "")
    msec = top.section("mechanism")
    kind = msec.choice("kind", MECHANISM_KINDS, "n-rrr")
    if kind == "n-rrr":
        mech = _mechanism(msec)
        joints = _joints(top.section("joints"), mech.n_chains)
        actuation, limits = _actuation(top.section("actuation"), mech.n_chains)
        graph = expand_nrrr(mech, joints, limits)
    else:
        mech, graph = None, read_graph(msec, Path(source).parent if source else Path())
        if top.has("joints"):
            raise SceneError("joints: not allowed with mechanism.kind 'graph' (give each joint's clearance in "
                             "mechanism.joints)")
        actuation, _ = _actuation(top.section("actuation"), len(graph.actuators), graph)
    scene = Scene(
        name=read_name(top, "name", name),
        **read_fields(top, Scene, ("description",)),
        mechanism=mech,
        graph=graph,
        effects=_effects(top.section("effects")),
        actuation=actuation,
        path=_path(top.section("path"), graph.task is not None, Path(source).parent if source else Path()),
        initial=_initial(top.section("initial")),
        integrator=_integrator(top.section("integrator")),
        forces=read_forces(top.raw("forces"), "forces", graph, Path(source).parent if source else Path()),
        source=source,
    )
    top.done()
    check_unused(scene, top.data.get("actuation"))
    p = scene.path
    if p.duration * p.sample_rate > MAX_SAMPLES:
        raise SceneError(f"path.sample_rate: {p.sample_rate:g} Hz over {p.duration:g} s is not allowed (at most "
                         f"{MAX_SAMPLES:g} samples)")
    if scene.integrator.step > p.duration:
        raise SceneError(f"integrator.step: {scene.integrator.step:g} s is not allowed (must not exceed "
                         f"path.duration = {p.duration:g} s)")
    return with_data(scene, data, parse_scene)


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
                    None, None, f"key {describe(key)} appears twice (first at line {seen[key] + 1})",
                    key_node.start_mark)
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


MAX_BYTES = 16 * 2**20  # largest YAML file read [bytes]
MAX_DEPTH = 64           # deepest nesting of mappings and lists
MAX_NODES = 1_000_000    # most mappings, lists and values, aliases expanded


def load_yaml(text: str, where: str):
    """The data of YAML `text` (`where` names it in errors), read safely: no key given twice,
    nesting at most MAX_DEPTH deep, at most MAX_NODES nodes with every alias expanded into a
    node of its own (a scene or spec that shares a block through an alias, ``&pin``/``*pin``,
    is read as if the block were written out at each place, so that setting one key changes
    one place). Raises :class:`SceneError` in one line."""
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = (str(getattr(e, "problem", None) or e).splitlines() or [type(e).__name__])[0][:100]
        raise SceneError(f"{where}: not valid YAML{at} ({problem})") from None
    except RecursionError:
        raise SceneError(f"{where}: nested too deeply (at most {MAX_DEPTH} levels of mappings and lists)") from None
    return _unshared(data, where)


def _unshared(data, where: str):
    """A copy of `data` in which no mapping or list is shared (YAML aliases expanded), made
    without recursion; SceneError beyond MAX_DEPTH levels or MAX_NODES nodes."""
    def fresh(v):
        return {} if isinstance(v, dict) else [] if isinstance(v, list) else v

    root = fresh(data)
    stack, nodes = ([(data, root, 1)] if isinstance(data, (dict, list)) else []), 1
    while stack:
        src, dst, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise SceneError(f"{where}: nested too deeply (at most {MAX_DEPTH} levels of mappings and lists)")
        items = src.items() if isinstance(src, dict) else enumerate(src)
        for k, v in items:
            nodes += 1
            if nodes > MAX_NODES:
                raise SceneError(f"{where}: too large (more than {MAX_NODES:g} values, aliases expanded)")
            copy = fresh(v)
            if isinstance(dst, dict):
                dst[k] = copy
            else:
                dst.append(copy)
            if isinstance(v, (dict, list)):
                stack.append((v, copy, depth + 1))
    return root


def read_yaml(path, what: str = "scene"):
    """The data of a YAML file (`what` names it in errors: 'scene', 'sweep spec'), with the
    file checks: it exists, is a regular UTF-8 text file, valid YAML, no key given twice, not
    empty. Raises :class:`SceneError`."""
    text = read_text(path, f"{what} file", f"a YAML {what} file", MAX_BYTES)
    path = shown(path)
    data = load_yaml(text, path)
    if data is None:
        raise SceneError(f"{what} file '{path}' is empty (a {what} mapping is required"
                         + (": mechanism, path, ...)" if what == "scene" else ")"))
    if not isinstance(data, dict):  # named, never echoed: it may be any file
        raise SceneError(f"{what} file '{path}' is not a {what} (its YAML is a {type(data).__name__}, not a mapping of "
                         + ("mechanism, path, ...)" if what == "scene" else "keys)"))
    return data


def read_scene(path) -> Scene:
    """Read and validate a YAML scene file (data only, see :func:`parse_scene`). Raises :class:`SceneError`."""
    p = Path(path)
    data = read_yaml(p)
    return parse_scene(data, name=p.stem, source=str(p))
