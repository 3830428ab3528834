"""What identification estimates, named by the dotted scene key paths of the sweeps
(:mod:`rrr4.scene.keys`), each with its nominal value (the scene's), bounds and a scale.

- ``joints.radial_clearance``: the clearance [m] of every clearance joint without its own;
- ``joints.per_joint.<J>.radial_clearance``: joint J's clearance [m];
- ``effects.friction.coefficient``: the friction coefficient mu of the seated journals;
- ``effects.contact.stiffness``: the contact stiffness K [N/m^n] of every clearance joint;
- ``mechanism.chains[i].driving_link.length``, ``mechanism.chains[i].following_link.length``,
  ``mechanism.chains[i].base[0]``, ``mechanism.chains[i].base[1]`` [m]: kinematic calibration
  of an n-RRR.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..checks import describe, unknown_value
from ..errors import SceneError
from ..problem import Problem
from ..scene import Scene, get_key

__all__ = ["Parameter", "resolve_parameters", "DEFAULT_PARAMETERS", "PATTERNS", "identified_scene", "scene_keys"]

DEFAULT_PARAMETERS = ("joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness")
PATTERNS = ("joints.radial_clearance", "joints.per_joint.<J>.radial_clearance", "effects.friction.coefficient",
            "effects.contact.stiffness", "mechanism.chains[i].driving_link.length",
            "mechanism.chains[i].following_link.length", "mechanism.chains[i].base[0|1]")
_PER_JOINT = re.compile(r"^joints\.per_joint\.([A-Za-z0-9_-]+)\.radial_clearance$")
_CHAIN = re.compile(r"^mechanism\.chains\[(\d+)\]\.(driving_link\.length|following_link\.length|base\[([01])\])$")


@dataclass(frozen=True)
class Parameter:
    """One identified parameter: its scene key, kind ('clearance', 'friction', 'stiffness',
    'driving', 'following', 'base'), nominal value, bounds and scale (the unit of its scaled
    coordinate, a typical magnitude), the clearance joints it sets, or its chain and axis."""
    key: str
    kind: str
    nominal: float
    lower: float
    upper: float
    scale: float
    joints: tuple[str, ...] = ()
    chain: int = -1
    axis: int = -1
    log: bool = False  # fitted in log(value / nominal) (a stiffness spans decades)

    def value(self, u: float) -> float:
        """The parameter's value at its scaled coordinate u."""
        return self.nominal * float(np.exp(u)) if self.log else self.nominal + self.scale * u

    def coordinate(self, value: float) -> float:
        """The scaled coordinate u of a value."""
        return float(np.log(value / self.nominal)) if self.log else (value - self.nominal) / self.scale

    def derivative(self, u: float) -> float:
        """d value / d u."""
        return self.value(u) if self.log else self.scale


def _bounds(key: str, spec, nominal: float, lower: float, upper: float) -> tuple[float, float, float]:
    """(nominal, lower, upper) from a user's spec: None, [lower, upper] or {nominal, lower, upper}."""
    if spec is None:
        return nominal, lower, upper
    if isinstance(spec, (list, tuple)) and len(spec) == 2:
        spec = {"lower": spec[0], "upper": spec[1]}
    if not isinstance(spec, dict) or set(spec) - {"nominal", "lower", "upper"}:
        raise SceneError(f"parameters.{key}: {describe(spec)} is not allowed (None, [lower, upper] or a mapping with "
                         "nominal, lower, upper)")
    out = []
    for name, default in (("nominal", nominal), ("lower", lower), ("upper", upper)):
        v = spec.get(name, default)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SceneError(f"parameters.{key}.{name}: {describe(v)} is not allowed (a finite number)")
        out.append(float(v))
    if not out[1] <= out[0] <= out[2] or out[1] == out[2]:
        raise SceneError(f"parameters.{key}: nominal {out[0]:g} and bounds [{out[1]:g}, {out[2]:g}] are not allowed "
                         "(lower <= nominal <= upper, lower < upper)")
    return tuple(out)


