"""`rrr4.simulate`: the front door of contact-dynamics simulation, and its result.

The scene decides the equations (:func:`rrr4.dynamics.builder.build_equations`); this
module feeds them with references, picks the integrator, rolls it inside compiled CasADi
and collects the results.

References in the 'torque' and 'prescribed' modes: theta_ref(t), theta_d_ref, theta_dd_ref
come from the scene's path through the closed-form IK, inside the graph. tau_ref is the
ideal inverse-dynamics feed-forward tau_p(t) (minimum norm, no preload), built in the graph
too, unless a ``preload`` solution (anything with ``t`` (N,) [s] and ``tau`` (N, n) [N m],
e.g. a PreloadSolution) is given; then tau_ref is that torque, linear between its samples.
In the 'free' mode the actuators carry no torque.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .dynamics.builder import Equations, build_equations, graph_size
from .dynamics.energy import energy_audit_residual, energy_terms
from .errors import SceneError
from .integrators import METHODS, FixedStepIntegrator, System
from .mechanism import Mechanism
from .scene import Scene
from .trajectory import trajectory_function

__all__ = ["Simulation", "simulate", "OVERRIDES"]

OVERRIDES = ("step", "output_rate", "preload", "v_min", "baumgarte", "jit", "progress")


@dataclass(frozen=True)
class Simulation:
    """Result of :func:`simulate`. N output instants (t = 0 included), nc clearance joints.

    t (N,) [s]; q, qd (N, nq); pose, pose_ref (N, 3) [m, m, rad]; platform_error (N,) [m]
    (position distance to the commanded path); tau (N, n) [N m]; contact_force (N, nc, 2)
    [N] on the journal (outboard) body, global frame = the reaction convention;
    normal_force (N, nc) [N]; eccentricity (N, nc, 2) [m]; penetration (N, nc) [m];
    reaction (N, k, 2) [N] of the k ideal passive joints (same convention);
    contact_loss_events: joint -> count of contact -> free-flight transitions (B1..C4, 0 for
    ideal joints); energy: dict of (N,) arrays [J] (see :mod:`rrr4.dynamics.energy`);
    energy_audit_residual = max |W_in - dE - D| / largest energy term; stats: solver
    statistics (method, step, steps, wall time, graph sizes).
    """
    scene: Scene
    clearance_joints: tuple[str, ...]
    ideal_passive_joints: tuple[str, ...]
    terms: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    pose: np.ndarray
    pose_ref: np.ndarray
    platform_error: np.ndarray
    tau: np.ndarray
    contact_force: np.ndarray
    normal_force: np.ndarray
    eccentricity: np.ndarray
    penetration: np.ndarray
    reaction: np.ndarray
    contact_loss_events: dict
    energy: dict
    energy_audit_residual: float
    stats: dict = field(default_factory=dict)


@functools.cache
def reference_function(scene: Scene, feed_forward: bool) -> ca.Function:
    """SX Function 'references': t [s] -> pose_ref (3), theta_ref (n) [rad], theta_d_ref,
    theta_dd_ref, tau_ff (n) [N m] (ideal inverse dynamics tau_p, or 0 without feed-forward)."""
    mech = Mechanism.from_scene(scene)
    t = ca.SX.sym("t")
    pose, pose_d, pose_dd = trajectory_function(scene.path)(t)
    theta = mech.ik_function(pose, ca.DM(mech.modes))[0]
    theta_d = ca.jacobian(theta, t)
    theta_dd = ca.jacobian(theta_d, t)
    if feed_forward:
        from .dynamics.inverse import inverse_dynamics_function
        tau_ff = inverse_dynamics_function(scene)(pose, pose_d, pose_dd)[0]
    else:
        tau_ff = ca.SX.zeros(mech.n)
    return ca.Function("references", [t], [pose, theta, theta_d, theta_dd, tau_ff],
                       ["t"], ["pose_ref", "theta_ref", "theta_d_ref", "theta_dd_ref", "tau_ff"])


_SYSTEMS: dict[tuple[int, int], tuple[Equations, ca.Function, System]] = {}


def _system(eqs: Equations, refs: ca.Function) -> System:
    """The ODE y = [q, qd, W_in, D_damping, D_friction] with discrete z = [delta_dot0,
    in_contact, losses] (nc each) and frame input u = [t_a, t_b, tau_a (n), tau_b (n)].
    Built once per (equations, references) pair (the entry keeps both alive, so their ids
    stay unique keys)."""
    key = (id(eqs), id(refs))
    if key not in _SYSTEMS:
        _SYSTEMS[key] = (eqs, refs, _build_system(eqs, refs))
    return _SYSTEMS[key][2]


def _build_system(eqs: Equations, refs: ca.Function) -> System:
    nq, n, nc = eqs.nq, eqs.n_actuators, len(eqs.clearance_joints)
    t, y, z = ca.SX.sym("t"), ca.SX.sym("y", 2 * nq + 3), ca.SX.sym("z", 3 * nc)
    u = ca.SX.sym("u", 2 + 2 * n)
    q, qd = y[:nq], y[nq:2 * nq]
    dd0, inc, losses = z[:nc], z[nc:2 * nc], z[2 * nc:]
    _, th, th_d, th_dd, tau_ff = refs(t)
    s = ca.fmin(ca.fmax((t - u[0]) / ca.fmax(u[1] - u[0], 1e-300), 0.0), 1.0)
    tau_ref = tau_ff + (1 - s) * u[2:2 + n] + s * u[2 + n:]
    out = eqs.acceleration(q=q, qd=qd, tau_ref=tau_ref, theta_ref=th, theta_d_ref=th_d, theta_dd_ref=th_dd,
                           delta_dot0=dd0, in_contact=inc)
    ydot = ca.vertcat(qd, out["qdd"], out["power_in"], out["power_damping"], out["power_friction"])
    ode = ca.Function("ode", [t, y, z, u], [ydot], ["t", "y", "z", "u"], ["y_dot"])
    dd0n, incn, loss = eqs.contact_update(q, qd, dd0, inc)
    disc = ca.Function("discrete", [t, y, z], [ca.vertcat(dd0n, incn, losses + loss)], ["t", "y", "z"], ["z_next"])
    return System(ode, disc)


def _integrator(scene: Scene, integrator, jit: bool) -> FixedStepIntegrator:
    if hasattr(integrator, "run"):  # an integrator instance (fixed-step or adaptive)
        return integrator
    name = scene.integrator.method if integrator is None else integrator
    if name not in METHODS:
        key = "integrator.method" if integrator is None else "integrator"
        raise SceneError(f"{key}: {name!r} is not available (available now: {', '.join(METHODS)})")
    return METHODS[name].from_settings(scene.integrator, jit=jit)


def _seated_eccentricity(scene: Scene, eqs: Equations, motion, tau0) -> np.ndarray:
    """Eccentricities (2n, 2) [m] of B1..Bn, C1..Cn with each clearance journal resting on
    its bearing wall under the ideal reaction r_j at t = 0 of the torque tau0 (n,) [N m]:
    e_j = -(c_j + delta_j) r_j / |r_j| with K_j delta_j^n = |r_j| (the elastic part of the
    contact law; the contact force on the journal points back to the bearing centre).
    Joints carrying less than 1e-9 N stay centred."""
    from .dynamics.inverse import inverse_dynamics_function
    tau_p, tau_n, r_p, r_n = (np.array(v) for v in inverse_dynamics_function(scene)(*motion))
    alpha = np.linalg.pinv(tau_n) @ (tau0 - tau_p.ravel()) if tau_n.size else np.zeros(0)
    n2 = r_p.shape[1]
    r = r_p.T + sum((a * r_n[:, k * n2:(k + 1) * n2].T for k, a in enumerate(alpha)), np.zeros((n2, 2)))
    names = [j.name for j in scene.joints]
    ecc = np.zeros((n2, 2))
    for j, K in zip(eqs.clearance_joints, eqs.stiffness, strict=True):
        k = names.index(j)
        f = float(np.linalg.norm(r[k]))
        if f > 1e-9:
            delta = (f / K) ** (1.0 / scene.effects.contact.exponent)
            ecc[k] = -(scene.joint(j).radial_clearance + delta) * r[k] / f
    return ecc


def simulate(scene: Scene, integrator=None, t_end: float | None = None, **overrides) -> Simulation:
    """Simulate `scene` from the path's start pose; journals centred, or seated under
    their initial load when the scene says ``initial.journals: seated``.

    integrator: None (the scene's integrator.method), a name from
    :data:`rrr4.integrators.METHODS`, or an integrator instance. t_end [s] defaults to the
    path duration. overrides: step [s] (rounded so a whole number of steps fits one output
    interval), output_rate [Hz] (default: path.sample_rate), preload (object with t, tau),
    v_min [m/s], baumgarte [rad/s], jit (compile the stepping loop), progress (bar).
    """
    bad = sorted(set(overrides) - set(OVERRIDES))
    if bad:
        raise SceneError(f"{bad[0]}: unknown override (allowed: {', '.join(OVERRIDES)})")
    t_end = scene.path.duration if t_end is None else float(t_end)
    rate = float(overrides.get("output_rate") or scene.path.sample_rate)
    h_req = float(overrides.get("step") or scene.integrator.step)
    for key, v in (("t_end", t_end), ("output_rate", rate), ("step", h_req)):
        if not (np.isfinite(v) and v > 0):
            raise SceneError(f"{key}: {v!r} is not allowed (must be a finite number > 0)")
    kw = {k: overrides[k] for k in ("v_min", "baumgarte") if k in overrides}
    eqs = build_equations(scene, **kw)
    method = _integrator(scene, integrator, bool(overrides.get("jit", False)))
    mech = Mechanism.from_scene(scene)
    n, nc = mech.n, len(eqs.clearance_joints)

    n_frames = max(int(round(t_end * rate)), 1)
    dt_out = t_end / n_frames
    spf = max(int(round(dt_out / h_req)), 1)
    h = dt_out / spf
    t_frames = np.linspace(0.0, t_end, n_frames + 1)

    preload = overrides.get("preload")
    feed_forward = eqs.mode == "torque" and preload is None
    refs = reference_function(scene, feed_forward)
    tab = np.zeros((n_frames + 1, n))
    if preload is not None and eqs.mode == "torque":
        pt, ptau = np.asarray(preload.t, float), np.asarray(preload.tau, float)
        tab = np.column_stack([np.interp(t_frames, pt, ptau[:, i]) for i in range(n)])
    u = np.column_stack([t_frames[:-1], t_frames[1:], tab[:-1], tab[1:]])

    pose0, pose_d0, pose_dd0 = (np.array(v).ravel() for v in trajectory_function(scene.path)(0.0))
    q0, qd0, _ = mech.body_motion(pose0, pose_d0 + np.asarray(scene.initial.platform_velocity))
    seated = np.zeros(nc)
    if scene.initial.journals == "seated" and nc and eqs.mode != "free":
        ecc = _seated_eccentricity(scene, eqs, (pose0, pose_d0, pose_dd0), tab[0] + np.array(refs(0.0)[4]).ravel())
        q0 = mech.seated_coordinates(pose0, ecc)
        names = [j.name for j in scene.joints]
        seated = np.array([np.any(ecc[names.index(j)] != 0) for j in eqs.clearance_joints], dtype=float)
    x0 = np.r_[0.0, q0, qd0, 0.0, 0.0, 0.0, np.full(nc, eqs.v_min), seated, np.zeros(nc)]

    system = _system(eqs, refs)
    wall = time.perf_counter()
    X = method.run(system, x0, u, h, spf, progress=bool(overrides.get("progress", False)))
    wall = time.perf_counter() - wall
    X = np.vstack([x0, X])
    nq = eqs.nq
    q, qd = X[:, 1:1 + nq], X[:, 1 + nq:1 + 2 * nq]
    W, Dd, Df = X[:, 1 + 2 * nq], X[:, 2 + 2 * nq], X[:, 3 + 2 * nq]
    z = X[:, 4 + 2 * nq:]
    if not np.all(np.isfinite(X)):
        raise SceneError(f"integrator.step: {h:g} s lets the state blow up (non-finite) with {method.name}; "
                         "use a smaller step")

    N = len(t_frames)
    pose_ref, th, th_d, th_dd, tau_ff = (np.array(v) for v in refs.map(N)(t_frames[None, :]))
    tau_ref = tau_ff + tab.T
    acc = eqs.acceleration.map(N)
    out = acc(q=q.T, qd=qd.T, tau_ref=tau_ref, theta_ref=th, theta_d_ref=th_d, theta_dd_ref=th_dd,
              delta_dot0=z[:, :nc].T, in_contact=z[:, nc:2 * nc].T)
    k = len(eqs.passive_ideal_joints)

    def per_joint(a, rows):
        return np.array(a).reshape(rows, N, -1).transpose(1, 2, 0) if rows == 2 else np.array(a).T

    pose = q[:, 6 * n:6 * n + 3]
    losses = {j: 0 for j in scene.ideal_joints}
    losses.update({j: int(round(v)) for j, v in zip(eqs.clearance_joints, z[-1, 2 * nc:], strict=True)})
    losses = {j.name: losses[j.name] for j in scene.joints}
    energy = energy_terms(eqs.energy, q, qd, W, Dd, Df)
    stats = {"method": method.name, "step": h, "steps": spf * n_frames, "frames": n_frames, "wall_time": wall,
             "jit": method.jit, "graph": {f.name(): graph_size(f) for f in (eqs.acceleration, system.ode)},
             "preload": "given" if preload is not None else ("feed-forward only" if feed_forward else "none")}
    stats.update(getattr(method, "run_stats", {}))
    return Simulation(
        scene=scene, clearance_joints=eqs.clearance_joints, ideal_passive_joints=eqs.passive_ideal_joints,
        terms=eqs.terms, t=t_frames, q=q, qd=qd, pose=pose, pose_ref=pose_ref.T,
        platform_error=np.linalg.norm(pose[:, :2] - pose_ref.T[:, :2], axis=1),
        tau=np.array(out["tau"]).T,
        contact_force=per_joint(out["contact_force"], 2) if nc else np.zeros((N, 0, 2)),
        normal_force=per_joint(out["normal_force"], 1) if nc else np.zeros((N, 0)),
        eccentricity=per_joint(out["eccentricity"], 2) if nc else np.zeros((N, 0, 2)),
        penetration=per_joint(out["penetration"], 1) if nc else np.zeros((N, 0)),
        reaction=per_joint(out["reaction"], 2) if k else np.zeros((N, 0, 2)),
        contact_loss_events=losses, energy=energy, energy_audit_residual=energy_audit_residual(energy),
        stats=stats)
