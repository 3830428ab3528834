"""Method 'dynamic': fit through the simulation itself (single shooting), over a whole record
(method 'staged' starts it from the seated fit) or where the journals are not (only) seated:
start-up, light preload.

The contact numbers are inputs of the compiled stepping: they sit in its discrete state
(``Problem.equation_parameters``, see :func:`rrr4.simulation.system.system_of`); with a link
length or base position among the parameters so do the masses, inertias and joint points
(the equations' geometry inputs, :data:`GEOMETRY_KINDS`). So a candidate parameter vector is
an initial state, not a new scene. One Function steps a frame
(the integrator's frame of :func:`rrr4.simulate`, with the nominal scene's controller: its
closed-form step, or a graph's references tabulated along the path as the frame's inputs; a
driven scene's drivers without a controller) and,
in CasADi forward mode (``Function.forward``, one direction per parameter), carries the
sensitivities S = d(state)/d(p) along: S_0 holds d(contact numbers)/dp (a clearance moves the
bearing radius and, with ``stiffness: auto``, the stiffness that follows from it), and the
measured outputs (task pose, actuator angles, the controller's efforts; a driven scene's
bodies' poses and drivers' efforts) and their
sensitivities are read off each frame's start. What is compiled (the frame, and its
derivative in a block of directions: :func:`sensitivity_frame`) is built once per scene
structure, integrator setting and frame (and block size; cached on disk as any compiled
stepping); a run with n directions costs about 1 + 1.2 n runs without (its derivative
evaluates each step once, not once per direction: 14 runs for 11 on the reference scene, 47
before), a run without directions
(Levenberg-Marquardt's trial steps and the check below) a simulation. Frames are rolled in
chunks; independent runs without directions (a refresh's differences, the check's) together,
the chunk mapped over them in threads (:meth:`DynamicData.run_batch`). An implicit method
steps with the scene's Newton variant at a tolerance of at most :data:`NEWTON_TOL` (so that
a run is smooth in its parameters far below the noise), and its stages are differentiated as
implicit functions (:attr:`rrr4.integrators.implicit.ImplicitIntegrator.implicit_derivative`:
exact at the converged stage, for simplified Newton too). The jumps of a contact's onset
(the onset velocity the contact law captures at the step where contact starts) are not in
the sensitivities.

Where the run's response to its parameters is not linear on the scale of the parameters the
least-squares fit and its intervals mean nothing: the sensitivities then disagree with
central differences of runs +-:data:`FD_STEP` of each parameter's scale. That is what a run
whose journals rattle does (an impact's instant and velocity move with the parameters and
move every later impact: over 50 ms without preload the sensitivities are exact to 0.1 %
against differences 1e-6 apart, but 320 % off against differences 1 % apart). The method
measures the disagreement at the nominal values and at the estimate and refuses beyond
:data:`CHAOS_LIMIT` instead of returning a number.
"""

from __future__ import annotations

import os
from dataclasses import replace

import casadi as ca
import numpy as np

from ..contact import joint_stiffness
from ..control import path_rows, step_inputs
from ..errors import MeasurementError, SceneError, SimulationError
from ..integrators import METHODS, FixedStepIntegrator
from ..integrators.compiled import compiled
from ..integrators.implicit import ImplicitIntegrator
from ..mechanism import geometry_parameters
from ..problem import Problem
from ..scene import Scene
from ..simulation import default_jit
from ..simulation.initial import initial_state
from ..simulation.input_layout import HELD
from ..simulation.run import controller_efforts, frame_times, run_references
from ..simulation.system import in_tree, loop_of, measured, system_of
from ..trajectory import trajectory_function
from .measurements import Measurements, body_rows, driven_scene, measurement_columns
from .parameters import Parameter, identified_scene

__all__ = ["DynamicData", "DYNAMIC_KINDS", "CHAOS_LIMIT", "FD_STEP", "sensitivity_frame"]

DYNAMIC_KINDS = ("clearance", "friction", "stiffness", "driving", "following", "base")  # inputs of the stepping
GEOMETRY_KINDS = ("driving", "following", "base")  # through the equations' geometry inputs (masses, joint points)
CHAOS_LIMIT = 0.25  # relative disagreement of the sensitivities and central differences beyond which shooting fails
FD_STEP = 1e-2  # finite-difference step in each parameter's scaled coordinate (the check, and the seated initial state)
CHUNK = 256  # frames per call from Python
# an implicit method's Newton tolerance in the runs: simplified Newton stopped at the scene's 1e-7 leaves
# errors that jump with the iteration count (central differences of runs 1e-3 of a scale apart then
# disagree with the sensitivities by 1 to 4 %, 89 % on the stiffness); at 1e-12 by 1e-7 to 5e-4, as full Newton
NEWTON_TOL = 1e-12
# directions per call of the compiled derivative (see sensitivity_frame): n directions take a block of the
# next multiple of BLOCK (one compile per such size), at most MAX_BLOCK (more: several blocks)
BLOCK, MAX_BLOCK = 4, 64


