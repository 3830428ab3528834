"""The controller: one CasADi Function per scene, run by the simulation and written to C.

Torque mode (DESIGN sections 1.3(b) and 7). A controller step maps the references and the
measured actuator coordinates and rates to actuator efforts:

    tau = clip(tau_ff + kp wrap(theta_ref - theta) + kd (theta_d_ref - theta_d), +-limit)

(:func:`feedback_function`; the angle error of a revolute actuator wrapped to [-pi, pi)).
For an n-RRR scene the whole step is one closed-form SX Function,
:func:`controller_function` ('controller_step'): from the desired pose and its first three
derivatives it computes

- the ideal inverse dynamics, the affine family tau = tau_p + alpha tau_n;
- the preload alpha with the scene's ``actuation.preload``: ``exact`` on a fixed branch,
  ``qp`` (the fixed-sign axial-force QP, solved in closed form for one degree of
  redundancy), or none (``method: none`` or ``min_force: 0``: alpha = 0);
- the references theta_ref, theta_d_ref: the IK of the pose, or with ``actuation.compensation:
  clearance`` the IK with every clearance journal at its predicted seat (below), and its
  rate with the seats held (their drift is below 1 % of the remaining error on the
  reference scene, and following it would triple the instructions);
- the feedback law above.

`rrr4.simulate` runs this Function (inlined in CasADi, or its generated C in the loop
through ``casadi.external``) and ``rrr4.codegen`` writes it: there is no second controller.

Clearance compensation. Under preload each clearance journal rests on the side of its
bearing that the planned reaction r_j pushes it to: its gap (second joint point minus
first) is g_j = -(c_j + delta_j) r_j / |r_j| with K_j delta_j^n = |r_j| (the elastic part
of the contact law). An n-RRR chain closes around its two gaps exactly like an ideal chain
whose platform point is moved by -(g_B + g_C) (:func:`rrr4.mechanism.kinematics.chain_ik`),
so the compensated IK is closed form. A joint carrying less than ``SEAT_FORCE`` is assumed
centred (its seat is undetermined).

A general graph scene has no closed-form controller: its references (IK by Newton, the
effort family by SVD, the preload from :func:`rrr4.solve_preload`, the compensated IK by
Newton around the predicted gaps) are tabulated on the path samples (:func:`graph_references`)
and the same feedback law runs on them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from .dynamics.builder import contact_parameters, fix_last_input
from .errors import SceneError
from .mechanism import Mechanism, Model
from .scene import FrictionEffect, Scene
from .scene.vocabulary import COMPENSATIONS

__all__ = ["controller_function", "parametric_controller", "controller_settings", "feedback_function",
           "parametric_feedback", "feedback_settings", "has_preload", "pointwise_controller", "preload_law",
           "preload_sign",
           "seat_gaps", "graph_references", "GraphReferences", "COMPENSATIONS", "CONTROLLERS", "SEAT_FORCE"]

CONTROLLERS = ("python", "generated")   # simulate(controller=...): CasADi's VM/JIT, or the codegen C
SEAT_FORCE = 1e-6  # [N] below this planned reaction a journal's seat is undetermined: assumed centred


def has_preload(scene: Scene) -> bool:
    """True if the scene's controller preloads: redundancy, min_force > 0 and a method other than none."""
    p = scene.actuation.preload
    return Model.of(scene.graph).redundancy >= 1 and p.min_force > 0 and p.method != "none"


def pointwise_controller(scene: Scene) -> str:
    """'' if the scene's controller is one closed-form Function (:func:`controller_function`),
    else why not (then the simulation tabulates its references)."""
    if scene.mechanism is None:
        return "a graph scene has no closed-form IK (its references are tabulated on the path samples)"
    if has_preload(scene):
        m = Model.of(scene.graph).redundancy
        if m > 1:
            return f"a pointwise preload in closed form needs one degree of redundancy, the scene has {m}"
        if scene.actuation.preload.method == "nlp":
            return "the 'nlp' preload is a trajectory optimisation, not a pointwise law"
    return ""


def _sign(scene: Scene) -> int:
    """The fixed preload sign (+1 / -1) that :func:`rrr4.solve_preload` picks for the scene's
    method on its path: feasible at more samples, ties -> less effort."""
    return _signs(replace(scene, name="", description="", source="", integrator=None, initial=None))


