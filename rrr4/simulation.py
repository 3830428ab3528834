"""`rrr4.simulate`: the front door of contact-dynamics simulation, and its result.

The scene decides the equations (:func:`rrr4.dynamics.builder.build_equations`); this
module feeds them with references, picks the integrator, rolls it inside compiled CasADi
and collects the results.

References in the 'torque' and 'prescribed' modes: theta_ref(t), theta_d_ref, theta_dd_ref
come from the scene's path. An n-RRR scene evaluates them through the closed-form IK,
inside the graph; any other graph with a task body solves its IK by Newton on the output
frames and the right-hand side interpolates them (cubic Hermite in theta and theta_d).
tau_ref is the ideal inverse-dynamics feed-forward tau_p(t) (minimum norm, no preload),
unless a ``preload`` solution (anything with ``t`` (N,) [s] and ``tau`` (N, n) [N m],
e.g. a PreloadSolution) is given; then tau_ref is that torque, linear between its samples.
In the 'free' mode the actuators carry no torque. A graph without a task body moves by its
drivers (prescribed joint coordinates, constraint rows in time).
"""

from __future__ import annotations

import functools
import os
import time
import warnings
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from .dynamics.builder import Equations, build_equations, graph_size
from .dynamics.energy import energy_audit_residual, energy_terms
from .errors import SceneError, SimulationError
from .files import c_compiler
from .integrators import METHODS, FixedStepIntegrator, System
from .mechanism import Mechanism, Model
from .scene import MAX_SAMPLES, Scene, argument, describe, unknown_value
from .trajectory import trajectory_function

__all__ = ["Simulation", "simulate", "OVERRIDES", "default_jit"]

OVERRIDES = ("step", "output_rate", "preload", "v_min", "baumgarte", "jit", "progress", "references")
MAX_STEPS = 1e10  # integrator steps one simulate call may take


@dataclass(frozen=True)
class Simulation:
    """Result of :func:`simulate`. N output instants (t = 0 included), nc clearance joints.

    t (N,) [s]; q, qd, qdd (N, nq); pose, pose_ref (N, 3) [m, m, rad] of the task body (zeros
    without one); platform_error (N,) [m] (position distance to the commanded path); tau
    (N, n) [N m or N]; contact_force (N, nc, 2) [N] on the journal body, global frame (the
    reaction convention when the journal sits on the joint's second body, as in every
    n-RRR); normal_force (N, nc) [N]; eccentricity (N, nc, 2) [m]; penetration (N, nc) [m];
    reaction (N, k, 2) [N] of the k ideal passive revolute joints (force of the first body
    on the second); driver_effort (N, n_drivers) [N m or N]; contact_loss_events: passive
    joint -> count of contact -> free-flight transitions (0 for ideal joints); energy: dict of (N,) arrays [J] (see
    :mod:`rrr4.dynamics.energy`); energy_audit_residual = max |W_in - dE - D| / largest
    energy term; stats: solver statistics (method, step, steps, wall time, graph sizes).
    :meth:`body` gives the (N, 3) pose of any body.
    """
    scene: Scene
    clearance_joints: tuple[str, ...]
    ideal_passive_joints: tuple[str, ...]
    terms: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    pose: np.ndarray
    pose_ref: np.ndarray
    platform_error: np.ndarray
    tau: np.ndarray
    contact_force: np.ndarray
    normal_force: np.ndarray
    eccentricity: np.ndarray
    penetration: np.ndarray
    reaction: np.ndarray
    driver_effort: np.ndarray
    contact_loss_events: dict
    energy: dict
    energy_audit_residual: float
    stats: dict = field(default_factory=dict)

    def body(self, name: str) -> np.ndarray:
        """(N, 3) pose [x, y, theta] [m, m, rad] of the centre of mass of the body `name`."""
        model = Model.of(self.scene.graph)
        if name not in model.body_names:
            raise unknown_value("body", "body", name, model.body_names)
        return model.body_poses(self.q, name)


def reference_function(scene: Scene, feed_forward: bool) -> ca.Function:
    """SX Function 'references': t [s] -> pose_ref (3), theta_ref (n) [rad], theta_d_ref,
    theta_dd_ref, tau_ff (n) [N m] (ideal inverse dynamics tau_p, or 0 without feed-forward).
    Built once per mechanism, gravity and path (not per integrator or initial state)."""
    return _reference_function(replace(scene, name="", description="", source="", integrator=None, initial=None,
                                       actuation=None), feed_forward)


@functools.lru_cache(maxsize=16)
def _reference_function(scene: Scene, feed_forward: bool) -> ca.Function:
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


