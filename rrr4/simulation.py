"""`rrr4.simulate`: the front door of contact-dynamics simulation, and its result.

The scene decides the equations (:func:`rrr4.dynamics.builder.build_equations`); this
module feeds them with references, picks the integrator, rolls it inside compiled CasADi
and collects the results.

Torque mode: the efforts are the scene's controller's (:mod:`rrr4.control`: feed-forward,
preload, compensation, PD), run continuously inside the right-hand side or sampled at
``actuation.control_rate`` with a zero-order hold (then the right-hand side only takes the
held efforts). An n-RRR scene runs its closed-form controller step (in CasADi, or its
generated C in the loop); any other graph with a task body tabulates the controller's
references on the path samples and runs the same feedback law on them, interpolated
(cubic Hermite). A ``preload`` override (anything with ``t`` (N,) [s] and ``tau`` (N, n),
e.g. a PreloadSolution) replaces the controller's feed-forward.

Prescribed mode: theta_ref(t), theta_d_ref, theta_dd_ref from the path's IK (closed form for
an n-RRR, inside the graph; Newton and interpolation for other graphs). In the 'free' mode
the actuators carry no effort. A graph without a task body moves by its drivers
(prescribed joint coordinates, constraint rows in time).
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

from .checks import argument, describe, unknown_value
from .control import (
    CONTROLLERS,
    GraphReferences,
    controller_function,
    controller_settings,
    feedback_settings,
    graph_references,
    has_preload,
    parametric_controller,
    parametric_feedback,
    pointwise_controller,
)
from .dynamics.builder import Equations, build_equations, graph_size
from .dynamics.energy import energy_audit_residual, energy_terms
from .errors import SceneError, SimulationError
from .files import c_compiler
from .integrators import METHODS, FixedStepIntegrator, FrameInputs, System, evaluate
from .mechanism import Mechanism, Model
from .scene import MAX_SAMPLES, PathSpec, Scene
from .trajectory import trajectory_function

__all__ = ["Simulation", "simulate", "scene_system", "OVERRIDES", "default_jit"]

OVERRIDES = ("step", "output_rate", "preload", "v_min", "baumgarte", "jit", "progress", "references", "controller",
             "model", "inputs")
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
    energy term; stats: solver statistics (method, step, steps, graph sizes; wall_time [s]: the
    stepping, without making its frame inputs, input_time [s]).
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


def reference_function(scene: Scene) -> ca.Function:
    """SX Function 'references' of an n-RRR scene: t [s] -> pose_ref (3), theta_ref (n) [rad],
    theta_d_ref, theta_dd_ref (the closed-form IK of the path, for the prescribed mode).
    Built once per mechanism and path (not per integrator or initial state)."""
    return _reference_function(replace(scene, name="", description="", source="", integrator=None, initial=None,
                                       actuation=None))


@functools.lru_cache(maxsize=16)
def _reference_function(scene: Scene) -> ca.Function:
    mech = Mechanism.from_scene(scene)
    t = ca.SX.sym("t")
    pose = trajectory_function(scene.path)(t)[0]
    theta = mech.ik_function(pose, ca.DM(mech.modes))[0]
    theta_d = ca.jacobian(theta, t)
    theta_dd = ca.jacobian(theta_d, t)
    return ca.Function("references", [t], [pose, theta, theta_d, theta_dd],
                       ["t"], ["pose_ref", "theta_ref", "theta_d_ref", "theta_dd_ref"])


def _hermite(s, h, a, b, da, db):
    """Cubic Hermite interpolant at s in [0, 1] of an interval of length h [s]."""
    s2, s3 = s * s, s * s * s
    return (2 * s3 - 3 * s2 + 1) * a + (s3 - 2 * s2 + s) * h * da + (3 * s2 - 2 * s3) * b + (s3 - s2) * h * db


REFERENCES = ("exact", "sampled")  # where the right-hand side gets its references (see simulate)


@dataclass(frozen=True)
class _Loop:
    """How the efforts enter the right-hand side.

    kind: 'exact' (the controller step, or the prescribed-mode IK, is evaluated inside the
    right-hand side at the path's time; frame input u = [t_a, t_b]); 'sampled' (the
    references are interpolated between the frame ends, cubic Hermite, and the feedback law
    runs inside the right-hand side; u = [t_a, t_b] + 10 n end values); 'held' (a sampled
    controller with zero-order hold: it runs once per frame = control period, u_frame =
    [t_a, t_b, references at t_a], and the right-hand side takes the held efforts).
    control: the controller step (pointwise: pose and its derivatives -> efforts), the
    feedback law (tabulated references), or None (free and prescribed modes); its last input
    is `settings`, the scene's numbers of it (gains, limits, preload), which the simulation
    carries in its discrete state so that compiled code does not depend on them.
    """
    kind: str
    control: ca.Function | None
    pointwise: bool
    path: PathSpec | None = None  # the path a pointwise controller follows inside the right-hand side
    sources: tuple = ()
    settings: tuple = ()


def _measured(model: Model, q, qd, eqs: Equations | None = None, parameters=None):
    """Actuator coordinates theta (n,) and rates theta_d = S qd of a state (symbolic); with
    the parametric equations `eqs`, from their actuator coordinates at `parameters` (a
    prismatic actuator's coordinate depends on its joint's points, which may be inputs)."""
    theta, S = (model.actuator_coordinates_function(q) if eqs is None else
                eqs.actuator_coordinates(q, parameters))
    return theta, S @ qd


def _system(eqs: Equations, loop: _Loop, refs: ca.Function | None, tree: bool = False) -> System:
    """The ODE y = [q, qd, W_in, D_damping, D_friction] (with `tree`, the tree coordinates
    p, pd instead of q, qd: see :mod:`rrr4.mechanism.tree`) with discrete z = [delta_dot0,
    in_contact, losses] (nc each) followed by the equations' parameters (contact numbers,
    masses and geometry, see :func:`rrr4.dynamics.builder.equation_parameters`) and the
    controller's settings (both constant: the discrete update keeps them), and the frame
    inputs of `loop` (see :class:`_Loop`). The numbers are state, not constants, so every
    scene that differs only in them steps with the same compiled code.
    refs: the prescribed mode's closed-form references (or None). Built once per (equations,
    loop, references) and kept by the equations (the entry holds them, so its key stays unique)."""
    key = (loop.kind, id(loop.control), loop.path if loop.kind == "exact" else None, id(refs), tree)
    if key not in eqs.systems:
        eqs.systems[key] = (loop, refs, _build_system(eqs, loop, refs, tree))
    return eqs.systems[key][2]


def _build_system(eqs: Equations, loop: _Loop, refs: ca.Function | None, tree: bool) -> System:
    model = Model.of(eqs.scene.graph)
    par = eqs.parametric
    n, nc = eqs.n_actuators, len(eqs.clearance_joints)
    nq = par.tree_acceleration.size1_in(0) if tree else eqs.nq  # the coordinates stepped
    ns = len(loop.settings)
    t, y, z = ca.SX.sym("t"), ca.SX.sym("y", 2 * nq + 3), ca.SX.sym("z", 3 * nc + len(eqs.parameters) + ns)
    width = {"exact": 0, "sampled": 10 * n, "held": n}[loop.kind]
    u = ca.SX.sym("u", 2 + width)
    dd0, inc, losses = z[:nc], z[nc:2 * nc], z[2 * nc:3 * nc]
    parameters, settings = z[3 * nc:3 * nc + len(eqs.parameters)], z[3 * nc + len(eqs.parameters):]

    def configuration(y, parameters):
        """(q, qd) of the state y: its first entries, or from the tree coordinates."""
        return par.tree_state(y[:nq], y[nq:2 * nq], parameters) if tree else (y[:nq], y[nq:2 * nq])

    q, qd = configuration(y, parameters)
    zeros = ca.SX.zeros(n)
    th, th_d, th_dd, effort = zeros, zeros, zeros, zeros
    if loop.kind == "held":
        effort = u[2:2 + n]
    elif loop.kind == "sampled":
        h = ca.fmax(u[1] - u[0], 1e-300)
        s = ca.fmin(ca.fmax((t - u[0]) / h, 0.0), 1.0)
        th_a, th_b, thd_a, thd_b, thdd_a, thdd_b, ff_a, ff_b, ffd_a, ffd_b = (
            u[2 + n * k:2 + n * (k + 1)] for k in range(10))
        th = _hermite(s, h, th_a, th_b, thd_a, thd_b)
        th_d = _hermite(s, h, thd_a, thd_b, thdd_a, thdd_b)
        th_dd = (1 - s) * thdd_a + s * thdd_b
        if eqs.mode == "torque":
            effort = loop.control(th, th_d, _hermite(s, h, ff_a, ff_b, ffd_a, ffd_b),
                                  *_measured(model, q, qd, par, parameters), settings)
    elif eqs.mode == "torque":  # exact: the controller step at the path's time
        effort = loop.control(*trajectory_function(loop.path)(t), *_measured(model, q, qd, par, parameters),
                              settings)[0]
    elif refs is not None:
        _, th, th_d, th_dd = refs(t)
    refs_in = dict(effort=effort, theta_ref=th, theta_d_ref=th_d, theta_dd_ref=th_dd, delta_dot0=dd0, in_contact=inc,
                   t=t, parameters=parameters)
    if tree:
        out = par.tree_acceleration(p=y[:nq], pd=y[nq:2 * nq], **refs_in)
        ydot = ca.vertcat(y[nq:2 * nq], out["pdd"], out["power_in"], out["power_damping"], out["power_friction"])
    else:
        out = par.acceleration(q=q, qd=qd, **refs_in)
        ydot = ca.vertcat(qd, out["qdd"], out["power_in"], out["power_damping"], out["power_friction"])
    ode = ca.Function("ode", [t, y, z, u], [ydot], ["t", "y", "z", "u"], ["y_dot"])
    dd0n, incn, loss = par.contact_update(q, qd, dd0, inc, parameters)
    disc = ca.Function("discrete", [t, y, z], [ca.vertcat(dd0n, incn, losses + loss, parameters, settings)],
                       ["t", "y", "z"], ["z_next"])
    control = None
    if loop.kind == "held":
        k = loop.control.size1_in(0)  # pose derivatives (3 each) or actuator references (n each): 3 blocks
        ym, zm, uf = ca.MX.sym("y", y.shape[0]), ca.MX.sym("z", z.shape[0]), ca.MX.sym("u_frame", 2 + 3 * k)
        pm = zm[3 * nc:3 * nc + len(eqs.parameters)]
        meas = _measured(model, *configuration(ym, pm), par, pm)
        args = [uf[2 + i * k:2 + (i + 1) * k] for i in range(3)]
        eff = loop.control(*args, *meas, zm[z.shape[0] - ns:])
        eff = eff[0] if isinstance(eff, (list, tuple)) else eff
        control = ca.Function("control", [ym, zm, uf], [ca.vertcat(uf[:2], eff)], ["y", "z", "u_frame"], ["u"])
    return System(ode, disc, control, loop.sources, n_events=3 * nc)
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


def _tabulated(scene: Scene, t: np.ndarray, given) -> GraphReferences:
    """The controller's references on the grid t (N,) [s]: the closed-form controller's own
    outputs where it has one (an n-RRR without a given preload), else
    :func:`rrr4.control.graph_references` (Newton IK, the effort family, the preload)."""
    if given is None and not pointwise_controller(scene):
        f = controller_function(scene)
        rows = _path_rows(scene, t)
        n = f.size1_in(3)
        out = f.map(len(t))(*(rows[:, 3 * k:3 * k + 3].T for k in range(3)), np.zeros((n, len(t))),
                            np.zeros((n, len(t))))
        _, ff, th, th_d, alpha, _ = (np.array(v).T for v in out)
        th_dd = CubicSpline(t, th_d, axis=0)(t, 1) if len(t) > 2 else np.zeros_like(th_d)
        return GraphReferences(t, rows[:, :3], th, th_d, th_dd, ff, alpha.reshape(len(t), -1))
    return graph_references(scene, t, given)


def _path_rows(scene: Scene, t: np.ndarray) -> np.ndarray:
    """(N, 9) [pose, pose_d, pose_dd] of the path at the times t (N,)."""
    out = _mapped(trajectory_function(scene.path), t=np.asarray(t, float)[None, :])
    return np.vstack(list(out.values())).T


def _loop(scene: Scene, eqs: Equations, controller: str, references: str, given) -> _Loop:
    """How this run's efforts are made (see :class:`_Loop`) by the controller of `scene` (the
    controller's model); raises SceneError for a combination that does not exist (a
    generated controller without a closed form or rate)."""
    held = eqs.mode == "torque" and scene.actuation.control_rate is not None
    if eqs.mode != "torque":
        kind = "sampled" if references == "sampled" or (scene.mechanism is None and scene.graph.task) else "exact"
        return _Loop(kind, None, False, scene.path)
    why = pointwise_controller(scene) or ("a feed-forward is given (preload=)" if given is not None else "") or (
        "references='sampled' tabulates the references" if references == "sampled" else "")
    if controller == "generated":
        if why:
            raise SceneError(f"controller: 'generated' is not allowed here ({why}; the generated C is the "
                             "closed-form controller step of an n-RRR scene)")
        if not held:
            raise SceneError("controller: 'generated' is not allowed without actuation.control_rate (the generated "
                             "controller runs as a sampled controller with zero-order hold: set a rate in Hz)")
        from .codegen import generated_controller
        step, source = generated_controller(scene)
        return _Loop("held", _without_settings(step), True, None, (source,))
    if why:
        return _Loop("held" if held else "sampled", parametric_feedback(scene), False, None,
                     settings=tuple(feedback_settings(scene)))
    return _Loop("held" if held else "exact", parametric_controller(scene), True, scene.path if not held else None,
                 settings=tuple(controller_settings(scene)))


@functools.lru_cache(maxsize=16)
def _without_settings(step: ca.Function) -> ca.Function:
    """`step` with an empty last input ``settings`` (the generated C holds the scene's numbers),
    one per step, so that the systems built on it are found again."""
    ins = [ca.MX.sym(step.name_in(i), step.sparsity_in(i)) for i in range(step.n_in())]
    return ca.Function(step.name(), [*ins, ca.MX.sym("settings", 0)], step(*ins), [*step.name_in(), "settings"],
                       step.name_out())


def scene_system(scene: Scene, references: str = "exact", controller: str = "python") -> System:
    """The ODE System :func:`simulate` steps for `scene` (torque mode: its controller
    continuous or held, see :class:`_Loop`), e.g. to time its right-hand side."""
    eqs = build_equations(scene)
    loop = _loop(scene, eqs, controller, references, None)
    refs = reference_function(scene) if eqs.mode == "prescribed" and scene.mechanism is not None else None
    return _system(eqs, loop, refs if loop.kind == "exact" else None, _in_tree(scene, eqs))


def _in_tree(scene: Scene, eqs: Equations) -> bool:
    """Whether the integrator steps tree coordinates (``integrator.coordinates``: 'auto' takes
    them wherever the ideal joints form a tree); raises SceneError for 'tree' without one."""
    c = scene.integrator.coordinates
    if c == "tree" and eqs.tree_acceleration is None:
        raise SceneError("integrator.coordinates: 'tree' is not allowed here (no ideal joint joins a body to the "
                         "ground or to a placed body; use auto or reference-point)")
    return c != "reference-point" and eqs.tree_acceleration is not None


def _grid(t_end: float, n: int, k) -> np.ndarray:
    """``np.linspace(0, t_end, n + 1)[k]`` bit for bit, for the indices k, without the rest
    (a long run's frame ends are made a block at a time)."""
    k = np.asarray(k)
    return np.where(k == n, t_end, k * (t_end / n))


def _interpolated(t_s: np.ndarray, th, th_d, th_dd, ff):
    """t -> {th, thd, thdd, ff, ffd} at the times t: references tabulated at the times t_s,
    interpolated cubic Hermite in theta (with theta_d) and theta_d (with theta_dd), cubic
    splines in theta_dd and the feed-forward (ffd: its rate); error ~ h^4, far below 1e-9 at
    1 kHz. With two samples (a run of one frame, t_s its ends) the samples themselves."""
    hermite = CubicHermiteSpline(t_s, th, th_d, axis=0), CubicHermiteSpline(t_s, th_d, th_dd, axis=0)
    if len(t_s) > 2:
        spline_dd, spline_ff = CubicSpline(t_s, th_dd, axis=0), CubicSpline(t_s, ff, axis=0)
        return lambda t: {"th": hermite[0](t), "thd": hermite[1](t), "thdd": spline_dd(t), "ff": spline_ff(t),
                          "ffd": spline_ff(t, 1)}
    return lambda t: {"th": hermite[0](t), "thd": hermite[1](t), "thdd": th_dd[np.searchsorted(t_s, t)],
                      "ff": ff[np.searchsorted(t_s, t)], "ffd": np.zeros((len(t), ff.shape[1]))}


def _frames(scene: Scene, t_end: float, rate: float, held: bool) -> tuple[int, int]:
    """(number of frames, frames per output): frames are the output intervals, or the
    control periods of a sampled controller (then every m-th frame is an output)."""
    if not held:
        return max(int(round(t_end * rate)), 1), 1
    c = scene.actuation.control_rate
    n = int(round(t_end * c))
    if n < 1 or abs(n - t_end * c) > 1e-6 * max(1.0, t_end * c):
        raise SceneError(f"actuation.control_rate: {c:g} Hz is not allowed with t_end {t_end:g} s (the run must be "
                         "a whole number of control periods)")
    m = max(int(round(c / rate)), 1)
    while n % m:
        m -= 1
    return n, m


def simulate(scene: Scene, integrator=None, t_end: float | None = None, **overrides) -> Simulation:
    """Simulate `scene` from the path's start pose; journals centred, or seated under
    their initial load when the scene says ``initial.journals: seated``.

    In torque mode the actuators get what the scene's controller (:mod:`rrr4.control`)
    commands: inverse-dynamics feed-forward, the preload of ``actuation.preload`` and the
    clearance compensation of ``actuation.compensation``, with PD feedback on the measured
    actuator coordinates; continuously, or sampled at ``actuation.control_rate`` with a
    zero-order hold.

    integrator: None (the scene's integrator.method), a name from
    :data:`rrr4.integrators.METHODS`, or an integrator instance. t_end [s] defaults to the
    path duration. overrides: step [s] (rounded so a whole number of steps fits one output
    interval or control period), output_rate [Hz] (default: path.sample_rate; with a sampled
    controller, at most its rate), controller: 'python' (default; the controller step in
    CasADi) or 'generated' (the C that :func:`rrr4.codegen` writes, compiled with the C
    compiler and called through ``casadi.external``; needs a control rate), preload (object
    with t, tau, e.g. a PreloadSolution: the feed-forward efforts instead of the controller's
    own), model (a Scene: the controller's model of the simulated mechanism, default the scene
    itself; e.g. nominal parameters against a mechanism built with tolerances), v_min [m/s],
    baumgarte [rad/s], jit (step in compiled C; default: yes when a C
    compiler exists and RRR4_JIT is not 0, see :func:`default_jit`), progress (bar),
    references: 'exact' (default; an n-RRR controller runs its closed form inside every
    right-hand side, or at every control instant when sampled) or 'sampled' (its references,
    feed-forward included, evaluated once per path sample and interpolated, cubic Hermite:
    only the feedback law is compiled; what a graph scene with a task always does), inputs:
    which of the scene's numbers the compiled stepping takes as inputs rather than constants
    (see :func:`rrr4.dynamics.builder.build_equations`; the controller's gains, limits and
    preload numbers always are): 'contact' (default) or 'geometry' (with references='sampled',
    scenes that differ in masses and geometry then share one compiled library).
    """
    bad = sorted(set(overrides) - set(OVERRIDES))
    if bad:
        raise unknown_value(bad[0], "override", bad[0], OVERRIDES)
    t_end = scene.path.duration if t_end is None else argument("t_end", t_end)
    rate = scene.path.sample_rate if overrides.get("output_rate") is None else argument("output_rate",
                                                                                          overrides["output_rate"])
    h_req = scene.integrator.step if overrides.get("step") is None else argument("step", overrides["step"])
    if t_end * rate > MAX_SAMPLES or t_end / h_req > MAX_STEPS:
        raise SceneError(f"t_end: {t_end:g} s is not allowed at output rate {rate:g} Hz and step {h_req:g} s "
                         f"(at most {MAX_SAMPLES:g} output frames and {MAX_STEPS:g} steps)")
    given = overrides.get("preload")
    if given is not None and not (hasattr(given, "t") and hasattr(given, "tau")):
        raise SceneError(f"preload: {describe(given)} is not allowed (a PreloadSolution from rrr4.solve_preload, or "
                         "an object with t (N,) [s] and tau (N, n))")
    controller = overrides.get("controller") or "python"
    if controller not in CONTROLLERS:
        raise unknown_value("controller", "value", controller, CONTROLLERS)
    mode = overrides.get("references") or "exact"
    if mode not in REFERENCES:
        raise unknown_value("references", "value", mode, REFERENCES)
    kw = {k: overrides[k] for k in ("v_min", "baumgarte", "inputs") if k in overrides}
    eqs = build_equations(scene, **kw)
    jit = overrides.get("jit")
    method = _integrator(scene, integrator, default_jit() if jit is None else bool(jit))
    mech = Mechanism.from_scene(scene)
    model = mech.model
    n, nc = mech.n, len(eqs.clearance_joints)
    model_scene = overrides.get("model") or scene
    if not isinstance(model_scene, Scene) or (Model.of(model_scene.graph).actuator_names != model.actuator_names):
        raise SceneError(f"model: {describe(model_scene)} is not allowed (a Scene of the same mechanism, with the "
                         "same actuators: the controller's model of the simulated one)")
    model_scene = replace(model_scene, path=scene.path)  # one commanded path
    loop = _loop(model_scene, eqs, controller, mode, given)
    held = loop.kind == "held"

    n_frames, every = _frames(model_scene, t_end, rate, held)
    dt = t_end / n_frames
    spf = max(int(round(dt / h_req)), 1)
    h = dt / spf
    if n_frames > MAX_SAMPLES or n_frames * spf > MAX_STEPS:
        raise SceneError(f"actuation.control_rate: {model_scene.actuation.control_rate:g} Hz is not allowed over "
                         f"{t_end:g} s (at most {MAX_SAMPLES:g} control periods and {MAX_STEPS:g} steps)")
    t_grid = functools.partial(_grid, t_end, n_frames)  # frame ends, by index
    t_out = t_grid(np.arange(0, n_frames + 1, every))

    # frame inputs, made a block of frames at a time while the run steps them
    refs = None
    refs_at = None  # t -> the tabulated references at the times t (see _interpolated)
    if loop.kind == "sampled" or (loop.kind == "held" and not loop.pointwise):
        # references on the path's sample grid (or the frames, if coarser), interpolated to
        # the frames
        n_s = max(int(round(t_end * scene.path.sample_rate)), 2) + 1
        t_s = t_grid(np.arange(n_frames + 1)) if n_frames + 1 <= n_s else np.linspace(0.0, t_end, n_s)
        if eqs.mode == "torque":
            tab = _tabulated(model_scene, t_s, given)
            th, th_d, th_dd, ff = tab.theta_ref, tab.theta_d_ref, tab.theta_dd_ref, tab.tau_ff
        elif scene.mechanism is not None:
            th, th_d, th_dd = (np.array(v).T for v in reference_function(scene).map(len(t_s))(t_s[None, :])[1:])
            ff = np.zeros_like(th)
        else:
            g = graph_references(scene, t_s)
            th, th_d, th_dd, ff = g.theta_ref, g.theta_d_ref, g.theta_dd_ref, np.zeros_like(g.theta_ref)
        refs_at = _interpolated(t_s, th, th_d, th_dd, ff)
    elif eqs.mode == "prescribed" and scene.mechanism is not None:
        refs = reference_function(scene)

    def rows(a: int, b: int) -> np.ndarray:  # the inputs of frames a..b-1
        t = t_grid(np.arange(a, b + 1))
        cols = [t[:-1], t[1:]]
        if refs_at is not None:
            at = refs_at(t)
            cols += ([at["th"][:-1], at["thd"][:-1], at["ff"][:-1]] if held else
                     [v for key in ("th", "thd", "thdd", "ff", "ffd") for v in (at[key][:-1], at[key][1:])])
        elif held:  # pointwise controller: the path and its derivatives at each control instant
            cols.append(_path_rows(scene, t[:-1]))
        return np.column_stack(cols)

    u = FrameInputs(n_frames, rows(0, 1).shape[1], rows)

    def tabulated_at(t):  # the tabulated controller's (theta, theta_d, tau_ff) at the times t
        return tuple(refs_at(t)[key] for key in ("th", "thd", "ff")) if refs_at is not None else None

    # initial state
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
        tau0 = _controller_efforts(model_scene, loop, model, np.array([0.0]), q0[None, :], qd0[None, :],
                                   tabulated_at(np.array([0.0])))[0] if (
            eqs.mode == "torque") else np.zeros(n)
        offsets = _seated_offsets(scene, eqs, mech, q0, qd0, qdd0, tau0)
        if scene.mechanism is not None:  # closed form; eccentricities of all passive joints
            ecc = np.zeros((len(scene.joints), 2))
            ecc[[[j.name for j in scene.joints].index(c) for c in eqs.clearance_joints]] = offsets
            q0 = mech.seated_coordinates(target, ecc)
        else:
            q0 = mech.assemble(target, offsets, guess=q0)
        seated = np.any(offsets != 0, axis=1).astype(float)
    tree = _in_tree(scene, eqs)
    y0 = np.r_[q0, qd0] if not tree else np.hstack([np.array(v).ravel() for v in eqs.tree_coordinates(q0, qd0)])
    x0 = np.r_[0.0, y0, 0.0, 0.0, 0.0, np.full(nc, eqs.v_min), seated, np.zeros(nc), eqs.parameters, loop.settings]

    system = _system(eqs, loop, refs, tree)
    wall = time.perf_counter()
    run = method.run(system, x0, u, h, spf, progress=bool(overrides.get("progress", False)), every=every)
    wall = time.perf_counter() - wall - u.seconds  # the stepping, without making its inputs
    X = np.vstack([x0[:system.kept], run.states])  # [t, y, the discrete state's events]
    if tree:  # back to reference-point coordinates: [t, q, qd, the rest]
        m = y0.size // 2
        qs = _mapped(eqs.tree_state, p=X[:, 1:1 + m].T, pd=X[:, 1 + m:1 + 2 * m].T)
        X = np.column_stack([X[:, 0], qs["q"].T, qs["qd"].T, X[:, 1 + 2 * m:]])
    nq = eqs.nq
    q, qd = X[:, 1:1 + nq], X[:, 1 + nq:1 + 2 * nq]
    W, Dd, Df = X[:, 1 + 2 * nq], X[:, 2 + 2 * nq], X[:, 3 + 2 * nq]
    z = X[:, 4 + 2 * nq:]
    if not np.all(np.isfinite(X)):
        k = int(np.argmax(~np.all(np.isfinite(X), axis=1)))
        raise SimulationError(f"integrator.step: {h:g} s lets the state blow up (non-finite by t = "
                              f"{t_out[k]:.6g} s) with {method.name}; use a smaller step")

    if "failure" in run.stats:  # the state stayed at the last accepted step: name the joint there
        pen = np.array(eqs.acceleration(q=q[-1], qd=qd[-1], delta_dot0=z[-1, :nc], in_contact=z[-1, nc:2 * nc],
                                        t=t_out[-1])["penetration"]).ravel() if nc else np.zeros(0)
        raise SimulationError(_failure_message(run.stats["failure"], method.name, eqs.clearance_joints, pen))
    N = len(t_out)
    pose_ref = _path_rows(scene, t_out)[:, :3] if model.task is not None else np.zeros((N, 3))
    effort = np.zeros((N, n))
    th = th_d = th_dd = np.zeros((N, n))
    if eqs.mode == "torque":
        effort = _controller_efforts(model_scene, loop, model, t_out, q, qd, tabulated_at(t_out))
    elif eqs.mode == "prescribed" and model.task is not None:
        if refs is not None:
            th, th_d, th_dd = (np.array(v).T for v in refs.map(N)(t_out[None, :])[1:])
        else:
            at = refs_at(t_out)
            th, th_d, th_dd = at["th"], at["thd"], at["thdd"]
    out = _mapped(eqs.acceleration, q=q.T, qd=qd.T, effort=effort.T, theta_ref=th.T, theta_d_ref=th_d.T,
                  theta_dd_ref=th_dd.T, delta_dot0=z[:, :nc].T, in_contact=z[:, nc:2 * nc].T, t=t_out[None, :])
    k = len(eqs.passive_ideal_joints)

    def per_joint(a, rows):
        return np.array(a).reshape(rows, N, -1).transpose(1, 2, 0) if rows == 2 else np.array(a).T

    pose = (_mapped(model.task_pose_function, **{model.task_pose_function.name_in(0): q.T})[
        model.task_pose_function.name_out(0)].T if model.task else np.zeros((N, 3)))
    losses = {j.name: 0 for j in scene.joints}
    losses.update({j: int(round(v)) for j, v in zip(eqs.clearance_joints, z[-1, 2 * nc:3 * nc], strict=True)})
    energy = energy_terms(eqs.energy, q, qd, W, Dd, Df)
    stats = {"method": method.name, "step": h, "steps": spf * n_frames, "frames": N - 1, "wall_time": wall,
             "input_time": u.seconds, "jit": method.jit,
             "graph": {f.name(): graph_size(f) for f in (eqs.acceleration, system.ode)},
             "controller": (controller if loop.control is not None else "none"),
             "coordinates": "tree" if tree else "reference-point",
             "control_rate": model_scene.actuation.control_rate if held else None, "references": loop.kind,
             "preload": "given" if given is not None else (model_scene.actuation.preload.method if has_preload(
                 model_scene) and eqs.mode == "torque" else "none"),
             "compensation": model_scene.actuation.compensation if eqs.mode == "torque" else "none"}
    stats.update(run.stats)
    return Simulation(
        scene=scene, clearance_joints=eqs.clearance_joints, ideal_passive_joints=eqs.passive_ideal_joints,
        terms=eqs.terms, t=t_out, q=q, qd=qd, qdd=np.array(out["qdd"]).T, pose=pose, pose_ref=pose_ref,
        platform_error=np.linalg.norm(pose[:, :2] - pose_ref[:, :2], axis=1),
        tau=np.array(out["tau"]).T,
        contact_force=per_joint(out["contact_force"], 2) if nc else np.zeros((N, 0, 2)),
        normal_force=per_joint(out["normal_force"], 1) if nc else np.zeros((N, 0)),
        eccentricity=per_joint(out["eccentricity"], 2) if nc else np.zeros((N, 0, 2)),
        penetration=per_joint(out["penetration"], 1) if nc else np.zeros((N, 0)),
        reaction=per_joint(out["reaction"], 2) if k else np.zeros((N, 0, 2)),
        driver_effort=np.array(out["driver_effort"]).T.reshape(N, -1),
        contact_loss_events=losses, energy=energy, energy_audit_residual=energy_audit_residual(energy),
        stats=stats)


def _failure_message(failure: dict, method: str, joints, penetration) -> str:
    """One line for an error-controlled run that could not go on: the time, the last step and
    the clearance joint pressed deepest there (where such failures start: stiff contact)."""
    where = ""
    if len(joints):
        j = int(np.argmax(penetration))
        where = (f" at joint {joints[j]} (penetration {penetration[j]:.3g} m)" if penetration[j] > 0 else
                 " with no journal in contact")
    return (f"integrator.tolerance: {method} cannot go on at t = {failure['t']:.9g} s{where}: even its smallest "
            f"step, {failure['step']:.3g} s, did not converge or stay finite (try a smaller integrator.step or a "
            "larger integrator.max_newton)")


@functools.lru_cache(maxsize=128)
def _map(f: ca.Function, m: int) -> ca.Function:
    """f.map(m), built once (building one costs about 0.5 ms, as much as evaluating it on a
    few hundred columns)."""
    return f.map(m)


def _nonzeros(sp: ca.Sparsity) -> np.ndarray:
    """Where the nonzeros of the pattern `sp` lie in its dense column-major entries."""
    rows, cols = sp.get_triplet()
    return np.asarray(cols, int) * sp.size1() + np.asarray(rows, int)


def _mapped(f: ca.Function, block: int = 4096, **inputs) -> dict:
    """f's outputs at each column of `inputs` (numpy arrays, one column per output instant),
    evaluated `block` columns at a time: the memory a long run's outputs take while they are
    converted out of CasADi stays bounded by the block, not by the run. Inputs and outputs go
    through CasADi's buffer interface, straight between numpy arrays and the evaluation
    (converting a DM to numpy costs about ten times the evaluation). An input not given is
    zero."""
    n = next(iter(inputs.values())).shape[1]
    ins = {f.index_in(k): (v, _nonzeros(f.sparsity_in(f.index_in(k)))) for k, v in inputs.items()}
    outs = [(f.sparsity_out(i), _nonzeros(f.sparsity_out(i))) for i in range(f.n_out())]
    # output i at instant j, column-major (rows, cols): the rows of a C-ordered (cols * n, rows) array
    out = [np.zeros((sp.size2() * n, sp.size1())) for sp, _ in outs]
    for a in range(0, n, block):
        m = min(block, n - a)
        args = [None] * f.n_in()
        for i, (v, nz) in ins.items():
            if nz.size:
                w = v.shape[1] // n  # columns per instant
                dense = np.asfortranarray(v[:, a * w:(a + m) * w], float).reshape(-1, order="F").reshape(m, -1)
                args[i] = np.ascontiguousarray(dense[:, nz])
        res = [np.empty((m, nz.size)) for _, nz in outs]
        evaluate(_map(f, m), args, res)
        for o, v, (sp, nz) in zip(out, res, outs, strict=True):
            block_out = o[sp.size2() * a:sp.size2() * (a + m)].reshape(m, -1)  # a view: (m, rows * cols)
            block_out[:, nz] = v
    return {f.name_out(i): o.T for i, o in enumerate(out)}


def _controller_efforts(scene: Scene, loop: _Loop, model: Model, t: np.ndarray, q: np.ndarray, qd: np.ndarray,
                        refs: tuple | None) -> np.ndarray:
    """(N, n) efforts the controller commands at the states (q, qd) (N, nq) at times t (N,):
    what it held over the control period starting there, or what it applied there. refs:
    a tabulated controller's (theta_ref, theta_d_ref, tau_ff) (N, n each) at t, as the loop
    used them (None for a closed-form controller)."""
    N = len(t)
    qs, qds = ca.SX.sym("q", q.shape[1]), ca.SX.sym("qd", q.shape[1])
    meas = ca.Function("measured", [qs, qds], list(_measured(model, qs, qds)))
    th, th_d = (np.array(v) for v in meas.map(N)(q.T, qd.T))
    if loop.pointwise:
        rows = _path_rows(scene, t)
        ins = [rows[:, 3 * k:3 * k + 3].T for k in range(3)]
    else:
        ins = [v.T for v in refs]
    settings = np.broadcast_to(np.asarray(loop.settings, float)[:, None], (len(loop.settings), N))
    out = _mapped(loop.control, **dict(zip(loop.control.name_in(), [*ins, th, th_d, settings], strict=True)))
    return out[loop.control.name_out(0)].T
