"""The vocabulary of a scene: every list of allowed names, as plain data.

Each registry (contact laws, friction laws, integrators, preload methods, QP solvers, ...)
builds its dict from these tuples, and ``tests/test_architecture.py`` checks that they
match, so a name is added in one place and the scene reader, the error messages and the
registry agree. Imports nothing.
"""

from __future__ import annotations

__all__ = ["MECHANISM_KINDS", "JOINT_TYPES", "PATH_TYPES", "TIME_LAWS", "DRIVER_LAWS", "ACTUATION_MODES",
           "CONTACT_LAWS", "FRICTION_LAWS", "LUBRICATION_LAWS", "ASSEMBLY_MEASURES",
           "CONTACT_LAW_KEYS", "FRICTION_LAW_KEYS",
           "LUBRICATION_LAW_KEYS", "WEAR_SURFACES", "FORCE_ELEMENTS", "LOAD_FRAMES", "INTEGRATORS",
           "ERROR_CONTROLLED", "NEWTON", "COORDINATES", "PRELOAD_METHODS", "COMPENSATIONS", "QP_SOLVERS",
           "JOURNAL_STARTS", "OBJECTIVES", "IDENTIFICATION_METHODS", "IDENTIFICATION_DEFAULT", "MATERIALS",
           "GROUND", "choices", "registry"]

GROUND = "ground"  # the fixed frame's name in a graph
MECHANISM_KINDS = ("n-rrr", "graph")
JOINT_TYPES = ("revolute", "prismatic")
# mechanism.assembly[].<measure>: the sign of the cross (bend) or dot (stretch) product of the
# two bodies' lines at a revolute joint
ASSEMBLY_MEASURES = ("bend", "stretch")
PATH_TYPES = ("circle", "line", "waypoints", "none")  # none: no task, the drivers set the motion
TIME_LAWS = ("quintic", "cycloidal", "linear", "table")  # table: path.time_table, e.g. an optimal one
# mechanism.drivers[].time_law: constant speed (the default), or a path's time law moving the
# driver by its travel over its duration (rest to rest for quintic and cycloidal)
DRIVER_LAWS = ("constant",) + TIME_LAWS
ACTUATION_MODES = ("torque", "prescribed", "free")  # free: zero actuator torque
CONTACT_LAWS = ("hertz", "kelvin-voigt", "hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")
FRICTION_LAWS = ("coulomb", "ambrosio", "smooth", "stribeck")  # a scene may also say 'none'
LUBRICATION_LAWS = ("long-bearing", "short-bearing")  # a scene may also say 'none' (dry joints)
# the keys of effects.contact / effects.friction each law uses besides 'law' (a scene giving
# another law's key is refused: the law would ignore it)
CONTACT_LAW_KEYS = {
    "hertz": ("exponent", "stiffness"),
    "kelvin-voigt": ("exponent", "stiffness", "damping"),
    **{law: ("restitution", "exponent", "stiffness") for law in ("hunt-crossley", "lankarani-nikravesh", "flores",
                                                                "gonthier")},
}
FRICTION_LAW_KEYS = {
    "none": (),
    "coulomb": ("coefficient",),
    "ambrosio": ("coefficient", "v0", "v1"),
    "smooth": ("coefficient", "v0"),
    "stribeck": ("coefficient", "static_coefficient", "v0", "stribeck_velocity"),
}
LUBRICATION_LAW_KEYS = {
    "none": (),
    **{law: ("viscosity", "length", "threshold") for law in LUBRICATION_LAWS},
}
# effects.wear.surfaces: which surfaces of a clearance joint wear (Archard); a scene may also say 'none'
WEAR_SURFACES = ("bearing", "journal")
FORCE_ELEMENTS = ("spring_damper", "rotational_spring_damper", "load")  # forces[].type
LOAD_FRAMES = ("ground", "body")  # forces[].frame of a load: the frame its force components are given in
INTEGRATORS = ("bathe", "newmark", "generalized-alpha", "ros2", "rk4", "erk", "rosenbrock", "cvodes", "idas", "rk45",
               "radau")
ERROR_CONTROLLED = ("bathe", "newmark", "generalized-alpha")  # the methods integrator.tolerance applies to
NEWTON = ("simplified", "full")  # integrator.newton of the implicit methods
COORDINATES = ("auto", "tree", "reference-point")  # integrator.coordinates
PRELOAD_METHODS = ("exact", "qp", "nlp")  # a scene may also say 'none'
COMPENSATIONS = ("none", "clearance")  # actuation.compensation
SEAT_MODELS = ("quasi_static", "rolling")  # actuation.seat_model: how the compensation's seats follow friction
QP_SOLVERS = ("qrqp", "osqp", "daqp", "qpoases")  # actuation.preload.qp_solver (CasADi conic plugins)
JOURNAL_STARTS = ("centred", "seated")  # initial.journals
IDENTIFICATION_METHODS = ("staged", "seated", "dynamic")  # rrr4.identify(method=...), rrr4 identify --method
IDENTIFICATION_DEFAULT = "staged"  # seated first, then dynamic over the whole record from its estimates
OBJECTIVES = ("time", "effort", "time+effort")  # of an optimal time law (rrr4 optimize --objective)
MATERIALS = {  # name: (Young's modulus [Pa], Poisson ratio)
    "steel": (207e9, 0.3),
    "aluminium": (70e9, 0.33),
    "bronze": (110e9, 0.34),
    "brass": (100e9, 0.34),
}



_CHOICES = {
    "contact law": CONTACT_LAWS,
    "friction law": ("none", *FRICTION_LAWS),
    "lubrication law": ("none", *LUBRICATION_LAWS),
    "wear surfaces": ("none", *WEAR_SURFACES, "both"),
    "integrator": INTEGRATORS,
    "error control": ERROR_CONTROLLED,
    "coordinates": COORDINATES,
    "newton": NEWTON,
    "preload method": ("none", *PRELOAD_METHODS),
    "compensation": COMPENSATIONS,
    "seat model": SEAT_MODELS,
    "qp solver": QP_SOLVERS,
    "force element": FORCE_ELEMENTS,
}


def registry(names: tuple[str, ...], implementations: dict) -> dict:
    """{name: implementation} in the vocabulary's order: how a registry is built from its
    names here. Raises RuntimeError (a programming error, at import) when the implementations
    and the names differ: a name without an implementation, or one the vocabulary lacks."""
    if set(names) != set(implementations):
        raise RuntimeError(f"registry: the names {sorted(names)} and the implementations "
                           f"{sorted(implementations)} differ")
    return {name: implementations[name] for name in names}


def choices(what: str) -> tuple[str, ...]:
    """The allowed names of a scene setting: 'contact law', 'friction law', 'lubrication law', 'wear surfaces',
    'integrator', 'error control', 'coordinates', 'newton', 'preload method', 'compensation', 'seat model',
    'qp solver' or 'force element'."""
    return _CHOICES[what]