def _system(eqs: Equations, refs: ca.Function | None) -> System:
    """The ODE y = [q, qd, W_in, D_damping, D_friction] with discrete z = [delta_dot0,
    in_contact, losses] (nc each) and frame input u = [t_a, t_b, tau_a (n), tau_b (n)]
    (given efforts, linear in t), followed, for sampled references (refs None), by theta,
    theta_d, theta_dd, the feed-forward tau_ff and its rate at both frame ends (n each;
    cubic Hermite in theta, theta_d and tau_ff). Built once per (equations, references) pair
    and kept by the equations (the entry holds the references, so its id stays unique)."""
    key = id(refs)
    if key not in eqs.systems:
        eqs.systems[key] = (refs, _build_system(eqs, refs))
    return eqs.systems[key][1]


def _hermite(s, h, a, b, da, db):
    """Cubic Hermite interpolant at s in [0, 1] of an interval of length h [s]."""
    s2, s3 = s * s, s * s * s
    return (2 * s3 - 3 * s2 + 1) * a + (s3 - 2 * s2 + s) * h * da + (3 * s2 - 2 * s3) * b + (s3 - s2) * h * db


def _build_system(eqs: Equations, refs: ca.Function | None) -> System:
    nq, n, nc = eqs.nq, eqs.n_actuators, len(eqs.clearance_joints)
    t, y, z = ca.SX.sym("t"), ca.SX.sym("y", 2 * nq + 3), ca.SX.sym("z", 3 * nc)
    u = ca.SX.sym("u", 2 + 2 * n + (0 if refs is not None else 10 * n))
    q, qd = y[:nq], y[nq:2 * nq]
    dd0, inc, losses = z[:nc], z[nc:2 * nc], z[2 * nc:]
    h = ca.fmax(u[1] - u[0], 1e-300)
    s = ca.fmin(ca.fmax((t - u[0]) / h, 0.0), 1.0)
    tau_ref = (1 - s) * u[2:2 + n] + s * u[2 + n:2 + 2 * n]
    if refs is not None:
        _, th, th_d, th_dd, tau_ff = refs(t)
        tau_ref = tau_ref + tau_ff
    else:
        th_a, th_b, thd_a, thd_b, thdd_a, thdd_b, ff_a, ff_b, ffd_a, ffd_b = (
            u[2 + n * k:2 + n * (k + 1)] for k in range(2, 12))
        th = _hermite(s, h, th_a, th_b, thd_a, thd_b)
        th_d = _hermite(s, h, thd_a, thd_b, thdd_a, thdd_b)
        th_dd = (1 - s) * thdd_a + s * thdd_b
        tau_ref = tau_ref + _hermite(s, h, ff_a, ff_b, ffd_a, ffd_b)
    out = eqs.acceleration(q=q, qd=qd, tau_ref=tau_ref, theta_ref=th, theta_d_ref=th_d, theta_dd_ref=th_dd,
                           delta_dot0=dd0, in_contact=inc, t=t)
    ydot = ca.vertcat(qd, out["qdd"], out["power_in"], out["power_damping"], out["power_friction"])
    ode = ca.Function("ode", [t, y, z, u], [ydot], ["t", "y", "z", "u"], ["y_dot"])
    dd0n, incn, loss = eqs.contact_update(q, qd, dd0, inc)
    disc = ca.Function("discrete", [t, y, z], [ca.vertcat(dd0n, incn, losses + loss)], ["t", "y", "z"], ["z_next"])
    return System(ode, disc)


@dataclass(frozen=True)
class _References:
    """References on the output frames (N,): task pose (N, 3) (zeros without a task),
    actuator theta, theta_d, theta_dd (N, n) and the feed-forward effort (N, n); `function`
    is the closed-form n-RRR reference Function evaluated inside the right-hand side, or
    None when the frame samples are interpolated (cubic Hermite) instead; tau_ff_d (N, n):
    the rate of tau_ff from its cubic spline through the frames (sampled references only)."""
    pose: np.ndarray
    theta: np.ndarray
    theta_d: np.ndarray
    theta_dd: np.ndarray
    tau_ff: np.ndarray
    function: ca.Function | None
    tau_ff_d: np.ndarray | None = None


REFERENCES = ("exact", "sampled")  # where the right-hand side gets its references (see simulate)


