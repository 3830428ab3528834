"""The equation builder: the one place that decides which terms exist.

From a scene it builds the constrained equations of motion (Nikravesh 1988, ch. 6;
Flores & Ambrosio 2004 for the clearance joints)

    M qdd + Phi_q^T lambda = Q_g + B tau + Q_contact(q, qd),
    Phi_q qdd = gamma - 2 omega_b Phi_dot - omega_b^2 Phi          (Baumgarte 1972)

with exactly the effects the scene asks for, each a term of :data:`TERMS` (contact with its
friction, :mod:`.contact_term`; oil film, :mod:`.film_term`; wear, :mod:`.wear_term`; force
elements, :mod:`.elements`), added over one :class:`rrr4.dynamics.assembly.Assembly`, then the
constraints (:mod:`.constraints`) and the tree coordinates (:mod:`.tree_equations`):

- Phi holds every joint without clearance (actuated or passive, ``Model.constraints``), one
  row per driver s_d(q) - (initial + speed t) = 0, and in the prescribed mode the driving
  constraints s(q) - theta_ref(t) = 0 (s: actuator coordinates);
- Q_contact has one journal-bearing contact per clearance joint, with the scene's normal
  law; the friction term exists only if the friction law is not 'none'; the oil film's
  force (:mod:`rrr4.contact.lubrication`) only at the clearance joints whose lubrication
  law is not 'none': w(eps) F(min(eps, threshold), eps_dot, whirl), acting at the joint
  centres, handed over to the dry laws between the threshold and eps = 1; the wear profiles
  (:mod:`rrr4.contact.wear`) only at the clearance joints that wear, whose contact is then
  conformal: an elastic layer over the worn arc (:mod:`rrr4.contact.conformal`), with the
  profiles' node depths among the input ``parameters``; with no clearance joint there is no contact code at all;
- tau (actuator efforts, generalised force S^T tau with S = ds/dq): 'free' -> 0 (no
  effort inputs in the graph); 'torque' -> the input ``effort``, what the controller
  (:mod:`rrr4.control`) commands; 'prescribed' -> tau = -lambda of the driving
  constraints.

Every Function is SX, named, with named inputs and outputs. Common inputs ("refs"):
q (nq,) [m, rad], qd (nq,), effort (n,) [N m or N] (torque mode), theta_ref (n,) [rad],
theta_d_ref (n,) [rad/s], theta_dd_ref (n,) [rad/s^2] (prescribed mode), delta_dot0
(nc,) [m/s], in_contact (nc,) {0, 1}, t [s] (drivers only) (nc = number of clearance
joints, in graph order; B1..Bn, C1..Cn for an n-RRR; prismatic actuators in m, m/s, N).

``acceleration`` (index-1 form, for explicit integrators): refs -> qdd (nq,), lambda (m,),
tau (n,) [N m], reaction (2, k) [N] of the k ideal passive revolute joints, contact_force (2, nc)
[N] (on the journal body: dry contact plus film), normal_force (nc,), friction_force (nc,),
penetration (nc,) [m], delta_dot (nc,) [m/s], eccentricity (2, nc) [m], power_in [W]
(actuators and drivers), power_damping [W] (the normal force's non-conservative part, and
the film's power -F_film . e_dot), power_friction [W] (dissipated), driver_effort
(n_drivers,) [N m or N] (what each driver applies along its joint coordinate, -lambda of
its row); with lubrication also film_force (2, nc) [N] on the journal (0 at dry joints)
and power_film [W] (the film's share of power_damping); with wear also wear_rate (the
node depth rates [m/s] of every wear profile, Equations.worn order: Archard's law).

``residual`` (for implicit Newton methods such as Bathe or Newmark): q, qd, qdd, lambda and
the other refs -> dynamics (nq,) = M qdd + Phi_q^T lambda - Q, constraint (m,) = Phi_q qdd -
gamma_stab, phi (m,) [m, rad] position-level constraint values.

``contact_update`` (the discrete state, once per step): q, qd, delta_dot0, in_contact ->
delta_dot0_next, in_contact_next, loss (nc each). Rule for the approach velocity delta_dot0:
at onset (delta > 0 after delta <= 0) capture delta_dot0 = max(delta_dot, v_min); hold
it for the whole contact period (persistent contact, e.g. under preload, keeps its
onset value); reset it to v_min in free flight. Between updates the force uses
max(delta_dot, v_min) for a joint not yet flagged in contact, i.e. chi at onset.
So delta_dot0 >= v_min > 0 always, and the force stays finite for grazing contact.
A loss is a transition contact -> free flight.

``energy``: q, qd -> kinetic [J], potential [J] = sum K delta^(n+1)/(n+1) + gravity + the
force elements' springs.

Force elements (``Scene.forces``, :mod:`rrr4.dynamics.elements`) exist only when the scene
has them: their generalised forces join Q, their springs' energy the potential, their
dampers' power ``power_damping`` and their loads' power ``power_in`` (the work done on the
mechanism from outside); their numbers follow the contact numbers in ``parameters``.

``actuator_coordinates``: q -> s (n,) [rad or m], S = ds/dq.

In tree coordinates p (:mod:`rrr4.mechanism.tree`; built where an ideal joint forms a tree):
``tree_acceleration``: p, pd and the refs after qd -> pdd, power_in, power_damping,
power_friction, by the velocity transformation q = q(p), qd = J pd: J^T M J pdd + Phi_p^T
lambda = J^T (Q - M Jdot pd), with the rows of the loop-closing ideal joints, the drivers and
the driving constraints, Baumgarte-stabilised as above; ``tree_state``: p, pd -> q, qd;
``tree_coordinates``: q, qd -> p, pd.

Every Function has a last input ``parameters``: the numbers of ``Problem.equation_parameters``
(the contact numbers, the force elements'; with ``inputs='geometry'`` also masses, inertias
and joint points), each named in ``Equations.layout`` (:mod:`rrr4.dynamics.layout`), so that
compiled code built on the equations serves every scene of the same structure.

Reaction convention: reaction[:, j] is the force the joint's first (inboard) body exerts on
its second, global frame (= -lambda); contact_force[:, j] is the force on the journal body,
the same convention when the journal sits on the second body (always in an n-RRR).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from ..checks import argument, unknown_value
from ..contact.normal import V_MIN
from ..errors import SceneError
from ..functions import fix_last_input
from ..mechanism.model import Model, geometry_parameters
from ..scene import Effects
from .assembly import Assembly
from .constraints import Actuation, constraints, solved
from .contact_term import CONTACT_OUTPUTS, ContactTerm, clearance_joint, contact_update
from .elements import ForceElementTerm
from .film_term import FilmTerm
from .layout import ParameterLayout, lubricated_joints, parameter_layout, worn_joints, worn_surfaces
from .tree_equations import tree_functions
from .wear_term import WearTerm

__all__ = ["Equations", "build_equations", "parametric_equations", "with_parameters", "with_profiles", "profiles_of",
           "INPUTS", "lubricated_joints", "worn_joints", "worn_surfaces", "BAUMGARTE_OMEGA", "TERMS"]

INPUTS = ("contact", "geometry")  # build_equations(inputs=...): the numbers the parametric equations take

# Baumgarte stabilisation frequency omega_b [rad/s] (alpha = omega_b, beta = omega_b).
BAUMGARTE_OMEGA = 100.0


@dataclass(frozen=True)
class Equations:
    """The built equations of one problem (immutable). See the module docstring."""
    model: Model
    clearance_joints: tuple[str, ...]   # graph order
    ideal_joints: tuple[str, ...]       # every joint held by an ideal constraint, graph order
    passive_ideal_joints: tuple[str, ...]  # ideal passive revolute joints: the `reaction` columns
    mode: str                           # 'free' | 'torque' | 'prescribed'
    terms: tuple[str, ...]              # effects present in the graph
    stiffness: tuple[float, ...]        # K per clearance joint [N/m^n]
    nq: int
    n_actuators: int
    n_constraints: int
    acceleration: ca.Function
    residual: ca.Function
    contact_update: ca.Function
    energy: ca.Function
    v_min: float
    baumgarte: float
    # tree coordinates p (rrr4.mechanism.tree; None where no ideal joint forms a tree):
    # tree_acceleration: p, pd and the refs after qd -> pdd, power_in, power_damping,
    # power_friction; tree_state: p, pd -> q, qd; tree_coordinates: q, qd -> p, pd
    actuator_coordinates: ca.Function | None = None  # q, parameters -> s (n,), S = ds/dq (n, nq)
    tree_acceleration: ca.Function | None = None
    tree_state: ca.Function | None = None
    tree_coordinates: ca.Function | None = None
    # the numbers that the equations take as an input (Problem.equation_parameters), and the
    # same equations with them as the last input "parameters" of every Function: shared by
    # every problem of the same structure, so that compiled code built on them is too
    parameters: np.ndarray = field(default_factory=lambda: np.zeros(0), compare=False, repr=False)
    parametric: Equations | None = field(default=None, compare=False, repr=False)
    # the wear profiles (rrr4.contact.wear): ((joint, surface, nodes), ...) in the order of the
    # profile's node depths [m] in ``parameters`` and of the output wear_rate
    worn: tuple = ()
    # the names of the entries of ``parameters`` (rrr4.dynamics.layout), built with the equations
    layout: ParameterLayout = field(default_factory=lambda: ParameterLayout(()))

    @property
    def profile_start(self) -> int:
        """Where the profiles' node depths start in ``parameters``."""
        return self.layout.slice("profiles").start