@functools.lru_cache(maxsize=32)
def _signs(scene: Scene) -> int:
    from .dynamics.family import effort_family
    from .preload.solve import _choose_signs
    from .trajectory import sample_path
    s = sample_path(scene.path)
    raw = effort_family(scene, s.pose, s.pose_d, s.pose_dd).raw
    p = scene.actuation.preload
    return int(_choose_signs(scene, raw, p.qp_solver, exact=p.method == "exact")[0])


def preload_sign(scene: Scene) -> int:
    """The controller's fixed preload sign: +1 / -1 (the exact branch or the QP's axial-force
    sign that :func:`rrr4.solve_preload` picks on the path), 0 without a preload."""
    return _sign(scene) if has_preload(scene) else 0


def preload_law(scene: Scene, sign: int | None = None) -> ca.Function | None:
    """The pointwise preload of the scene's controller, an SX Function tau_p, tau_n, r_p, r_n
    -> alpha, tau, feasible, margin (None without a preload): the exact law on the branch
    `sign`, or the closed-form QP with that axial-force sign (default: :func:`rrr4.solve_preload`'s
    choice on the path)."""
    law = _parametric_law(scene)
    if law is None:
        return None
    p = scene.actuation.preload
    return fix_last_input(law, _law_settings(scene, p.weights, scene.actuation.torque_limit, p.min_force,
                                             _sign(scene) if sign is None else int(sign)))


def _law_settings(scene: Scene, weights, limits, f_min, sign):
    """The input ``settings`` of the scene's preload law (numbers or symbols): weights,
    limits, f_min, then the exact law's branch, or the QP's axial-force sign of every joint."""
    signs = [sign] * len(Model.of(scene.graph).preload_joints) if scene.actuation.preload.method == "qp" else [sign]
    return ca.vertcat(*weights, *limits, f_min, *signs)


def _parametric_law(scene: Scene) -> ca.Function | None:
    """The preload law of :func:`preload_law` with its numbers (weights, limits, f_min, sign)
    as the last input ``settings`` (:func:`_law_settings`)."""
    if not has_preload(scene):
        return None
    why = pointwise_controller(scene)
    if why and scene.mechanism is not None:
        raise SceneError(f"actuation.preload.method: {scene.actuation.preload.method!r} is not allowed in a "
                         f"controller step ({why}; choose exact or qp, or pass preload= to simulate)")
    model = Model.of(scene.graph)
    n, nj = model.n_actuators, len(model.preload_joints)
    if scene.actuation.preload.method == "exact":
        from .preload.exact import parametric_exact_preload
        return parametric_exact_preload(n, nj)
    from .preload.qp import parametric_scalar_qp_preload
    return parametric_scalar_qp_preload(n, nj)


def seat_gaps(scene: Scene, r, slip=None):
    """Predicted gaps (2, nj) [m] (second joint point - first) of the passive revolute joints
    (``Model.preload_joints`` order) under their planned reactions r (2, nj) [N] (force of
    the first body on the second), 0 at ideal joints. SX or numeric; a reaction below
    SEAT_FORCE leaves its joint centred.

    The journal seats where the contact force balances r: normal force f_n along -n and
    friction f_t = mu f_n along t = E n, with mu the scene's friction law at the slip
    velocity slip (nj,) [m/s] (R_J omega_J - R_B omega_B; None or law 'none': mu = 0). Then
    gap = -(c + delta) (r + mu E r) / (sqrt(1 + mu^2) |r|) with K delta^n = f_n = |r| / sqrt(1 + mu^2),
    whichever body carries the journal."""
    gaps, _ = _seats(scene, r, slip, contact_parameters(scene))
    return np.array(ca.evalf(gaps)) if not isinstance(r, (ca.SX, ca.MX)) else gaps


def _contact_numbers(scene: Scene, contact) -> tuple[dict, FrictionEffect]:
    """({clearance joint: (K [N/m^n], journal radius, bearing radius [m])}, the friction law
    with its coefficients) read from `contact`, the vector of
    :func:`rrr4.dynamics.builder.contact_parameters` (numbers or symbols)."""
    from .dynamics.builder import JOINT_PARAMETERS
    k, clear = len(JOINT_PARAMETERS), Model.of(scene.graph).clearance_joints
    per = {name: tuple(contact[k * j + i] for i in range(k)) for j, name in enumerate(clear)}
    mu, mu_s, v0, v1, v_s = (contact[k * len(clear) + 2 + i] for i in range(5))
    fe = replace(scene.effects.friction, coefficient=mu, static_coefficient=mu_s, v0=v0, v1=v1, stribeck_velocity=v_s)
    return per, fe