def resolve_parameters(problem: Problem, parameters=None, data: dict | None = None) -> list[Parameter]:
    """The :class:`Parameter` list of `parameters`: None (:data:`DEFAULT_PARAMETERS`), a list
    of keys, or a mapping key -> None | [lower, upper] | {nominal, lower, upper}. `data`: the
    scene's YAML (which joints have their own clearance). SceneError (one line) for a key that
    is not one of :data:`PATTERNS`, names a joint or chain the scene does not have, or sets a
    value twice."""
    if parameters is None:
        parameters = DEFAULT_PARAMETERS
    if isinstance(parameters, str):
        parameters = [parameters]
    specs = dict(parameters) if isinstance(parameters, dict) else {k: None for k in parameters}
    if not specs:
        raise SceneError("parameters: none given (choose from: " + ", ".join(PATTERNS) + ")")
    scene, clear = problem.scene, problem.clearance_joints
    if not clear:
        raise SceneError(f"joints.clearance: scene {scene.name!r} has no clearance joint (nothing to identify in the "
                         "seated model)")
    own = {j for j in clear if get_key(data or {}, f"joints.per_joint.{j}.radial_clearance") is not None}
    own |= {m.group(1) for k in specs if (m := _PER_JOINT.match(str(k)))}
    out = []
    for key, spec in specs.items():
        if not isinstance(key, str):
            raise SceneError(f"parameters: key {describe(key)} is not allowed (choose from: {', '.join(PATTERNS)})")
        m_joint, m_chain = _PER_JOINT.match(key), _CHAIN.match(key)
        if key == "joints.radial_clearance":
            joints = tuple(j for j in clear if j not in own)
            if not joints:
                raise SceneError(f"parameters.{key}: every clearance joint has its own clearance (per_joint)")
            c = scene.joint(joints[0]).radial_clearance
            out.append(Parameter(key, "clearance", *_bounds(key, spec, c, 1e-3 * c, min(10 * c, 0.5 * min(
                scene.joint(j).journal_radius for j in joints))), scale=c, joints=joints))
        elif m_joint:
            j = m_joint.group(1)
            if j not in clear:
                raise unknown_value(f"parameters.{key}", "clearance joint", j, clear)
            c = scene.joint(j).radial_clearance
            out.append(Parameter(key, "clearance", *_bounds(key, spec, c, 1e-3 * c,
                                                            min(10 * c, 0.5 * scene.joint(j).journal_radius)),
                                 scale=c, joints=(j,)))
        elif key == "effects.friction.coefficient":
            fe = scene.effects.friction
            if fe.law == "none":
                raise SceneError(f"parameters.{key}: scene {scene.name!r} has friction law 'none' (set a friction "
                                 "law in effects.friction to identify its coefficient)")
            out.append(Parameter(key, "friction", *_bounds(key, spec, fe.coefficient, 0.0, 1.0), scale=0.1))
        elif key == "effects.contact.stiffness":
            ks = {problem.joint_stiffness(j) for j in clear}
            if len(ks) > 1:
                raise SceneError(f"parameters.{key}: the clearance joints have different stiffnesses (their "
                                 "materials or radii differ); one value for all would change them")
            k = ks.pop()
            out.append(Parameter(key, "stiffness", *_bounds(key, spec, k, 1e-2 * k, 1e2 * k), scale=k, log=True))
        elif m_chain:
            if not problem.closed_form:
                raise SceneError(f"parameters.{key}: kinematic parameters are defined for n-RRR scenes")
            i = int(m_chain.group(1))
            chains = scene.mechanism.chains
            if i >= len(chains):
                raise SceneError(f"parameters.{key}: chain {i} is not allowed (the mechanism has chains 0 to "
                                 f"{len(chains) - 1})")
            c = chains[i]
            what = m_chain.group(2)
            if what.startswith("base"):
                axis = int(m_chain.group(3))
                v = float(c.base[axis])
                out.append(Parameter(key, "base", *_bounds(key, spec, v, v - 5e-3, v + 5e-3), scale=1e-4, chain=i,
                                     axis=axis))
            else:
                kind = what.split("_")[0]
                v = (c.driving if kind == "driving" else c.following).length
                out.append(Parameter(key, kind, *_bounds(key, spec, v, 0.99 * v, 1.01 * v), scale=1e-4, chain=i))
        else:
            raise SceneError(f"parameters: key {key!r} is not allowed (choose from: {', '.join(PATTERNS)})")
    return out


def identified_scene(scene: Scene, params, values, name: str = "identified") -> Scene | None:
    """`scene` with the values set at the parameters' keys (:meth:`rrr4.scene.Scene.with_values`),
    renamed '<name>_identified' where its data names it (else called `name`); None when the
    scene holds no YAML data (built from dataclasses)."""
    if scene.data is None:
        return None
    changes = {}
    for p, v in zip(params, values, strict=True):
        changes.update({k: float(v) for k in scene_keys(scene, p)})
    if isinstance(scene.data.get("name"), str):
        changes["name"] = f"{scene.data['name']}_identified"
    return scene.with_values(changes, name=name)


def scene_keys(scene: Scene, p: Parameter) -> list[str]:
    """The dotted keys of `scene`'s YAML that hold parameter `p`: its own key, or on a graph
    scene (which gives each joint's clearance in ``mechanism.joints``) a clearance's
    ``mechanism.joints[i].clearance.radial_clearance`` for each of its joints."""
    mech = (scene.data or {}).get("mechanism", {})
    if p.kind != "clearance" or mech.get("kind") != "graph":
        return [p.key]
    index = {j.get("name"): i for i, j in enumerate(mech.get("joints", []))}
    return [f"mechanism.joints[{index[j]}].clearance.radial_clearance" for j in p.joints]