def with_parameters(eqs: Equations, parameters) -> Equations:
    """The equations of `eqs`'s structure with their input ``parameters`` fixed to `parameters`
    (e.g. another wear profile: nothing is rebuilt or compiled)."""
    par = eqs.parametric
    p = np.asarray(parameters, float)
    stiffness = tuple(p[par.layout.index(f"joints.{j}.stiffness")] for j in par.clearance_joints)
    return replace(par, stiffness=stiffness, parameters=p, parametric=par,
                   **{k: fix_last_input(getattr(par, k), p) for k in ("acceleration", "residual", "contact_update",
                                                                       "energy", "actuator_coordinates",
                                                                       "tree_acceleration", "tree_state",
                                                                       "tree_coordinates") if getattr(par, k)})


def with_profiles(eqs: Equations, profiles: dict) -> Equations:
    """`eqs` on worn profiles: `profiles` maps joint -> surface -> node depths (M,) [m] (finite,
    >= 0; a profile not given stays as it is). Nothing is rebuilt or compiled. Raises SceneError
    naming a joint, surface or length that does not fit."""
    p = np.array(eqs.parameters, float)
    known = {(j, s): eqs.layout.slice(f"profiles.{j}.{s}") for j, s, _ in eqs.worn}
    for joint, by_surface in profiles.items():
        for surface, depths in by_surface.items():
            if (joint, surface) not in known:
                raise unknown_value("wear", "worn surface", f"{joint}.{surface}", [f"{j}.{s}" for j, s in known])
            at = known[(joint, surface)]
            m = at.stop - at.start
            d = np.asarray(depths, float).ravel()
            if d.shape != (m,) or not np.all(np.isfinite(d)) or np.any(d < 0):
                raise SceneError(f"wear: the profile of {joint}.{surface} is not allowed ({m} finite depths >= 0 "
                                 "in m are required)")
            p[at] = d
    return with_parameters(eqs, p)