def _seats(scene: Scene, r, slip, contact):
    """(gaps (2, nj) [m], friction forces f_t (nj,) [N]) of :func:`seat_gaps`, symbolic, with
    the contact numbers from `contact` (see :func:`_contact_numbers`)."""
    from .contact import friction_force
    names = Model.of(scene.graph).preload_joints
    per, fe = _contact_numbers(scene, contact) if scene.clearance_joints else ({}, scene.effects.friction)
    n_exp = scene.effects.contact.exponent
    cols, f_t = [], []
    for j, name in enumerate(names):
        if name not in per:
            cols.append(ca.DM.zeros(2))
            f_t.append(0.0)
            continue
        stiffness, r_journal, r_bearing = per[name]
        rj = r[:, j]
        mu = 0.0 if slip is None or fe.law == "none" else friction_force(fe, slip[j], 1.0)
        f = ca.norm_2(rj)
        root = ca.sqrt(1 + mu**2)
        f_n = f / root
        delta = (f_n / stiffness) ** (1.0 / n_exp)
        g = -(r_bearing - r_journal + delta) * (rj + mu * ca.vertcat(-rj[1], rj[0])) / (
            root * ca.fmax(f, SEAT_FORCE))
        cols.append(ca.if_else(f > SEAT_FORCE, g, ca.DM.zeros(2)))
        f_t.append(mu * f_n)
    return ca.horzcat(*cols), ca.vertcat(*f_t)


def _nrrr_slip(scene: Scene, pose, pose_d, contact=None):
    """Slip velocities (2n,) [m/s] R_J omega_J - R_B omega_B of the passive joints B1..Bn,
    C1..Cn of an n-RRR at the desired motion (journals on the outboard bodies); the radii of
    the clearance joints from `contact` (default: the scene's, see :func:`_contact_numbers`)."""
    from .dynamics.inverse import _chain_motion, _link_rates, _transmission
    mech = Mechanism.from_scene(scene)
    per = {} if not scene.clearance_joints else _contact_numbers(
        scene, contact_parameters(scene) if contact is None else contact)[0]

    def radii(name):
        j = scene.joint(name)
        return per[name][1:] if name in per else (j.journal_radius, j.bearing_radius)

    cs = (ca.cos(pose[2]), ca.sin(pose[2]))
    b, c = [], []
    for i, ch in enumerate(mech.data.chains):
        u1, e, _, cd_rel, _, _ = _chain_motion(ch, pose[0:2], pose_d[2], 0, cs)
        w1, w2 = _link_rates(ch, u1, e, pose_d[0:2] + cd_rel, _transmission(ch, u1, e)[2])
        (rb_j, rb_b), (rc_j, rc_b) = radii(f"B{i + 1}"), radii(f"C{i + 1}")
        b.append(rb_j * w2 - rb_b * w1)
        c.append(rc_j * pose_d[2] - rc_b * w2)
    return ca.vertcat(*b, *c)


def _friction_feed_forward(scene: Scene, pose, pose_d, slip, f_t):
    """Actuator torques (n,) [N m] that overcome the friction moments of the seated clearance
    journals (minimum norm): by virtual power, J^T dtau = -G^T f_t with f_t (nj,) [N] the
    friction forces at the planned normal forces and G = d slip / d pose_d (slip is linear
    in the platform twist)."""
    from .dynamics.inverse import joint_reactions_function
    G = ca.jacobian(slip, pose_d)
    J = joint_reactions_function(scene)(pose, pose_d, pose_d)[5]  # J depends on the pose only
    return J @ ca.solve(J.T @ J, -G.T @ f_t)


def feedback_function(scene: Scene) -> ca.Function:
    """SX Function 'feedback': theta_ref, theta_d_ref, tau_ff, theta, theta_d (n each) ->
    tau (n,) = clip(tau_ff + kp e + kd (theta_d_ref - theta_d), +-limit), e = theta_ref -
    theta wrapped to [-pi, pi) for revolute actuators [rad], as is for prismatic ones [m]."""
    return fix_last_input(parametric_feedback(scene), feedback_settings(scene))


def feedback_settings(scene: Scene) -> list[float]:
    """The feedback law's input ``settings``: kp, kd, torque limits (n)."""
    a = scene.actuation
    return [a.kp, a.kd, *a.torque_limit]