def _references(scene: Scene, mech: Mechanism, t_frames: np.ndarray, feed_forward: bool,
                mode: str = "exact") -> _References:
    N, n = len(t_frames), mech.n
    if scene.mechanism is not None and mode == "exact":
        f = reference_function(scene, feed_forward)
        pose, th, th_d, th_dd, tau_ff = (np.array(v).T for v in f.map(N)(t_frames[None, :]))
        return _References(pose, th, th_d, th_dd, tau_ff, f)
    if scene.graph.task is None:
        z = np.zeros((N, n))
        return _References(np.zeros((N, 3)), z, z, z, z, None, z)
    traj = trajectory_function(scene.path)
    pose = np.array(traj.map(N)(t_frames[None, :])[0]).T
    # the references on the path's sample grid (or the frames, if coarser): closed form for an
    # n-RRR, Newton IK and the effort family for any other graph; cubic Hermite / spline
    # interpolation to the frames (error ~ h^4, far below 1e-9 at 1 kHz)
    t_end = float(t_frames[-1])
    n_s = max(int(round(t_end * scene.path.sample_rate)), 1) + 1
    t_s = t_frames if N <= n_s else np.linspace(0.0, t_end, n_s)
    if scene.mechanism is not None:
        f = reference_function(scene, feed_forward)
        _, th, th_d, th_dd, tau_ff = (np.array(v).T for v in f.map(len(t_s))(t_s[None, :]))
    else:
        p_s, pd_s, pdd_s = (np.array(v).T for v in traj.map(len(t_s))(t_s[None, :]))
        k = mech.n_task
        q = mech.path_coordinates(p_s[:, :k])
        _, qdd, th_d, th_dd = mech.motion(q, pd_s[:, :k], pdd_s[:, :k])
        th = np.array(mech.model.actuator_coordinates_function.map(len(t_s))(q.T)[0]).T
        tau_ff = np.zeros((len(t_s), n))
        if feed_forward:
            from .dynamics.family import graph_family
            tau_ff = graph_family(mech, q, qdd, scene.effects.gravity).tau_p
    if len(t_s) < 3:
        return _References(pose, th, th_d, th_dd, tau_ff, None, np.zeros_like(tau_ff))
    ff = CubicSpline(t_s, tau_ff, axis=0)
    if t_s is t_frames:
        return _References(pose, th, th_d, th_dd, tau_ff, None, ff(t_frames, 1))
    return _References(pose, CubicHermiteSpline(t_s, th, th_d, axis=0)(t_frames),
                       CubicHermiteSpline(t_s, th_d, th_dd, axis=0)(t_frames),
                       CubicSpline(t_s, th_dd, axis=0)(t_frames), ff(t_frames), None, ff(t_frames, 1))


_NO_COMPILER_WARNED = False


def default_jit() -> bool:
    """Whether simulate compiles its stepping by default: when a C compiler exists (cached on
    disk, so a scene compiles once), unless the environment sets RRR4_JIT=0. Without a
    compiler it warns once and steps in CasADi's virtual machine, 5 to 10 times slower."""
    global _NO_COMPILER_WARNED
    if os.environ.get("RRR4_JIT", "1").strip() == "0":
        return False
    if c_compiler() is None:
        if not _NO_COMPILER_WARNED:
            warnings.warn("no C compiler found (set CC or install gcc): simulate steps in CasADi's virtual "
                          "machine, several times slower", RuntimeWarning, stacklevel=3)
            _NO_COMPILER_WARNED = True
        return False
    return True


def _integrator(scene: Scene, integrator, jit: bool) -> FixedStepIntegrator:
    if hasattr(integrator, "run"):  # an integrator instance (fixed-step or adaptive)
        return integrator
    name = scene.integrator.method if integrator is None else integrator
    if name not in METHODS:
        raise unknown_value("integrator.method" if integrator is None else "integrator", "integrator", name, METHODS)
    return METHODS[name].from_settings(scene.integrator, jit=jit)


def _seated_offsets(scene: Scene, eqs: Equations, mech: Mechanism, q0, qd0, qdd0, tau0) -> np.ndarray:
    """Offsets (nc, 2) [m] (second joint point - first) of the clearance joints with each
    journal resting on its bearing wall under the ideal reaction r_j at t = 0 of the
    efforts tau0 (n,): -(c_j + delta_j) r_j / |r_j| with K_j delta_j^n = |r_j| (the elastic
    part of the contact law), whichever body carries the journal. Joints carrying less than
    1e-9 N stay centred."""
    from .dynamics.family import graph_family
    fam = graph_family(mech, np.atleast_2d(q0), np.atleast_2d(qdd0), scene.effects.gravity)
    tau_n = fam.tau_n[0]
    alpha = np.linalg.pinv(tau_n) @ (tau0 - fam.tau_p[0]) if tau_n.size else np.zeros(0)
    r = fam.r_p[0] + (fam.r_n[0] @ alpha if alpha.size else 0.0)
    names = mech.model.preload_joints
    out = np.zeros((len(eqs.clearance_joints), 2))
    for k, (j, K) in enumerate(zip(eqs.clearance_joints, eqs.stiffness, strict=True)):
        rj = r[names.index(j)]
        f = float(np.linalg.norm(rj))
        if f > 1e-9:
            delta = (f / K) ** (1.0 / scene.effects.contact.exponent)
            out[k] = -(scene.joint(j).radial_clearance + delta) * rj / f
    return out