def profiles_of(eqs: Equations) -> dict:
    """The wear profiles the equations use: joint -> surface -> node depths (M,) [m]."""
    out = {}
    for joint, surface, _ in eqs.worn:
        out.setdefault(joint, {})[surface] = np.array(eqs.parameters[eqs.layout.slice(f"profiles.{joint}.{surface}")],
                                                      float)
    return out


def build_equations(model: Model, effects: Effects, mode: str, parameters, v_min: float = V_MIN,
                    baumgarte: float = BAUMGARTE_OMEGA, inputs: str = "contact", forces: tuple = ()) -> Equations:
    """The equations of the structure (model, effects, actuation mode) with their input
    ``parameters`` fixed to `parameters` (``Problem.equation_parameters``); use
    :meth:`rrr4.problem.Problem.equations`, which passes its structure keys.

    v_min [m/s] floors the approach velocity delta_dot0; baumgarte = omega_b [rad/s].
    inputs (:data:`INPUTS`): which numbers the parametric equations take as their input
    ``parameters``: 'contact' (default) or 'geometry' (the contact numbers, masses, inertias
    and joint points; about 20 % more instructions, since zeros and ones in the geometry no
    longer simplify, for sweeps over the mechanism). The parametric equations are built on
    every call (``Problem.equations`` keeps them, once per structure and options). forces:
    the scene's force elements (:mod:`rrr4.dynamics.elements`; their numbers follow the
    contact numbers in ``parameters``). Raises SceneError if the actuation mode
    over-constrains the mechanism.
    """
    return with_parameters(parametric_equations(model, effects, mode, v_min, baumgarte, inputs, forces), parameters)