def parametric_feedback(scene: Scene) -> ca.Function:
    """:func:`feedback_function` with the input ``settings`` (:func:`feedback_settings`) last."""
    model = Model.of(scene.graph)
    return _feedback(tuple(scene.graph.joint(j).type == "revolute" for j in model.actuated_joints))


@functools.cache
def _feedback(revolute: tuple[bool, ...]) -> ca.Function:
    n = len(revolute)
    th_ref, thd_ref, ff, th, thd = (ca.SX.sym(s, n) for s in ("theta_ref", "theta_d_ref", "tau_ff", "theta",
                                                               "theta_d"))
    settings = ca.SX.sym("settings", 2 + n)
    kp, kd, lim = settings[0], settings[1], settings[2:]
    d = th_ref - th
    wrap = ca.DM([1.0 if r else 0.0 for r in revolute])
    e = d - wrap * 2 * ca.pi * ca.floor((d + ca.pi) / (2 * ca.pi))
    tau = ca.fmin(ca.fmax(ff + kp * e + kd * (thd_ref - thd), -lim), lim)
    return ca.Function("feedback", [th_ref, thd_ref, ff, th, thd, settings], [tau],
                       ["theta_ref", "theta_d_ref", "tau_ff", "theta", "theta_d", "settings"], ["tau"])


def controller_function(scene: Scene, sign: int | None = None) -> ca.Function:
    """SX Function 'controller_step' of an n-RRR scene: pose_des, pose_d_des, pose_dd_des,
    (3 each) [m, rad and their rates], theta, theta_d (n each) [rad, rad/s] ->
    tau (n,) [N m] (clipped), tau_ff (n,) [N m] (inverse dynamics + preload), theta_ref,
    theta_d_ref (n,) [rad, rad/s] (compensated if the scene says so), alpha (m,) [N m],
    feasible (1.0 / 0.0; 1.0 without a preload).

    sign: the preload branch / axial-force sign (default: :func:`preload_law`'s). The
    scene's numbers are folded in as constants (what ``rrr4 codegen`` writes); the same graph
    with them as an input is :func:`parametric_controller`.
    Raises SceneError for a scene without a closed-form controller (:func:`pointwise_controller`).
    """
    return fix_last_input(parametric_controller(scene), controller_settings(scene, sign))


def controller_settings(scene: Scene, sign: int | None = None) -> np.ndarray:
    """The numbers of the controller step that :func:`parametric_controller` takes as its
    input ``settings``: kp, kd, torque limits (n) (:func:`feedback_settings`), the preload's
    weights (n), f_min [N] and sign (+1 / -1; 0 without a preload), then, with clearance
    compensation, the contact numbers (:func:`rrr4.dynamics.builder.contact_parameters`)."""
    a, n = scene.actuation, Model.of(scene.graph).n_actuators
    s = 0 if not has_preload(scene) else (_sign(scene) if sign is None else int(sign))
    out = [*feedback_settings(scene), *a.preload.weights[:n], a.preload.min_force, float(s)]
    return np.array([*out, *(contact_parameters(scene) if _compensates(scene) else [])], float)


def _compensates(scene: Scene) -> bool:
    return scene.actuation.compensation == "clearance" and bool(scene.clearance_joints)


def parametric_controller(scene: Scene) -> ca.Function:
    """:func:`controller_function` with the input ``settings`` (:func:`controller_settings`)
    last: one Function for every scene of the same structure (mechanism, gravity, preload
    method, compensation, friction law), so that compiled code built on it is shared by
    scenes that differ only in gains, limits, f_min, the preload's sign or contact numbers."""
    why = pointwise_controller(scene)
    if why:
        key = "mechanism.kind" if scene.mechanism is None else "actuation.preload.method"
        raise SceneError(f"{key}: no closed-form controller step for scene {scene.name!r} ({why}; choose exact or "
                         "qp for the preload)" if scene.mechanism is not None else
                         f"{key}: no closed-form controller step for scene {scene.name!r} ({why})")
    from .dynamics.builder import _structure
    a, n = scene.actuation, Model.of(scene.graph).n_actuators
    preload = replace(a.preload, min_force=float(a.preload.min_force > 0), weights=(1.0,) * n, qp_solver="qrqp",
                      smoothness_weight=0.0, max_turn_rate=0.0)  # the last three: not in a pointwise law
    neutral = replace(a, kp=0.0, kd=0.0, torque_limit=(1.0,) * n, control_rate=None, preload=preload)
    return _controller(replace(_structure(scene), name="", description="", source="", path=None, integrator=None,
                               initial=None, actuation=neutral))


