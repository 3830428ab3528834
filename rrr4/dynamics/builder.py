"""The equation builder: the one place that decides which terms exist.

From a scene it builds the constrained equations of motion (Nikravesh 1988, ch. 6;
Flores & Ambrosio 2004 for the clearance joints)

    M qdd + Phi_q^T lambda = Q_g + B tau + Q_contact(q, qd),
    Phi_q qdd = gamma - 2 omega_b Phi_dot - omega_b^2 Phi          (Baumgarte 1972)

with exactly the effects the scene asks for:

- Phi holds every joint without clearance (actuated or passive, ``Model.constraints``), one
  row per driver s_d(q) - (initial + speed t) = 0, and in the prescribed mode the driving
  constraints s(q) - theta_ref(t) = 0 (s: actuator coordinates);
- Q_contact has one journal-bearing contact per clearance joint, with the scene's normal
  law; the friction term exists only if the friction law is not 'none'; the oil film's
  force (:mod:`rrr4.contact.lubrication`) only at the clearance joints whose lubrication
  law is not 'none': w(eps) F(min(eps, threshold), eps_dot, whirl), acting at the joint
  centres, handed over to the dry laws between the threshold and eps = 1; the wear profiles
  (:mod:`rrr4.contact.wear`) only at the clearance joints that wear: the penetration is
  |e| - c0 - w(psi) and the normal force acts along its gradient, with the profiles' node
  depths among the input ``parameters``; with no clearance joint there is no contact code at all;
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

Every Function has a last input ``parameters``: the numbers of :func:`equation_parameters`
(the contact numbers; with ``inputs='geometry'`` also masses, inertias and joint points),
so that compiled code built on the equations serves every scene of the same structure.

Reaction convention: reaction[:, j] is the force the joint's first (inboard) body exerts on
its second, global frame (= -lambda); contact_force[:, j] is the force on the journal body,
the same convention when the journal sits on the second body (always in an n-RRR).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from ..checks import argument, unknown_value
from ..contact import (
    clearance_kinematics,
    contact_generalized_forces,
    elastic_force,
    friction_force,
    normal_force,
)
from ..contact.lubrication import film_force, film_rates, film_weight
from ..contact.normal import V_MIN, power
from ..contact.wear import archard_volume_rate, node_depth_rates, profile_depth, spline_slopes, spline_weights
from ..errors import SceneError
from ..functions import fix_last_input
from ..mechanism.model import Model, geometry_parameters
from ..mechanism.tree import tree_map
from ..scene import Effects
from .elements import N_PARAMETERS, force_terms

__all__ = ["Equations", "build_equations", "parametric_equations", "with_parameters", "with_profiles", "profiles_of",
           "INPUTS", "lubricated_joints", "worn_joints", "worn_surfaces", "BAUMGARTE_OMEGA", "JOINT_PARAMETERS",
           "EFFECT_PARAMETERS", "LUBRICATION_PARAMETERS", "WEAR_PARAMETERS"]

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
    # profile's node depths [m] in ``parameters`` (from profile_start) and of the output wear_rate
    worn: tuple = ()
    profile_start: int = 0


# The contact numbers that enter the equations as part of their input ``parameters`` rather
# than as constants: per clearance joint, then the effects'.
JOINT_PARAMETERS = ("stiffness", "journal_radius", "bearing_radius")
EFFECT_PARAMETERS = ("restitution", "damping", "friction_coefficient", "static_coefficient", "v0", "v1",
                     "stribeck_velocity")
# then per lubricated joint (graph order), the film's numbers
LUBRICATION_PARAMETERS = ("viscosity", "length", "threshold")
# then per worn joint (graph order) its wear numbers, then the node depths [m] of every worn
# surface (worn_surfaces): the wear profile is an input, so updating it compiles nothing
WEAR_PARAMETERS = ("coefficient", "hardness", "length")


def lubricated_joints(model: Model, effects: Effects) -> tuple:
    """((name, LubricationEffect), ...) of the clearance joints with an oil film, graph order."""
    films = ((j, effects.lubrication_of(model.graph.joint(j))) for j in model.clearance_joints)
    return tuple((j, f) for j, f in films if f.law != "none")


def worn_joints(model: Model, effects: Effects) -> tuple:
    """((name, WearEffect), ...) of the clearance joints that wear, graph order."""
    wear = ((j, effects.wear_of(model.graph.joint(j))) for j in model.clearance_joints)
    return tuple((j, w) for j, w in wear if w.worn)


def worn_surfaces(model: Model, effects: Effects) -> tuple:
    """((joint, surface, nodes), ...): the wear profiles, in the order of their node depths."""
    return tuple((j, s, w.nodes) for j, w in worn_joints(model, effects) for s in w.worn)


def with_parameters(eqs: Equations, parameters) -> Equations:
    """The equations of `eqs`'s structure with their input ``parameters`` fixed to `parameters`
    (e.g. another wear profile: nothing is rebuilt or compiled)."""
    par = eqs.parametric
    p = np.asarray(parameters, float)
    k = len(JOINT_PARAMETERS)
    return replace(par, stiffness=tuple(p[:k * len(par.clearance_joints):k]), parameters=p, parametric=par,
                   **{k: fix_last_input(getattr(par, k), p) for k in ("acceleration", "residual", "contact_update",
                                                                       "energy", "actuator_coordinates",
                                                                       "tree_acceleration", "tree_state",
                                                                       "tree_coordinates") if getattr(par, k)})


def with_profiles(eqs: Equations, profiles: dict) -> Equations:
    """`eqs` on worn profiles: `profiles` maps joint -> surface -> node depths (M,) [m] (finite,
    >= 0; a profile not given stays as it is). Nothing is rebuilt or compiled. Raises SceneError
    naming a joint, surface or length that does not fit."""
    p = np.array(eqs.parameters, float)
    at = eqs.profile_start
    known = {(j, s): (a, m) for (j, s, m), a in zip(eqs.worn, np.cumsum([at, *(m for *_, m in eqs.worn)]),
                                                     strict=False)}
    for joint, by_surface in profiles.items():
        for surface, depths in by_surface.items():
            if (joint, surface) not in known:
                raise unknown_value("wear", "worn surface", f"{joint}.{surface}", [f"{j}.{s}" for j, s in known])
            a, m = known[(joint, surface)]
            d = np.asarray(depths, float).ravel()
            if d.shape != (m,) or not np.all(np.isfinite(d)) or np.any(d < 0):
                raise SceneError(f"wear: the profile of {joint}.{surface} is not allowed ({m} finite depths >= 0 "
                                 "in m are required)")
            p[int(a):int(a) + m] = d
    return with_parameters(eqs, p)


def profiles_of(eqs: Equations) -> dict:
    """The wear profiles the equations use: joint -> surface -> node depths (M,) [m]."""
    out, at = {}, eqs.profile_start
    for joint, surface, m in eqs.worn:
        out.setdefault(joint, {})[surface] = np.array(eqs.parameters[at:at + m], float)
        at += m
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


def _parametric(model: Model, effects: Effects, mode: str, v_min: float, omega: float, geometry: bool,
                forces: tuple = ()) -> Equations:
    """The equations of a structure (``Problem.plant_key``, or with `geometry`
    ``Problem.geometry_key``), every Function with the input ``parameters`` last."""
    graph = model.graph
    n, nq, nd = model.n_actuators, model.nq, len(graph.drivers)
    clear = model.clearance_joints
    ideal = model.constrained_joints
    dof = nq - 2 * len(ideal) - nd
    if mode == "prescribed" and n > dof:
        raise SceneError(f"actuation.mode: 'prescribed' is not allowed here ({n} driving constraints over-constrain "
                         f"a mechanism with {dof} degrees of freedom; use 'torque')")
    nc = len(clear)

    t = ca.SX.sym("t")
    q, qd, qdd_s = ca.SX.sym("q", nq), ca.SX.sym("qd", nq), ca.SX.sym("qdd", nq)
    effort, th_ref, thd_ref, thdd_ref = (ca.SX.sym(s, n) for s in ("effort", "theta_ref", "theta_d_ref",
                                                                    "theta_dd_ref"))
    dd0, inc = ca.SX.sym("delta_dot0", nc), ca.SX.sym("in_contact", nc)
    refs = [q, qd, effort, th_ref, thd_ref, thdd_ref, dd0, inc, t]
    ref_names = ["q", "qd", "effort", "theta_ref", "theta_d_ref", "theta_dd_ref", "delta_dot0", "in_contact", "t"]

    films = dict(lubricated_joints(model, effects))
    worn = dict(worn_joints(model, effects))
    surfaces = worn_surfaces(model, effects)
    nk0 = (len(JOINT_PARAMETERS) * nc + len(EFFECT_PARAMETERS)) if nc else 0
    nk1 = nk0 + len(LUBRICATION_PARAMETERS) * len(films)
    nk2 = nk1 + len(WEAR_PARAMETERS) * len(worn)  # the profiles' node depths from here
    nk = nk2 + sum(m for _, _, m in surfaces)
    ends = np.cumsum([0, *(m for *_, m in surfaces)])
    starts = {(j, s): nk2 + int(a) for (j, s, _), a in zip(surfaces, ends, strict=False)}
    nf = N_PARAMETERS * len(forces)  # the force elements' numbers after the contact numbers
    P = ca.SX.sym("parameters", nk + nf + (geometry_parameters(graph).size if geometry else 0))
    G = P[nk + nf:] if geometry else None  # masses, inertias, joint points (else constants)
    m_diag = model.masses(G)[0]
    theta = ca.vertcat(*[model.joint_coordinate(q, a.joint, G) for a in graph.actuators]) if n else ca.SX(0, 1)
    S = ca.jacobian(theta, q)
    theta_d = S @ qd
    terms = []
    Q = model.gravity_forces(effects.gravity, G)
    if not geometry:
        m_diag, Q = ca.DM(m_diag), ca.SX(ca.DM(Q))
    if effects.gravity != (0.0, 0.0):
        terms.append("gravity")

    # ---- actuation: generalised forces S^T tau of the actuator efforts (virtual work)
    if mode == "torque":
        tau = effort
        Q = Q + S.T @ tau
        terms.append("actuator efforts (the controller's)")
    elif mode == "free":
        tau = ca.SX.zeros(n)
        terms.append("free actuators" if n else "no actuators")

    # ---- contacts
    ce = effects.contact
    fe = effects.friction
    if nc:
        restitution, damping, mu, mu_s, v0, v1, v_s = ca.vertsplit(P[len(JOINT_PARAMETERS) * nc:nk0])
        fe = replace(fe, coefficient=mu, static_coefficient=mu_s, v0=v0, v1=v1, stribeck_velocity=v_s)
    cols = {k: [] for k in ("f", "fn", "ft", "delta", "delta_dot", "e", "film")}
    wear_rates = []
    V_contact, p_damp, p_fric, p_film = ca.SX(0), ca.SX(0), ca.SX(0), ca.SX(0)
    delta_list = []
    if nc:
        terms.append(f"contact ({ce.law}) at {' '.join(clear)}")
        if fe.law != "none":
            terms.append(f"friction ({fe.law})")
        for law in sorted({f.law for f in films.values()}):
            terms.append(f"lubrication ({law}) at {' '.join(j for j, f in films.items() if f.law == law)}")
        for on in sorted({w.surfaces for w in worn.values()}):
            terms.append(f"wear (Archard, {on}) at {' '.join(j for j, w in worn.items() if w.surfaces == on)}")
    for j, name in enumerate(clear):
        spec = graph.joint(name)
        pts = model.joint_points(q, spec, G)
        p_j, p_b = pts[spec.journal], pts[1 - spec.journal]
        g_j, g_b = ca.jacobian(p_j, q), ca.jacobian(p_b, q)
        i_b, i_j = model.rotation_index(spec.bearing_body), model.rotation_index(spec.journal_body)
        K, r_j, r_b = (P[len(JOINT_PARAMETERS) * j + k] for k in range(len(JOINT_PARAMETERS)))
        e_dot = (g_j - g_b) @ qd
        w_b, w_j = 0 if i_b is None else qd[i_b], 0 if i_j is None else qd[i_j]
        kin = clearance_kinematics(p_j - p_b, e_dot, w_b, w_j, r_j, r_b)
        profiles = []
        if name in worn:  # the worn clearance in the journal's direction: c0 + w_B(psi_B) + w_J(psi_J)
            # the direction of e; (1, 0) for a journal within 1e-3 c of the centre, where the depth
            # does not matter and atan2's derivative would be 0/0
            near = ca.dot(kin.eccentricity, kin.eccentricity) < (1e-3 * (r_b - r_j)) ** 2
            angle = ca.atan2(ca.if_else(near, 0.0, kin.normal[1]), ca.if_else(near, 1.0, kin.normal[0]))
            depth, slope, m = ca.SX(0), ca.SX(0), worn[name].nodes
            grad = ca.SX.zeros(nq)  # d depth / dq: through each surface's angle psi_s = angle - theta_s
            for surface in worn[name].worn:
                at = starts[(name, surface)]
                i_s, r_s = (i_b, r_b) if surface == "bearing" else (i_j, r_j)
                psi = angle - (0 if i_s is None else q[i_s])
                weights = spline_weights(psi, m)
                depth += profile_depth(P[at:at + m], weights)
                s = profile_depth(P[at:at + m], spline_slopes(psi, m))  # dw_s / dpsi_s [m/rad]
                slope += s
                if i_s is not None:
                    grad[i_s] -= s
                profiles.append((weights, r_s, m))
            tilt = ca.if_else(near, 0.0, slope / (kin.penetration + r_b - r_j))  # d depth / d(e . t), |e| > 0
            grad += (g_j - g_b).T @ (tilt * kin.tangent)
            kin = replace(kin, penetration=kin.penetration - depth, delta_dot=kin.delta_dot - ca.dot(grad, qd))
        dd0_eff = ca.if_else(inc[j] > 0.5, dd0[j], ca.fmax(kin.delta_dot, v_min))
        fn = normal_force(ce.law, kin.penetration, kin.delta_dot, dd0_eff, K, ce.exponent, restitution, damping,
                          v_min)
        f_el = elastic_force(kin.penetration, K, ce.exponent)
        ft = friction_force(fe, kin.v_t, fn) if fe.law != "none" else ca.SX(0)
        Qc, f = contact_generalized_forces(kin, fn, ft, g_b, g_j, i_b, i_j, r_j, r_b, nq)
        Q = Q + Qc
        if profiles:  # the normal along the worn surface's: -F_n d delta / dq; Archard onto the nodes
            Q = Q + fn * grad
            f = f + fn * tilt * kin.tangent
            k_w, hardness, length = (P[nk1 + len(WEAR_PARAMETERS) * list(worn).index(name) + k]
                                     for k in range(len(WEAR_PARAMETERS)))
            volume_rate = archard_volume_rate(k_w, hardness, fn, kin.v_t)
            wear_rates += [node_depth_rates(volume_rate, w, length, r_s, m) for w, r_s, m in profiles]
        f_film = ca.SX.zeros(2)
        if name in films:  # the oil film, at the joint centres (its pressure passes through them)
            mu_oil, length, eps_t = (P[nk0 + len(LUBRICATION_PARAMETERS) * list(films).index(name) + k]
                                     for k in range(len(LUBRICATION_PARAMETERS)))
            c = r_b - r_j
            eps = (kin.penetration + c) / c
            A, B = film_rates(eps, kin.delta_dot, ca.dot(e_dot, kin.tangent), w_j, w_b, c)
            f_r, f_s = film_force(films[name].law, ca.fmin(eps, eps_t), A, B, r_j, length, mu_oil, c)
            f_film = film_weight(eps, eps_t) * (f_r * kin.normal + f_s * kin.tangent)
            Q = Q + (g_j - g_b).T @ f_film
            f = f + f_film
            p_film += -ca.dot(f_film, e_dot)
        V_contact += K * power(ca.fmax(kin.penetration, 0.0), ce.exponent + 1) / (ce.exponent + 1)
        if ce.law != "hertz":
            p_damp += (fn - f_el) * kin.delta_dot
        if fe.law != "none":
            p_fric += -ft * kin.v_t
        for k, v in zip(cols, (f, fn, ft, kin.penetration, kin.delta_dot, kin.eccentricity, f_film), strict=True):
            cols[k].append(v)
        delta_list.append(kin.penetration)

    def stack(key, rows):
        return ca.horzcat(*cols[key]) if nc else ca.SX(rows, 0)

    contact_force, ecc = stack("f", 2), stack("e", 2)
    p_damp += p_film
    # ---- force elements: spring-dampers and loads, only when the scene has them
    elements = force_terms(model, forces, q, qd, t, P[nk:nk + nf])
    if forces:
        Q = Q + elements.Q
        V_contact += elements.potential
        p_damp += elements.power_damping
        terms.append("force elements " + " ".join(f"{e.name} ({e.type})" for e in forces))
    fn_v, ft_v, delta_v, dd_v = (ca.vertcat(*cols[k]) if nc else ca.SX(0, 1)
                                 for k in ("fn", "ft", "delta", "delta_dot"))

    # ---- constraints: ideal joints, drivers (+ driving constraints), Baumgarte-stabilised
    phi, phi_q, gamma = model.constraint_terms(q, qd, ideal, bool(nd), G)
    phi_dot = phi_q @ qd
    if nd:
        value, rate, acc_d = model.driver_values(t)
        off = ca.vertcat(ca.SX.zeros(2 * len(ideal)), value)
        phi, phi_dot = phi - off, phi_dot - ca.vertcat(ca.SX.zeros(2 * len(ideal)), rate)
        gamma = gamma + ca.vertcat(ca.SX.zeros(2 * len(ideal)), acc_d)
        terms.append("drivers " + " ".join(f"{d.name} ({d.joint})" for d in graph.drivers))
    if mode == "prescribed":
        phi = ca.vertcat(phi, theta - th_ref)
        phi_q = ca.vertcat(phi_q, S)
        gamma = ca.vertcat(gamma, thdd_ref - ca.jtimes(theta_d, q, qd))
        phi_dot = ca.vertcat(phi_dot, theta_d - thd_ref)
        terms.append("prescribed actuator coordinates (driving constraints)")
    gamma_s = gamma - 2 * omega * phi_dot - omega**2 * phi
    n_con = phi.shape[0]
    m_inv = 1.0 / m_diag
    lam = ca.solve(phi_q @ ca.diag(m_inv) @ phi_q.T, phi_q @ (m_inv * Q) - gamma_s)
    qdd = m_inv * (Q - phi_q.T @ lam)
    if mode == "prescribed":
        tau = -lam[n_con - n:]
    reacting = tuple(j for j in model.ideal_passive_joints if graph.joint(j).type == "revolute")
    rows = [2 * ideal.index(j) + c for j in reacting for c in (0, 1)]
    reaction = ca.reshape(-lam[rows], 2, len(reacting)) if reacting else ca.SX(2, 0)
    power_in = ca.dot(tau, theta_d)
    if mode == "free":
        power_in = ca.SX(0)
    # drivers: effort -lambda_d on their coordinate [N m or N]; power -lambda_d . (S_d qd)
    drv = lam[2 * len(ideal):2 * len(ideal) + nd] if nd else ca.SX(0, 1)
    driver_effort = -drv
    if nd:
        power_in = power_in + ca.dot(driver_effort, phi_q[2 * len(ideal):2 * len(ideal) + nd, :] @ qd)
    if forces:
        power_in = power_in + elements.power_load

    # ca.cse merges repeated subexpressions (each body's sin/cos is built once per joint point
    # otherwise): about 11 % fewer instructions on the reference scene.
    film_out = ([stack("film", 2), p_film], ["film_force", "power_film"]) if films else ([], [])
    wear_rate = ca.vertcat(*wear_rates)
    if worn:
        film_out = ([*film_out[0], wear_rate], [*film_out[1], "wear_rate"])
    acc = ca.Function(
        "acceleration", [*refs, P],
        ca.cse([qdd, lam, tau, reaction, contact_force, fn_v, ft_v, delta_v, dd_v, ecc, power_in, p_damp, p_fric,
                driver_effort, *film_out[0]]),
        [*ref_names, "parameters"],
        ["qdd", "lambda", "tau", "reaction", "contact_force", "normal_force", "friction_force", "penetration",
         "delta_dot", "eccentricity", "power_in", "power_damping", "power_friction", "driver_effort", *film_out[1]])

    lam_s = ca.SX.sym("lambda", n_con)
    res = ca.Function(
        "residual", [q, qd, qdd_s, lam_s] + refs[2:] + [P],
        ca.cse([m_diag * qdd_s + phi_q.T @ lam_s - Q, phi_q @ qdd_s - gamma_s, phi]),
        ["q", "qd", "qdd", "lambda"] + ref_names[2:] + ["parameters"], ["dynamics", "constraint", "phi"])

    now = ca.vertcat(*[d > 0 for d in delta_list]) if nc else ca.SX(0, 1)
    prev = inc > 0.5
    onset = ca.logic_and(now, ca.logic_not(prev))
    dd0_next = ca.if_else(onset, ca.fmax(dd_v, v_min), ca.if_else(now, dd0, v_min)) if nc else ca.SX(0, 1)
    loss = ca.logic_and(prev, ca.logic_not(now)) if nc else ca.SX(0, 1)
    upd = ca.Function("contact_update", [q, qd, dd0, inc, P], [dd0_next, now, loss],
                      ["q", "qd", "delta_dot0", "in_contact", "parameters"],
                      ["delta_dot0_next", "in_contact_next", "loss"])

    kinetic = 0.5 * ca.dot(qd, m_diag * qd)
    potential = V_contact - ca.dot(ca.SX(model.gravity_forces(effects.gravity, G)), q)
    energy = ca.Function("energy", [q, qd, P], [kinetic, potential], ["q", "qd", "parameters"],
                         ["kinetic", "potential"])

    # ---- the same equations in tree coordinates p (velocity transformation q = q(p), qd = J pd)
    tree = tree_map(model, G)
    tree_fns = (None, None, None)
    if tree.tree_joints:
        p, pd = tree.p, ca.SX.sym("pd", tree.p.shape[0])
        J = ca.jacobian(tree.q, p)
        jd = ca.jtimes(J @ pd, p, pd)  # dJ/dt pd

        def on_tree(e):
            return ca.substitute(e, ca.vertcat(q, qd), ca.densify(ca.vertcat(tree.q, J @ pd)))

        rows = [2 * ideal.index(j) + c for j in tree.closures for c in (0, 1)] + list(range(2 * len(ideal), n_con))
        M_t = J.T @ (m_diag * J)
        rhs = J.T @ (on_tree(Q) - m_diag * jd)
        lam_t = ca.SX(0, 1)
        if rows:  # loop closures, drivers and driving constraints stay constraints
            phi_p = on_tree(phi_q[rows, :]) @ J
            gamma_p = on_tree(gamma_s[rows]) - on_tree(phi_q[rows, :]) @ jd
            m_phi = ca.solve(M_t, phi_p.T)
            lam_t = ca.solve(phi_p @ m_phi, phi_p @ ca.solve(M_t, rhs) - gamma_p)
            rhs = rhs - phi_p.T @ lam_t
        pdd = ca.solve(M_t, rhs)
        tau_t = -lam_t[lam_t.shape[0] - n:] if mode == "prescribed" else tau
        power_t = ca.SX(0) if mode == "free" else ca.dot(tau_t, on_tree(theta_d))
        if nd:
            k = 2 * len(tree.closures)
            power_t += ca.dot(-lam_t[k:k + nd], on_tree(phi_q[2 * len(ideal):2 * len(ideal) + nd, :] @ qd))
        if forces:
            power_t += on_tree(elements.power_load)
        coordinate = ca.substitute(tree.coordinate, tree.q_symbols, q)
        wear_t = ([on_tree(wear_rate)], ["wear_rate"]) if worn else ([], [])
        tree_fns = (
            ca.Function("tree_acceleration", [p, pd, *refs[2:], P],
                        ca.cse([pdd, power_t, on_tree(p_damp), on_tree(p_fric), *wear_t[0]]),
                        ["p", "pd", *ref_names[2:], "parameters"], ["pdd", "power_in", "power_damping",
                                                                    "power_friction", *wear_t[1]]),
            ca.Function("tree_state", [p, pd, P], [tree.q, J @ pd], ["p", "pd", "parameters"], ["q", "qd"]),
            ca.Function("tree_coordinates", [q, qd, P], [coordinate, ca.jtimes(coordinate, q, qd)],
                        ["q", "qd", "parameters"], ["p", "pd"]))

    actuators = ca.Function("actuator_coordinates", [q, P], [theta, S], ["q", "parameters"], ["s", "S"])
    return Equations(model, clear, ideal, reacting, mode, tuple(terms), (), nq, n, n_con, acc, res, upd,
                     energy, v_min, omega, actuators, *tree_fns, worn=surfaces, profile_start=nk2)