def parametric_equations(model: Model, effects: Effects, mode: str, v_min: float = V_MIN,
                         baumgarte: float = BAUMGARTE_OMEGA, inputs: str = "contact", forces: tuple = ()) -> Equations:
    """The parametric equations of the structure (every number of ``parameters`` an input;
    see :func:`build_equations`), before any numbers are folded in: :func:`with_parameters`
    folds them. Built anew on every call: :meth:`rrr4.problem.Problem.equations` keeps them on
    the structure's Problem (``memo``), the one cache of them."""
    v_min = argument("v_min", v_min)
    baumgarte = argument("baumgarte", baumgarte, allow_zero=True)
    if inputs not in INPUTS:
        raise unknown_value("inputs", "value", inputs, INPUTS)
    par = _parametric(model, effects, mode, float(v_min), float(baumgarte), inputs == "geometry", tuple(forces))
    return replace(par, parametric=par)


# The effects of a scene as terms (rrr4.dynamics.assembly), in the order they add to the
# equations: a new effect is one more term here, its keys on the scene schema and its group
# in the parameter layout (rrr4.dynamics.layout).
TERMS = (ContactTerm, FilmTerm, WearTerm, ForceElementTerm)


def _parametric(model: Model, effects: Effects, mode: str, v_min: float, omega: float, geometry: bool,
                forces: tuple = ()) -> Equations:
    """The equations of a structure (``Problem.plant_key``, or with `geometry`
    ``Problem.geometry_key``), every Function with the input ``parameters`` last."""
    _check_mode(model, mode)
    n, nq, nc = model.n_actuators, model.nq, len(model.clearance_joints)
    t = ca.SX.sym("t")
    q, qd, qdd_s = ca.SX.sym("q", nq), ca.SX.sym("qd", nq), ca.SX.sym("qdd", nq)
    effort, th_ref, thd_ref, thdd_ref = (ca.SX.sym(s, n) for s in ("effort", "theta_ref", "theta_d_ref",
                                                                    "theta_dd_ref"))
    dd0, inc = ca.SX.sym("delta_dot0", nc), ca.SX.sym("in_contact", nc)
    refs = [q, qd, effort, th_ref, thd_ref, thdd_ref, dd0, inc, t]
    ref_names = ["q", "qd", "effort", "theta_ref", "theta_d_ref", "theta_dd_ref", "delta_dot0", "in_contact", "t"]
    layout = parameter_layout(model, effects, forces, geometry_parameters(model.graph).size if geometry else 0)
    P = ca.SX.sym("parameters", layout.size)
    G = P[layout.slice("geometry")] if geometry else None  # masses, inertias, joint points (else constants)
    m_diag = model.masses(G)[0]
    Q = model.gravity_forces(effects.gravity, G)
    if not geometry:
        m_diag, Q = ca.DM(m_diag), ca.SX(ca.DM(Q))
    a = Assembly(model, effects, forces, layout, P, G, v_min, q, qd, t, dd0, inc, Q,
                 labels=["gravity"] if effects.gravity != (0.0, 0.0) else [])
    act = _actuation(a, mode, effort, (th_ref, thd_ref, thdd_ref))
    _add_terms(a)
    con = constraints(a, act, omega)
    sol = solved(a, act, con, m_diag)
    outputs = [("qdd", sol["qdd"]), ("lambda", sol["lam"]), ("tau", sol["tau"]), ("reaction", sol["reaction"]),
               *((k, a.columns[k]) for k in CONTACT_OUTPUTS), ("power_in", sol["power_in"]),
               ("power_damping", a.power_damping), ("power_friction", a.power_friction),
               ("driver_effort", sol["driver_effort"]), *a.outputs]
    # ca.cse merges repeated subexpressions (each body's sin/cos is built once per joint point
    # otherwise): about 11 % fewer instructions on the reference scene.
    acc = ca.Function("acceleration", [*refs, P], ca.cse([e for _, e in outputs]), [*ref_names, "parameters"],
                      [k for k, _ in outputs])
    n_con = con.phi.shape[0]
    lam_s = ca.SX.sym("lambda", n_con)
    res = ca.Function(
        "residual", [q, qd, qdd_s, lam_s] + refs[2:] + [P],
        ca.cse([m_diag * qdd_s + con.phi_q.T @ lam_s - a.Q, con.phi_q @ qdd_s - con.gamma_s, con.phi]),
        ["q", "qd", "qdd", "lambda"] + ref_names[2:] + ["parameters"], ["dynamics", "constraint", "phi"])
    kinetic = 0.5 * ca.dot(qd, m_diag * qd)
    potential = a.potential - ca.dot(ca.SX(model.gravity_forces(effects.gravity, G)), q)
    energy = ca.Function("energy", [q, qd, P], [kinetic, potential], ["q", "qd", "parameters"],
                         ["kinetic", "potential"])
    tree_fns = tree_functions(a, act, con, m_diag, refs[2:], ref_names[2:], dict(outputs))
    actuators = ca.Function("actuator_coordinates", [q, P], [act.theta, act.S], ["q", "parameters"], ["s", "S"])
    return Equations(model, model.clearance_joints, con.ideal, sol["reacting"], mode, tuple(a.labels), (), nq, n,
                     n_con, acc, res, contact_update(a), energy, v_min, omega, actuators, *tree_fns,
                     worn=worn_surfaces(model, effects), layout=layout)