@functools.lru_cache(maxsize=32)
def _controller(scene: Scene) -> ca.Function:
    from .dynamics.inverse import actuator_motion_function, inverse_dynamics_function
    mech = Mechanism.from_scene(scene)
    n = mech.n
    pose, pose_d, pose_dd = (ca.SX.sym(s, 3) for s in ("pose_des", "pose_d_des", "pose_dd_des"))
    theta, theta_d = ca.SX.sym("theta", n), ca.SX.sym("theta_d", n)
    compensates = _compensates(scene)
    n_contact = contact_parameters(scene).size if compensates else 0
    settings = ca.SX.sym("settings", 2 * n + 4 + n_contact)
    gains, weights, f_min_sign, contact = (settings[:2 + n], settings[2 + n:2 + 2 * n], settings[2 + 2 * n:4 + 2 * n],
                                           settings[4 + 2 * n:])
    tau_p, tau_n, r_p, r_n = inverse_dynamics_function(scene)(pose, pose_d, pose_dd)
    law = _parametric_law(scene)
    if law is None:
        alpha, tau_ff, feasible = ca.SX.zeros(tau_n.shape[1]), tau_p, ca.SX(1.0)
    else:
        alpha, tau_ff, feasible, _ = law(tau_p, tau_n, r_p, r_n, _law_settings(
            scene, ca.vertsplit(weights), ca.vertsplit(gains[2:]), f_min_sign[0], f_min_sign[1]))
    if compensates:
        r = r_p + (alpha * r_n if alpha.numel() else 0)
        slip = _nrrr_slip(scene, pose, pose_d, contact)
        gap, f_t = _seats(scene, r, slip, contact)
        if scene.effects.friction.law != "none":
            tau_ff = tau_ff + _friction_feed_forward(scene, pose, pose_d, slip, f_t)
        # the IK closed around the seats; its rate at fixed seats (their drift adds < 1 % of
        # the remaining error on the reference scene, for a third of the instructions)
        u_ref, theta_d_ref = actuator_motion_function(scene)(pose, pose_d, gap[:, :n] + gap[:, n:])
    else:
        # theta_ref from the driving-link directions the inverse dynamics computes anyway
        u_ref, theta_d_ref = actuator_motion_function(scene)(pose, pose_d, ca.SX.zeros(2, n))
    theta_ref = ca.atan2(u_ref[1, :], u_ref[0, :]).T
    tau = parametric_feedback(scene)(theta_ref, theta_d_ref, tau_ff, theta, theta_d, gains)
    return ca.Function("controller_step", [pose, pose_d, pose_dd, theta, theta_d, settings],
                       ca.cse([tau, tau_ff, theta_ref, theta_d_ref, alpha, feasible]),
                       ["pose_des", "pose_d_des", "pose_dd_des", "theta", "theta_d", "settings"],
                       ["tau", "tau_ff", "theta_ref", "theta_d_ref", "alpha", "feasible"])


@dataclass(frozen=True)
class GraphReferences:
    """Controller references of a scene on a time grid t (N,) [s]: theta_ref, theta_d_ref,
    theta_dd_ref, tau_ff (N, n) (actuator coordinates [rad or m], their rates, the
    feed-forward efforts [N m or N] with the preload), alpha (N, m), pose (N, 3)."""
    t: np.ndarray
    pose: np.ndarray
    theta_ref: np.ndarray
    theta_d_ref: np.ndarray
    theta_dd_ref: np.ndarray
    tau_ff: np.ndarray
    alpha: np.ndarray