def sensitivity_frame(problem: Problem, n_directions: int, interval: float, jit: bool | None = None,
                      inputs: str = "contact"):
    """(frame, system, loop, eqs, tree, integrator, frame length [s]) of the problem's run with its
    own controller: 'sensitivity_frame' (x, S (nx, n_directions), u) -> (x_next, S_next, o,
    dO): one frame and its forward sensitivities; o (n_out,): task pose, actuator angles,
    efforts at the frame's start, dO = do/dx S. A frame is a control period of a sampled
    controller, else the whole integrator steps nearest `interval` [s] (the measurements'
    spacing). inputs: the equations' inputs ('geometry': masses, inertias and joint points are
    state too, for link lengths and base positions).

    What is compiled (with `jit`, default as rrr4.simulate): the frame with its outputs
    ('sensitivity_step'), once per problem structure and frame, and the frame's forward
    derivative in a block of d directions ('sensitivity_directions', d the next multiple of
    :data:`BLOCK` at or above n, at most :data:`MAX_BLOCK`; more directions map it over
    blocks), once per d (cached on disk as any compiled stepping). The derivative is that of
    :meth:`~rrr4.integrators.base.FixedStepIntegrator.derivative_frame_function`: the frame
    evaluated once per call and its leaves' one-direction derivatives called d times, so its C
    hardly grows with d (reference scene: 0.97 MB for 4 directions, 1.03 MB for 12) and no
    direction recomputes the frame's Newton iterations; an implicit step's stages differentiated
    as implicit functions."""
    jit = default_jit() if jit is None else bool(jit)
    scene = problem.scene
    held = scene.actuation.mode == "torque" and scene.actuation.control_rate is not None
    dt = 1.0 / scene.actuation.control_rate if held else \
        scene.integrator.step * max(int(round(interval / scene.integrator.step)), 1)
    parts = problem.memo(("identify_sensitivity", dt, jit, inputs), lambda: _build(problem, dt, jit, inputs))
    d = min(BLOCK * -(-n_directions // BLOCK), MAX_BLOCK)
    block = problem.memo(("identify_sensitivity_directions", d, dt, jit, inputs),
                         lambda: _directions(problem, parts, d, jit, inputs)) if d else None
    frame = problem.memo(("identify_sensitivity_frame", n_directions, dt, jit, inputs),
                         lambda: _with_directions(parts[0], block, n_directions))
    return (frame, *parts[1:])


def _with_directions(step: ca.Function, block: ca.Function | None, nd: int) -> ca.Function:
    """The frame with nd directions from the compiled step and its derivative in blocks of d
    directions (zero directions pad the last block)."""
    nx, nu = step.size1_in(0), step.size1_in(1)
    x, u, S = ca.MX.sym("x", nx), ca.MX.sym("u", nu), ca.MX.sym("S", nx, nd)
    x1, o, do_x = step(x, u)
    if nd:
        d = block.size2_in(3)
        blocks = -(-nd // d)
        padded = ca.horzcat(S, ca.MX.zeros(nx, blocks * d - nd))
        threads = min(blocks, os.cpu_count() or 1)  # the blocks are independent: one per core
        mapped = block if blocks == 1 else block.map(blocks, "thread", threads) if threads > 1 else block.map(blocks)
        S1 = mapped(x, u, x1, padded, ca.MX.zeros(nu, blocks * d))[:, :nd]
    else:
        S1 = ca.MX(nx, 0)
    return ca.Function("sensitivity_frame", [x, S, u], [x1, S1, o, do_x @ S], ["x", "S", "u"],
                       ["x_next", "S_next", "o", "dO"])


def _build(problem: Problem, dt: float, jit: bool, inputs: str):
    scene = problem.scene
    eqs = problem.equations(inputs=inputs)
    driven = driven_scene(problem)  # its drivers' prescribed motion, as rrr4.simulate runs it: no controller
    if eqs.mode != "torque" and not driven:
        raise SceneError(f"actuation.mode: method 'dynamic' is not allowed with {eqs.mode!r} (it fits the run of "
                         "the scene's controller, torque, or of a driven scene's drivers)")
    loop = loop_of(problem, eqs, "python", "exact", None)  # a tabulated controller's references: frame inputs
    method = METHODS[scene.integrator.method].from_settings(scene.integrator, jit=False)
    if isinstance(method, ImplicitIntegrator):  # a run smooth in its parameters to far below the noise
        method.newton_tol = min(method.newton_tol, NEWTON_TOL)
    if not isinstance(method, FixedStepIntegrator) or getattr(method, "tolerance", None) is not None:
        raise SceneError(f"integrator.method: {scene.integrator.method!r} is not allowed with method 'dynamic' (its "
                         "sensitivities are the forward derivatives of a fixed-step frame: an adaptive method has "
                         "no fixed frame; model the run with bathe at a fixed step, or rk4 at a step that keeps it "
                         "stable, e.g. 1e-05 s)")
    tree = in_tree(problem, eqs)
    system = system_of(problem, eqs, loop, None, tree, inputs)
    spf = max(int(round(dt / scene.integrator.step)), 1)
    unit = method.frame_function(system, dt / spf, spf)
    nx, nu = unit.size1_in(0), unit.size1_in(1)
    x, u = ca.MX.sym("x", nx), ca.MX.sym("u", nu)
    x1 = unit(x, u)
    out = _outputs(problem, eqs, loop, system, tree)
    xs, us = ca.SX.sym("x", nx), ca.SX.sym("u", nu)
    o = out(xs[:1 + system.ny + system.nz], us)  # an implicit method's memory follows [t, y, z]
    do = ca.Function("outputs", [xs, us], [o, ca.jacobian(o, xs)])
    step = ca.Function("sensitivity_step", [x, u], [x1, *do(x, u)], ["x", "u"], ["x_next", "o", "do_dx"])
    if jit:
        step = compiled(step, system.c_sources)
    return step, system, loop, eqs, tree, method, dt


def _directions(problem: Problem, parts, d: int, jit: bool, inputs: str) -> ca.Function:
    """'sensitivity_directions' (x, u, x_next, dx (nx, d), du (nu, d)) -> dx_next: the frame's
    forward derivative in d directions (see :func:`sensitivity_frame`)."""
    step, system, loop, eqs, tree, method, dt = parts
    spf = max(int(round(dt / problem.scene.integrator.step)), 1)
    frame = problem.memo(("identify_derivative_frame", dt, inputs), lambda: method.derivative_frame_function(
        system_of(problem, eqs, loop, None, tree, inputs, derivatives=True), dt / spf, spf))
    nx, nu = step.size1_in(0), step.size1_in(1)
    x, u, x_out = ca.MX.sym("x", nx), ca.MX.sym("u", nu), ca.MX.sym("x_next", nx)
    dx, du = ca.MX.sym("dx", nx, d), ca.MX.sym("du", nu, d)
    block = ca.Function("sensitivity_directions", [x, u, x_out, dx, du], [frame.forward(d)(x, u, x_out, dx, du)],
                        ["x", "u", "x_next", "dx", "du"], ["dx_next"])
    return compiled(block, system.c_sources) if jit else block


def _outputs(problem: Problem, eqs, loop, system, tree: bool) -> ca.Function:
    """(x, u) -> what the run records at a frame's start x with the frame's inputs u: [task pose
    (3), actuator angles (n), efforts (n)], or for a driven scene [the bodies' poses (3 each),
    the drivers' efforts] (the order of :func:`rrr4.identify.measurements.measurement_columns`).
    A tabulated controller (a graph's) takes its references at the frame's start from u."""
    model, par, L, U = problem.model, eqs.parametric, system.layout, loop.inputs
    x, u = ca.SX.sym("x", 1 + L.ny + L.nz), ca.SX.sym("u", U.width)
    t, parameters, settings = x[0], x[L.in_x("parameters")], x[L.in_x("settings")]
    q, qd = x[L.in_x("q")], x[L.in_x("qd")]
    if tree:
        q, qd = par.tree_state(q, qd, parameters)
    if driven_scene(problem):  # the drivers' efforts: -lambda of their rows, as the simulation's outputs
        n = ca.SX(eqs.n_actuators, 1)
        acc = par.acceleration(q=q, qd=qd, effort=n, theta_ref=n, theta_d_ref=n, theta_dd_ref=n,
                               delta_dot0=x[L.in_x("delta_dot0")], in_contact=x[L.in_x("in_contact")], t=t,
                               parameters=parameters)
        return ca.Function("recorded", [x, u], [ca.vertcat(q[body_rows(problem).tolist()], acc["driver_effort"])])
    theta, theta_d = measured(model, q, qd, par, parameters)
    references = trajectory_function(problem.path)(t) if loop.pointwise else \
        [u[U.reference(name)] for name in HELD]  # th, thd, ff at t_a (sampled: the frame's first end)
    tau = loop.control(*references, theta, theta_d, settings)
    tau = tau[0] if isinstance(tau, (list, tuple)) else tau
    return ca.Function("recorded", [x, u], [ca.vertcat(model.task_pose_function(q), theta, tau)])


class DynamicData:
    """The measured run and the sensitivity runs that predict it (see the module docstring)."""

    def __init__(self, problem: Problem, m: Measurements, params: list[Parameter], scene: Scene | None = None):
        where = m.source or "measurements"
        if m.t[0] < -1e-12 or m.t[-1] > problem.path.duration + 1e-9:
            raise MeasurementError(f"{where}: t runs from {m.t[0]:.6g} s to {m.t[-1]:.6g} s (the scene's path runs "
                                   f"from 0 to {problem.path.duration:g} s; times are path times)")
        seated = problem.scene.initial.journals == "seated"
        scene = problem.scene if scene is None else scene  # the nominal scene, varied for each candidate
        if seated and scene.data is None:
            raise SceneError(f"scene: {problem.name!r} has no YAML data (its journals start seated, where the "
                             "clearances put them: method 'dynamic' varies the scene's data to place them; read it "
                             "with rrr4.load_scene or rrr4.scene.parse_scene)")
        self.problem, self.m, self.params, self.scene = problem, m, params, scene
        self.inputs = "geometry" if any(q.kind in GEOMETRY_KINDS for q in params) else "contact"
        if self.inputs == "geometry" and scene.data is None:
            raise SceneError(f"scene: {problem.name!r} has no YAML data (method 'dynamic' varies the scene's data "
                             "for link lengths and base positions; read it with rrr4.load_scene)")
        kinds = measurement_columns(problem)
        self.kinds = kinds
        # the recorded outputs' columns, in the order of the frame's outputs (see _outputs)
        driven = driven_scene(problem)
        self.outputs = kinds["body"] + kinds["driver"] if driven else kinds["pose"] + kinds["angle"] + kinds["effort"]
        body_angles = [c for c in kinds["body"] if c.endswith("_theta_rad")]
        self.pose_cols, self.angle_cols = m.has(kinds["pose"]), m.has(kinds["angle"] + body_angles)  # angles: wrapped
        self.effort_cols = m.has(kinds["effort"] + kinds["driver"])
        self.body_cols = m.has([c for c in kinds["body"] if c not in body_angles])  # a driven scene's positions
        if not self.columns():
            raise MeasurementError(f"{where}: no column that method 'dynamic' fits for scene {problem.name!r} "
                                   f"(expected some of: {', '.join(self.outputs)}; given: "
                                   f"{', '.join(m.columns) or 'none'})")
        self.angles_measured = bool(self.angle_cols)
        self.f, self.system, self.loop, self.eqs, self.tree, self.method, self.dt = sensitivity_frame(
            problem, len(params), float(np.median(np.diff(m.t))), inputs=self.inputs)
        self.preload, self.lag = "the drivers' motion" if driven else "simulated controller", 0.0
        self.n_frames = int(np.ceil(m.t[-1] / self.dt - 1e-9)) + 1  # frame starts 0, dt, ... cover t
        self.runs, self.chaos, self._cache, self._rolls = 0, None, {}, {}
        self.refs_at = self._tabulated()
        self.u = self.frame_inputs(0, self.n_frames)
        self.seated = seated
        self.G = self._geometry()

    def columns(self) -> list[str]:
        return self.pose_cols + self.angle_cols + self.effort_cols + self.body_cols

    # ------------------------------------------------------------------ the runs

    def _geometry(self) -> np.ndarray:
        """d(geometry inputs)/dp (n_g, np): central differences of the scene's geometry numbers
        (:func:`rrr4.mechanism.geometry_parameters`) for each link length or base position (none
        without geometry inputs; they are linear in them but for an inertia's l^2)."""
        if self.inputs != "geometry":
            return np.zeros((0, len(self.params)))
        G = np.zeros((self.problem.equation_parameters(geometry=True).size - self.problem.equation_parameters().size,
                      len(self.params)))
        for i, q in enumerate(self.params):
            if q.kind in GEOMETRY_KINDS:
                h = 1e-3 * q.scale
                up, down = (geometry_parameters(self.scene.with_values({q.key: q.nominal + s}).graph) for s in (h, -h))
                G[:, i] = (up - down) / (2 * h)
        return G

    def contact_numbers(self, p) -> np.ndarray:
        """The equations' parameters (contact numbers, and with geometry inputs masses, inertias
        and joint points) at the parameter values p, each contact number written by its name in
        the equations' layout (:mod:`rrr4.dynamics.layout`), the geometry to first order in the
        link lengths and base positions."""
        pb, at = self.problem, self.eqs.layout.index
        v = pb.equation_parameters(geometry=self.inputs == "geometry").copy()
        if self.G.size:
            v[v.size - self.G.shape[0]:] += self.G @ (np.asarray(p, float) - [q.nominal for q in self.params])
        clear = self.eqs.clearance_joints
        auto = pb.scene.effects.contact.stiffness is None and not any(q.kind == "stiffness" for q in self.params)
        for q, value in zip(self.params, p, strict=True):
            if q.kind == "clearance":
                for j in q.joints:
                    joint = replace(pb.joint(j), radial_clearance=float(value))
                    v[at(f"joints.{j}.bearing_radius")] = joint.bearing_radius
                    if auto:  # the stiffness follows from the radii
                        v[at(f"joints.{j}.stiffness")] = joint_stiffness(joint)
            elif q.kind == "stiffness":
                v[[at(f"joints.{j}.stiffness") for j in clear]] = value
            elif q.kind == "friction":
                v[at("contact.friction_coefficient")] = value
        return v

    def derivatives(self, p=None) -> np.ndarray:
        """d(contact numbers)/dp (n_e, np) at the parameter values p (default the nominal
        ones): 1 at a parameter's own entries, and with stiffness 'auto' dK/dc of each
        clearance's stiffness (central difference of its closed form, which is smooth; it
        changes with c: taken at p, not at the nominal values)."""
        at = np.array([q.nominal for q in self.params] if p is None else p, float)
        D = np.zeros((len(self.eqs.parameters), len(self.params)))
        for i, q in enumerate(self.params):
            h = 1e-4 * q.scale
            e = np.eye(len(self.params))[i] * h
            D[:, i] = (self.contact_numbers(at + e) - self.contact_numbers(at - e)) / (2 * h)
        return D

    def initial(self, p) -> np.ndarray:
        """x0 at the parameter values p: the scene's initial state with p's contact numbers
        (journals seated where the candidate's clearances put them)."""
        if not np.all(np.isfinite(p)):  # a step computed from sensitivities that overflowed
            raise SimulationError(f"method 'dynamic': the fit's step is not finite over 0 to {self.m.t[-1]:.3g} s (the "
                                  "run's sensitivities overflow: a slip reversal too stiff for the integrator's step, "
                                  "or journals that rattle); fit a shorter span, split it into windows (windows=N), "
                                  "or step with an implicit integrator (bathe)")
        pb, eqs = self.problem, self.eqs
        if self.seated or self.inputs == "geometry":  # the candidate's equations: its seats, its assembly
            pb = Problem.from_scene(identified_scene(self.scene, self.params, p, name="candidate"))
            eqs = pb.equations(inputs=self.inputs)
        x0 = initial_state(pb, eqs, self._efforts, self.tree, self.loop.settings)
        x0[self.parameter_rows] = self.contact_numbers(p)
        x0 = self.system.started(x0, self.frame_inputs(0, 1)[0])
        extra = getattr(self.method, "initial_extra", None)  # an implicit method's memory and counters
        return np.r_[x0, extra(self.system, x0, self.frame_inputs(0, 1)[0])] if extra else x0

    def _tabulated(self):
        """t -> the tabulated controller's references at the times t, as rrr4.simulate tabulates
        them for a run over the frames (on the path's sample grid, interpolated; the nominal
        controller's, as the measured run's was); None for a closed-form controller step or a
        driven scene."""
        if self.loop.pointwise or self.loop.control is None:
            return None
        t_end = self.n_frames * self.dt
        grid = lambda k: frame_times(t_end, self.n_frames, k)  # noqa: E731
        return run_references(self.problem, self.problem, self.eqs, self.loop, None, t_end, self.n_frames, grid)[1]

    def _efforts(self, t, q, qd) -> np.ndarray:
        """The controller's efforts at the states (q, qd) at the times t (for seated journals' loads)."""
        t = np.asarray(t, float)
        refs = None if self.refs_at is None else tuple(self.refs_at(t)[k] for k in HELD)
        return controller_efforts(self.problem, self.loop, self.problem.model, t, np.atleast_2d(q),
                                  np.atleast_2d(qd), refs)

    def frame_inputs(self, a: int, b: int) -> np.ndarray:
        """(b - a, nu) inputs of frames a..b-1: [t_a, t_b] (and a held controller's path rows at t_a,
        or a tabulated controller's references, :mod:`rrr4.simulation.input_layout`)."""
        t = np.arange(a, b + 1) * self.dt
        layout = self.loop.inputs
        return layout.rows(t, None if self.refs_at is None else self.refs_at(t),
                           step=step_inputs(self.loop.control, self.problem.path, t[:-1]) if layout.step else None)

    def frame(self, n_directions: int) -> ca.Function:
        """The compiled frame with `n_directions` sensitivity directions (see :func:`sensitivity_frame`)."""
        return sensitivity_frame(self.problem, n_directions, self.dt, inputs=self.inputs)[0]

    def start(self, p, sensitivities: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(x0, S0 (nx, np), no columns without `sensitivities`): the run's initial state at the
        parameter values p and its sensitivities (the contact numbers' d/dp; a seated start's
        by central differences)."""
        nd, motion = (len(self.params) if sensitivities else 0), self.system.layout.in_x("motion")
        x = self.initial(p)
        S = np.zeros((x.size, nd))
        if sensitivities:
            S[self.parameter_rows] = self.derivatives(p)
        # the start moves with the geometry and the seats (clearance, and the elastic penetration the stiffness and
        # the friction angle add): central differences (a forward one is off by ~FD_STEP on a log-fitted stiffness)
        moved = DYNAMIC_KINDS if self.seated else GEOMETRY_KINDS
        if sensitivities:
            for i in (i for i, q in enumerate(self.params) if q.kind in moved):
                up, down = self.shifted(p, i), self.shifted(p, i, -FD_STEP)
                S[motion, i] = (self.initial(up)[motion] - self.initial(down)[motion]) / (up[i] - down[i])
        return x, S

    @property
    def parameter_rows(self) -> slice:
        """The entries of the frame's state x that hold the equations' parameters (contact numbers)."""
        return self.system.layout.in_x("parameters")

    def roll(self, x, S, a: int, b: int):
        """Frames a..b-1 from the state x with its sensitivities S (nx, nd): (x at frame b, S there,
        o (b - a, n_out) at the frame starts, dO (b - a, n_out, nd))."""
        nd = S.shape[1]
        f = self.frame(nd)
        os, dos = [], []
        for c in range(a, b, CHUNK):
            d = min(c + CHUNK, b)
            if (nd, d - c) not in self._rolls:  # x and S carried from frame to frame
                self._rolls[nd, d - c] = f.mapaccum("roll", d - c, 2)
            x_all, S_all, o, do = self._rolls[nd, d - c](x, S, self.u[c:d].T)
            x, S = np.array(x_all[:, -1]).ravel(), np.array(S_all[:, S_all.shape[1] - nd:]).reshape(x.size, nd)
            os.append(np.array(o).T)
            dos.append(np.array(do).T.reshape(d - c, nd, -1).transpose(0, 2, 1) if nd else
                       np.zeros((d - c, os[-1].shape[1], 0)))
        return x, S, np.vstack(os), np.concatenate(dos)

    def run(self, p, sensitivities: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """(o (n_frames, n_out), dO (n_frames, n_out, np)) at the frame starts with the parameter
        values p: the recorded outputs and their exact sensitivities (None without
        `sensitivities`: the frame without directions, compiled apart, a third of the cost)."""
        p = np.asarray(p, float)
        key = tuple(p.tolist())
        if key in self._cache and (self._cache[key][1] is not None or not sensitivities):
            return self._cache[key]
        self.runs += 1
        x, S = self.start(p, sensitivities)
        _, _, o, do = self.roll(x, S, 0, self.n_frames)
        return self._kept(p, o, do if sensitivities else None)

    def run_batch(self, P) -> list[np.ndarray]:
        """The outputs o (n_frames, n_out) of the runs without sensitivities at each row of P (k, np),
        as :meth:`run` gives them one at a time (the same numbers): the rows not cached rolled together,
        each chunk of frames one call of the frame mapped over them in threads (one per core)."""
        P = np.atleast_2d(np.asarray(P, float))
        keys = [tuple(p.tolist()) for p in P]
        out = {key: self._cache[key][0] for key in keys if key in self._cache}
        todo = list(dict.fromkeys(key for key in keys if key not in out))  # each point once, in order
        if todo:
            X = np.column_stack([self.initial(np.array(key)) for key in todo])
            self.runs += len(todo)
            for key, o in zip(todo, self.roll_batch(X), strict=True):
                out[key] = self._kept(np.array(key), o, None)[0]
        return [out[key] for key in keys]

    def roll_batch(self, X: np.ndarray) -> list[np.ndarray]:
        """The outputs o (n_frames, n_out) of the runs without sensitivities from the initial states
        X (nx, k), one per column: :meth:`roll`'s chunks mapped over the columns (CasADi's thread map)."""
        k, os_ = X.shape[1], []
        for c in range(0, self.n_frames, CHUNK):
            d = min(c + CHUNK, self.n_frames)
            key = ("batch", k, d - c)
            if key not in self._rolls:
                self._rolls[key] = self._batch_roll(k, d - c)
            X, o = self._rolls[key](X, self.u[c:d].T)
            os_.append(np.array(o).T.reshape(k, d - c, -1))
        return list(np.concatenate(os_, axis=1))

    def _batch_roll(self, k: int, n: int) -> ca.Function:
        """(X (nx, k), u (nu, n)) -> (X after n frames, o (n_out, k n)): n frames of k runs without
        sensitivities, each run's n frames one mapaccum of the frame (as :meth:`roll`'s), the runs a
        map in threads (one per core); only the last states leave (all of them cost a copy)."""
        frame = self.frame(0)
        nx, roll = frame.size1_in(0), frame.mapaccum("roll", n, 2)
        threads = min(k, os.cpu_count() or 1)
        mapped = roll.map(k, "thread", threads) if threads > 1 else roll.map(k)
        X, u = ca.MX.sym("X", nx, k), ca.MX.sym("u", self.u.shape[1], n)
        x_all, _, o, _ = mapped(X, ca.MX(nx, 0), u)
        return ca.Function("roll_batch", [X, u], [x_all[:, [n * (a + 1) - 1 for a in range(k)]], o])

    def _kept(self, p, o, do):
        """(o, do) of the run at p, cached (after the check that they are finite)."""
        if not (np.all(np.isfinite(o)) and (do is None or np.all(np.isfinite(do)))):
            raise SimulationError(f"integrator.step: the run of {self.problem.name!r} is not finite with the "
                                  f"parameters {dict(zip([q.key for q in self.params], p.tolist(), strict=True))}")
        key = tuple(np.asarray(p, float).tolist())
        self._cache.pop(key, None)
        if len(self._cache) >= 8:  # the oldest goes (the estimate's run with sensitivities is asked again after)
            self._cache.pop(next(iter(self._cache)))
        self._cache[key] = (o, do)
        return o, do

    def shifted(self, p, i: int, step: float = FD_STEP) -> np.ndarray:
        """p with parameter i one `step` up in its scaled coordinate."""
        q = self.params[i]
        out = np.array(p, float)
        out[i] = q.value(q.coordinate(p[i]) + step)
        return out

    # ------------------------------------------------------------------ residuals

    def at_measured(self, o: np.ndarray, do: np.ndarray | None) -> tuple[dict, dict]:
        """{column: (N,)} and {column: (N, np)} (none without do) at the measured instants
        (linear in time between frame starts)."""
        t_f = np.arange(self.n_frames) * self.dt
        index = {c: i for i, c in enumerate(self.outputs)}
        val, sens = {}, {}
        for c in self.columns():
            i = index[c]
            val[c] = np.interp(self.m.t, t_f, o[:, i])
            if do is not None:
                sens[c] = np.column_stack([np.interp(self.m.t, t_f, do[:, i, j]) for j in range(do.shape[2])])
        return val, sens

    def residuals(self, p, sigma: dict, jacobian: bool = True) -> dict:
        """As :meth:`rrr4.identify.seated.SeatedData.residuals`; the Jacobian from the run's
        forward sensitivities (none without `jacobian`)."""
        return self.residuals_of(*self.at_measured(*self.run(p, jacobian)), sigma, jacobian)

    def residuals_batch(self, P, sigma: dict) -> list[np.ndarray]:
        """The whitened residuals r at each row of P (k, np), as :meth:`residuals` without the
        Jacobian gives them one at a time: the runs rolled together (:meth:`run_batch`)."""
        return [self.residuals_of(*self.at_measured(o, None), sigma, False)["r"] for o in self.run_batch(P)]

    def residuals_of(self, base: dict, sens: dict, sigma: dict, jacobian: bool = True) -> dict:
        """The residuals of the predictions `base` {column: (N,)} with their sensitivities `sens`
        {column: (N, n)} (see :meth:`residuals`)."""
        rs, js, raw, expected, explained = [], [], {}, {}, {}
        pose_ref, theta_ref = self._references()
        for c in self.columns():
            raw[c] = self.m.columns[c] - base[c]
            if c in ("theta_rad", *self.angle_cols):
                raw[c] = np.arctan2(np.sin(raw[c]), np.cos(raw[c]))
            expected[c] = np.ones(len(raw[c]))
            if c in self.pose_cols:
                explained[c] = base[c] - pose_ref[:, self.kinds["pose"].index(c)]
            elif c in self.angle_cols and theta_ref is not None:
                d = base[c] - theta_ref[:, self.kinds["angle"].index(c)]
                explained[c] = np.arctan2(np.sin(d), np.cos(d))
            else:
                explained[c] = base[c]
            rs.append(raw[c] / sigma[c])
            if jacobian:
                js.append(-sens[c] / sigma[c])
        return {"r": np.concatenate(rs), "J": np.vstack(js) if jacobian else None, "raw": raw, "expected": expected,
                "prediction": base, "explained": explained}

    def _references(self):
        """The path's poses (N, 3) at the measured instants and the ideal IK's actuator angles
        (N, n) (what the figures show offsets from); (None, None) without a task (a driven scene)."""
        if self.problem.model.task is None:
            return None, None
        if not hasattr(self, "_refs"):
            pose_ref = path_rows(self.problem.path, self.m.t)[:, :3]
            if self.refs_at is not None:  # a tabulated controller's
                theta_ref = self.refs_at(self.m.t)["th"]
            else:
                mech = self.problem.mechanism
                theta_ref = np.array(mech.ik_function.map(len(self.m.t))(pose_ref.T, mech.modes)[0]).T
            self._refs = pose_ref, theta_ref
        return self._refs

    def initial_noise(self) -> dict:
        out = {}
        for c in self.columns():
            out[c] = 1e-5 if c == "theta_rad" else 1e-6 if c in ("x_m", "y_m", *self.body_cols) else \
                1e-5 if c in self.angle_cols \
                else max(0.01 * float(np.sqrt(np.mean(self.m.columns[c] ** 2))), 1e-9)
        return out

    # ------------------------------------------------------------------ the check

    def central_differences(self, p, sigma: dict, step: float = FD_STEP) -> np.ndarray:
        """The Jacobian of the whitened residuals in p by central differences of whole runs,
        `step` (scaled coordinate) either side: the check of the sensitivities."""
        p = np.asarray(p, float)
        ups = [self.shifted(p, i, step) for i in range(len(p))]
        downs = [self.shifted(p, i, -step) for i in range(len(p))]
        r = self.residuals_batch(ups + downs, sigma)  # the 2 np runs rolled together
        return np.column_stack([(r[i] - r[len(p) + i]) / (ups[i][i] - downs[i][i]) for i in range(len(p))])

    def check_sensitivities(self, p, sigma: dict, J: np.ndarray) -> float:
        """The relative disagreement |J - J_cd| / |J_cd| of the run's sensitivities J and central
        differences at p; SimulationError where it exceeds CHAOS_LIMIT (the run is too
        sensitive to its parameters for shooting over this span)."""
        J_cd = self.central_differences(p, sigma)
        d = float(np.linalg.norm(J - J_cd) / max(np.linalg.norm(J_cd), 1e-300))
        self.chaos = d
        if not d <= CHAOS_LIMIT:
            remedy = ("a run whose journals stay loaded (a load on the mechanism or a slower drive, as "
                      "problems/slider_crank_loaded.yaml)" if driven_scene(self.problem) else
                      "split it into windows (windows=N, --windows N: multiple shooting), or a preloaded run with "
                      "'seated'")
            raise SimulationError(f"method 'dynamic': the run over 0 to {self.m.t[-1]:.3g} s is too sensitive to its "
                                  f"parameters for shooting (its sensitivities and central differences of runs "
                                  f"+-{100 * FD_STEP:g} % of a parameter's scale differ by {100 * d:.0f} %, allowed "
                                  f"{100 * CHAOS_LIMIT:.0f} %): journals that rattle make it chaotic; fit a shorter "
                                  f"span from the start, or {remedy}")
        return d