def _check_mode(model: Model, mode: str) -> None:
    n, ideal = model.n_actuators, model.constrained_joints
    dof = model.nq - 2 * len(ideal) - len(model.graph.drivers)
    if mode == "prescribed" and n > dof:
        raise SceneError(f"actuation.mode: 'prescribed' is not allowed here ({n} driving constraints over-constrain "
                         f"a mechanism with {dof} degrees of freedom; use 'torque')")


def _actuation(a: Assembly, mode: str, effort: ca.SX, refs: tuple) -> Actuation:
    """The actuator coordinates and the generalised forces S^T tau of the efforts (virtual
    work): 'torque' -> the input effort, 'free' -> 0, 'prescribed' -> solved with the constraints."""
    model, n = a.model, a.model.n_actuators
    theta = ca.vertcat(*[model.joint_coordinate(a.q, x.joint, a.G) for x in model.graph.actuators]) if n \
        else ca.SX(0, 1)
    S = ca.jacobian(theta, a.q)
    tau = None
    if mode == "torque":
        tau = effort
        a.Q = a.Q + S.T @ tau
        a.labels.append("actuator efforts (the controller's)")
    elif mode == "free":
        tau = ca.SX.zeros(n)
        a.labels.append("free actuators" if n else "no actuators")
    return Actuation(mode, theta, S, S @ a.qd, tau, refs)


def _add_terms(a: Assembly) -> None:
    """Every term of :data:`TERMS` through its phases: start, at each clearance joint shape
    then forces, finish."""
    terms = [term() for term in TERMS]
    for term in terms:
        term.start(a)
    for j, name in enumerate(a.model.clearance_joints):
        joint = clearance_joint(a, j, name)
        for term in terms:
            term.shape(a, joint)
        for term in terms:
            term.at_joint(a, joint)
        a.joints.append(joint)
    for term in terms:
        term.finish(a)