def graph_references(scene: Scene, t: np.ndarray, preload=None) -> GraphReferences:
    """The controller references of any scene with a task body at the times t (N,) [s]:
    IK by Newton along the path, the effort family, the preload (``preload``: an object
    with t and tau, e.g. a PreloadSolution, else :func:`rrr4.solve_preload` with the scene's
    method when it preloads) and, with compensation, the Newton IK around the predicted
    journal seats. Rates of compensated references by central differences of the IK over
    +-1e-4 of a sample step (second order, error ~ 1e-10 rad/s on the reference scene)."""
    from .dynamics.family import graph_family
    from .trajectory import trajectory_function
    mech = Mechanism.from_scene(scene)
    model, N, k = mech.model, len(t), mech.n_task
    traj = trajectory_function(scene.path)
    p, pd, pdd = (np.array(v).T for v in traj.map(N)(t[None, :]))
    if scene.mechanism is not None:  # closed form
        q = np.array(mech.body_motion_function.map(N)(p.T, pd.T, pdd.T)[0]).T
    else:
        q = mech.path_coordinates(p[:, :k])
    _, qdd, th_d, th_dd = mech.motion(q, pd[:, :k], pdd[:, :k])
    th = np.array(model.actuator_coordinates_function.map(N)(q.T)[0]).T
    fam = graph_family(mech, q, qdd, scene.effects.gravity)
    m = fam.tau_n.shape[2]
    alpha = np.zeros((N, m))
    tau_ff = fam.tau_p
    if preload is not None:
        tau_ff = np.column_stack([np.interp(t, preload.t, np.asarray(preload.tau)[:, i]) for i in range(mech.n)])
        alpha = np.einsum("knm,kn->km", fam.tau_n, tau_ff - fam.tau_p)
    elif has_preload(scene):
        from .preload.solve import solve_preload
        sol = solve_preload(scene, branch="auto")  # exact: one branch, as the n-RRR controller
        alpha = np.column_stack([np.interp(t, sol.t, np.asarray(sol.alpha).reshape(len(sol.t), -1)[:, i])
                                 for i in range(m)])
        tau_ff = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, alpha)
    if scene.actuation.compensation == "clearance" and scene.clearance_joints:
        r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, alpha)
        W = _slip_rows(scene, model)
        qd = mech.motion(q, pd[:, :k], pdd[:, :k])[0]
        slip = qd @ W.T
        dt = 1e-4 * (t[1] - t[0] if N > 1 else 1e-3)
        th, f_t = _compensated_ik(scene, mech, p[:, :k], r, slip, q)
        shifted = [_compensated_ik(scene, mech, p[:, :k] + s * dt * pd[:, :k], r + s * dt * np.gradient(r, t, axis=0),
                                   slip, q)[0] for s in (1.0, -1.0)]
        th_d = (shifted[0] - shifted[1]) / (2 * dt)
        th_dd = np.gradient(th_d, t, axis=0) if N > 2 else np.zeros_like(th_d)
        if scene.effects.friction.law != "none":  # the friction moments, by virtual power (see the n-RRR step)
            V, S = mech.velocity_maps(q)
            J, G = S @ V, W @ V
            rhs = -np.einsum("kjt,kj->kt", G, f_t)
            JtJ = np.einsum("knt,kns->kts", J, J)
            tau_ff = tau_ff + np.einsum("knt,kt->kn", J, np.linalg.solve(JtJ, rhs[..., None])[..., 0])
    return GraphReferences(t, p, th, th_d, th_dd, tau_ff, alpha)


def _slip_rows(scene: Scene, model: Model) -> np.ndarray:
    """W (nj, nq): slip velocities R_J omega_J - R_B omega_B = W qd of the passive revolute
    joints (``Model.preload_joints``; zero rows for ideal joints)."""
    W = np.zeros((len(model.preload_joints), model.nq))
    for j, name in enumerate(model.preload_joints):
        spec = scene.graph.joint(name)
        if not spec.clearance:
            continue
        for body, radius in ((spec.journal_body, spec.journal_radius), (spec.bearing_body, -spec.bearing_radius)):
            i = model.rotation_index(body)
            if i is not None:
                W[j, i] += radius
    return W


def _compensated_ik(scene: Scene, mech: Mechanism, task: np.ndarray, r: np.ndarray, slip: np.ndarray,
                    guess: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Actuator coordinates (N, n) that put the task at `task` (N, k) with every clearance
    joint opened by its predicted seat under the reactions r (N, nj, 2) and slip velocities
    (N, nj), by Newton; and the seated journals' friction forces f_t (N, nj) [N]."""
    model = mech.model
    names = model.preload_joints
    clear = [names.index(j) for j in model.clearance_joints]
    out, f_t = np.empty((len(task), mech.n)), np.zeros((len(task), len(names)))
    contact = contact_parameters(scene)
    for i in range(len(task)):
        gaps, ft = _seats(scene, ca.DM(r[i].T), ca.DM(slip[i]), contact)
        offsets = np.array(ca.evalf(gaps)).T[clear]
        f_t[i] = np.array(ca.evalf(ft)).ravel()
        qi = mech.assemble(task[i], offsets, guess=guess[i])
        out[i] = np.array(model.actuator_coordinates_function(qi)[0]).ravel()
    return out, f_t