def simulate(scene: Scene, integrator=None, t_end: float | None = None, **overrides) -> Simulation:
    """Simulate `scene` from the path's start pose; journals centred, or seated under
    their initial load when the scene says ``initial.journals: seated``.

    integrator: None (the scene's integrator.method), a name from
    :data:`rrr4.integrators.METHODS`, or an integrator instance. t_end [s] defaults to the
    path duration. overrides: step [s] (rounded so a whole number of steps fits one output
    interval), output_rate [Hz] (default: path.sample_rate), preload (object with t, tau),
    v_min [m/s], baumgarte [rad/s], jit (step in compiled C; default: yes when a C compiler
    exists and RRR4_JIT is not 0, see :func:`default_jit`), progress (bar), references:
    'exact' (default; an n-RRR evaluates its closed-form IK and feed-forward inside every
    right-hand side) or 'sampled' (evaluated once per path sample and interpolated, cubic
    Hermite; what a graph scene with a task always does).
    """
    bad = sorted(set(overrides) - set(OVERRIDES))
    if bad:
        raise unknown_value(bad[0], "override", bad[0], OVERRIDES)
    t_end = scene.path.duration if t_end is None else argument("t_end", t_end)
    rate = scene.path.sample_rate if overrides.get("output_rate") is None else argument("output_rate",
                                                                                          overrides["output_rate"])
    h_req = scene.integrator.step if overrides.get("step") is None else argument("step", overrides["step"])
    n_frames = max(int(round(t_end * rate)), 1)
    if n_frames > MAX_SAMPLES or t_end / h_req > MAX_STEPS:
        raise SceneError(f"t_end: {t_end:g} s is not allowed at output rate {rate:g} Hz and step {h_req:g} s "
                         f"(at most {MAX_SAMPLES:g} output frames and {MAX_STEPS:g} steps)")
    preload = overrides.get("preload")
    if preload is not None and not (hasattr(preload, "t") and hasattr(preload, "tau")):
        raise SceneError(f"preload: {describe(preload)} is not allowed (a PreloadSolution from rrr4.solve_preload, or "
                         "an object with t (N,) [s] and tau (N, n))")
    kw = {k: overrides[k] for k in ("v_min", "baumgarte") if k in overrides}
    eqs = build_equations(scene, **kw)
    jit = overrides.get("jit")
    method = _integrator(scene, integrator, default_jit() if jit is None else bool(jit))
    mech = Mechanism.from_scene(scene)
    n, nc = mech.n, len(eqs.clearance_joints)

    dt_out = t_end / n_frames
    spf = max(int(round(dt_out / h_req)), 1)
    h = dt_out / spf
    t_frames = np.linspace(0.0, t_end, n_frames + 1)

    feed_forward = eqs.mode == "torque" and preload is None
    mode = overrides.get("references") or "exact"
    if mode not in REFERENCES:
        raise unknown_value("references", "value", mode, REFERENCES)
    ref = _references(scene, mech, t_frames, feed_forward, mode)
    tab = np.zeros((n_frames + 1, n))
    if preload is not None and eqs.mode == "torque":
        pt, ptau = np.asarray(preload.t, float), np.asarray(preload.tau, float)
        tab = np.column_stack([np.interp(t_frames, pt, ptau[:, i]) for i in range(n)])
    ends = [tab]
    if ref.function is None:
        ends = [tab, ref.theta, ref.theta_d, ref.theta_dd, ref.tau_ff, ref.tau_ff_d]
    u = np.column_stack([t_frames[:-1], t_frames[1:]] + [v for e in ends for v in (e[:-1], e[1:])])

    model = mech.model
    if model.task is not None:
        pose0, pose_d0, pose_dd0 = (np.array(v).ravel() for v in trajectory_function(scene.path)(0.0))
        k = mech.n_task
        target, target_d, target_dd = (pose0[:k], (pose_d0 + np.asarray(scene.initial.platform_velocity))[:k],
                                       pose_dd0[:k])
    else:
        target = mech.driver_targets(0.0)[0]
        target_d = np.array([d.speed for d in scene.graph.drivers])
        target_dd = np.zeros(len(target))
    if scene.mechanism is not None:  # closed form
        q0, qd0, qdd0 = mech.body_motion(target, target_d, target_dd)
    else:
        q0 = mech.assemble(target)
        qd0, qdd0, _, _ = (v.ravel() for v in mech.motion(q0, target_d, target_dd))
    seated = np.zeros(nc)
    if scene.initial.journals == "seated" and nc and (eqs.mode != "free" or scene.graph.drivers):
        offsets = _seated_offsets(scene, eqs, mech, q0, qd0, qdd0, tab[0] + ref.tau_ff[0])
        if scene.mechanism is not None:  # closed form; eccentricities of all passive joints
            ecc = np.zeros((len(scene.joints), 2))
            ecc[[[j.name for j in scene.joints].index(c) for c in eqs.clearance_joints]] = offsets
            q0 = mech.seated_coordinates(target, ecc)
        else:
            q0 = mech.assemble(target, offsets, guess=q0)
        seated = np.any(offsets != 0, axis=1).astype(float)
    x0 = np.r_[0.0, q0, qd0, 0.0, 0.0, 0.0, np.full(nc, eqs.v_min), seated, np.zeros(nc)]

    system = _system(eqs, ref.function)
    wall = time.perf_counter()
    run = method.run(system, x0, u, h, spf, progress=bool(overrides.get("progress", False)))
    X = run.states
    wall = time.perf_counter() - wall
    X = np.vstack([x0, X])
    nq = eqs.nq
    q, qd = X[:, 1:1 + nq], X[:, 1 + nq:1 + 2 * nq]
    W, Dd, Df = X[:, 1 + 2 * nq], X[:, 2 + 2 * nq], X[:, 3 + 2 * nq]
    z = X[:, 4 + 2 * nq:]
    if not np.all(np.isfinite(X)):
        k = int(np.argmax(~np.all(np.isfinite(X), axis=1)))
        raise SimulationError(f"integrator.step: {h:g} s lets the state blow up (non-finite by t = "
                              f"{t_frames[k]:.6g} s) with {method.name}; use a smaller step")

    N = len(t_frames)
    tau_ref = (ref.tau_ff + tab).T
    acc = eqs.acceleration.map(N)
    out = acc(q=q.T, qd=qd.T, tau_ref=tau_ref, theta_ref=ref.theta.T, theta_d_ref=ref.theta_d.T,
              theta_dd_ref=ref.theta_dd.T, delta_dot0=z[:, :nc].T, in_contact=z[:, nc:2 * nc].T, t=t_frames[None, :])
    k = len(eqs.passive_ideal_joints)

    def per_joint(a, rows):
        return np.array(a).reshape(rows, N, -1).transpose(1, 2, 0) if rows == 2 else np.array(a).T

    pose = np.array(model.task_pose_function.map(N)(q.T)).T if model.task else np.zeros((N, 3))
    losses = {j.name: 0 for j in scene.joints}
    losses.update({j: int(round(v)) for j, v in zip(eqs.clearance_joints, z[-1, 2 * nc:], strict=True)})
    energy = energy_terms(eqs.energy, q, qd, W, Dd, Df)
    stats = {"method": method.name, "step": h, "steps": spf * n_frames, "frames": n_frames, "wall_time": wall,
             "jit": method.jit, "graph": {f.name(): graph_size(f) for f in (eqs.acceleration, system.ode)},
             "preload": "given" if preload is not None else ("feed-forward only" if feed_forward else "none")}
    stats.update(run.stats)
    return Simulation(
        scene=scene, clearance_joints=eqs.clearance_joints, ideal_passive_joints=eqs.passive_ideal_joints,
        terms=eqs.terms, t=t_frames, q=q, qd=qd, qdd=np.array(out["qdd"]).T, pose=pose, pose_ref=ref.pose,
        platform_error=np.linalg.norm(pose[:, :2] - ref.pose[:, :2], axis=1),
        tau=np.array(out["tau"]).T,
        contact_force=per_joint(out["contact_force"], 2) if nc else np.zeros((N, 0, 2)),
        normal_force=per_joint(out["normal_force"], 1) if nc else np.zeros((N, 0)),
        eccentricity=per_joint(out["eccentricity"], 2) if nc else np.zeros((N, 0, 2)),
        penetration=per_joint(out["penetration"], 1) if nc else np.zeros((N, 0)),
        reaction=per_joint(out["reaction"], 2) if k else np.zeros((N, 0, 2)),
        driver_effort=np.array(out["driver_effort"]).T.reshape(N, -1),
        contact_loss_events=losses, energy=energy, energy_audit_residual=energy_audit_residual(energy),
        stats=stats)
