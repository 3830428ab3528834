"""The plant and the controller coupled into one ODE :class:`~rrr4.integrators.System`.

How the efforts enter the right-hand side (:class:`Loop`): the controller step evaluated
inside it at the path's time ('exact'); references interpolated between frame ends, the
feedback law inside it ('sampled'); or a sampled controller with zero-order hold that runs
once per control period ('held'). The System is built once per structure (the equations'
structure key, the controller, the path, the references and the coordinates) and cached on
the Problem of that structure, so every problem of the same structure steps the same
compiled code.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ..codegen import generated_controller
from ..control import (
    controller_settings,
    feedback_settings,
    parametric_controller,
    parametric_feedback,
    pointwise_controller,
    reference_function,
)
from ..dynamics.builder import Equations
from ..errors import SceneError
from ..functions import one_direction_derivatives
from ..integrators import System
from ..mechanism import Model
from ..problem import Problem
from ..scene import PathSpec
from ..trajectory import trajectory_function
from .input_layout import HELD, SAMPLED, TIMES, InputLayout
from .state_layout import StateLayout

__all__ = ["Loop", "loop_of", "system_of", "state_layout", "problem_system", "measured", "in_tree", "extremes",
           "REFERENCES"]


def hermite(s, h, a, b, da, db):
    """Cubic Hermite interpolant at s in [0, 1] of an interval of length h [s]."""
    s2, s3 = s * s, s * s * s
    return (2 * s3 - 3 * s2 + 1) * a + (s3 - 2 * s2 + s) * h * da + (3 * s2 - 2 * s3) * b + (s3 - s2) * h * db


REFERENCES = ("exact", "sampled")  # where the right-hand side gets its references (see simulate)


@dataclass(frozen=True)
class Loop:
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
    key: tuple = ()  # what `control` is built from (a structure key or the generated C), for the system cache
    inputs: InputLayout | None = None  # the frame inputs' layout (set by loop_of)


def measured(model: Model, q, qd, eqs: Equations | None = None, parameters=None):
    """Actuator coordinates theta (n,) and rates theta_d = S qd of a state (symbolic); with
    the parametric equations `eqs`, from their actuator coordinates at `parameters` (a
    prismatic actuator's coordinate depends on its joint's points, which may be inputs)."""
    theta, S = (model.actuator_coordinates_function(q) if eqs is None else
                eqs.actuator_coordinates(q, parameters))
    return theta, S @ qd


def system_of(problem: Problem, eqs: Equations, loop: Loop, refs: ca.Function | None, tree: bool = False,
              inputs: str = "contact", derivatives: bool = False) -> System:
    """The ODE y = [q, qd, W_in, D_damping, D_friction, wear] (with `tree`, the tree coordinates
    p, pd instead of q, qd: see :mod:`rrr4.mechanism.tree`; wear: the node depths [m] worn since
    the start, per profile of ``eqs.worn``, none without wear) with discrete z = [delta_dot0,
    in_contact, losses] (nc each) followed by the equations' parameters (contact numbers,
    masses and geometry, see ``Problem.equation_parameters``) and the controller's settings
    (both constant: the discrete update keeps them), then the running maxima of the peaks
    (see :func:`extremes`), and the frame inputs of `loop` (see :class:`Loop`). The numbers
    are state, not constants, so every problem that differs only in them steps with the same
    compiled code.
    refs: the prescribed mode's closed-form references (or None). Built once per structure:
    cached on the Problem of the equations' structure key (``inputs``: 'contact' -> the plant's,
    'geometry' -> the geometry's), keyed by the equations' options, the loop (its kind, what its
    controller is built from, the path a pointwise controller follows), the references' path
    and the coordinates. derivatives: the system's Functions take forward derivatives one
    direction at a time (:func:`rrr4.functions.one_direction_derivatives`), for a frame
    differentiated in many directions (:meth:`FixedStepIntegrator.derivative_frame_function
    <rrr4.integrators.base.FixedStepIntegrator.derivative_frame_function>`); a system of its own."""
    path = loop.path if loop.kind == "exact" and eqs.mode == "torque" else None
    key = ("system", eqs.v_min, eqs.baumgarte, loop.kind, loop.key, path, problem.path_key if refs else None, tree,
           derivatives)
    structure = problem.structure("geometry" if inputs == "geometry" else "plant")
    if derivatives:
        with one_direction_derivatives():
            return structure.memo(key, lambda: _build_system(eqs, loop, refs, tree))
    return structure.memo(key, lambda: _build_system(eqs, loop, refs, tree))


def _build_system(eqs: Equations, loop: Loop, refs: ca.Function | None, tree: bool) -> System:
    model = eqs.model
    par = eqs.parametric
    n = eqs.n_actuators
    L = state_layout(eqs, loop, tree)
    t, y, z = ca.SX.sym("t"), ca.SX.sym("y", L.ny), ca.SX.sym("z", L.nz)
    U = loop.inputs
    u = ca.SX.sym("u", U.ode_width)
    dd0, inc, losses = z[L.delta_dot0], z[L.in_contact], z[L.losses]
    parameters, settings, peaks = z[L.parameters], z[L.settings], z[L.peaks]

    def configuration(y, parameters):
        """(q, qd) of the state y: its first entries, or from the tree coordinates."""
        return par.tree_state(y[L.q], y[L.qd], parameters) if tree else (y[L.q], y[L.qd])

    q, qd = configuration(y, parameters)
    zeros = ca.SX.zeros(n)
    th, th_d, th_dd, effort = zeros, zeros, zeros, zeros
    if loop.kind == "held":
        effort = u[U.effort]
    elif loop.kind == "sampled":
        h = ca.fmax(u[1] - u[0], 1e-300)
        s = ca.fmin(ca.fmax((t - u[0]) / h, 0.0), 1.0)
        th_a, th_b, thd_a, thd_b, thdd_a, thdd_b, ff_a, ff_b, ffd_a, ffd_b = (
            u[U.reference(name, end)] for name in SAMPLED for end in (0, 1))
        th = hermite(s, h, th_a, th_b, thd_a, thd_b)
        th_d = hermite(s, h, thd_a, thd_b, thdd_a, thdd_b)
        th_dd = (1 - s) * thdd_a + s * thdd_b
        if eqs.mode == "torque":
            effort = loop.control(th, th_d, hermite(s, h, ff_a, ff_b, ffd_a, ffd_b),
                                  *measured(model, q, qd, par, parameters), settings)
    elif eqs.mode == "torque":  # exact: the controller step at the path's time
        effort = loop.control(*trajectory_function(loop.path)(t), *measured(model, q, qd, par, parameters),
                              settings)[0]
    elif refs is not None:
        _, th, th_d, th_dd = refs(t)
    refs_in = dict(effort=effort, theta_ref=th, theta_d_ref=th_d, theta_dd_ref=th_dd, delta_dot0=dd0, in_contact=inc,
                   t=t, parameters=parameters)
    if tree:
        out = par.tree_acceleration(p=y[L.q], pd=y[L.qd], **refs_in)
        ydot = ca.vertcat(y[L.qd], out["pdd"], out["power_in"], out["power_damping"], out["power_friction"])
    else:
        out = par.acceleration(q=q, qd=qd, **refs_in)
        ydot = ca.vertcat(qd, out["qdd"], out["power_in"], out["power_damping"], out["power_friction"])
    if L.n_wear:
        ydot = ca.vertcat(ydot, out["wear_rate"])
    ode = ca.Function("ode", [t, y, z, u], [ydot], ["t", "y", "z", "u"], ["y_dot"])
    dd0n, incn, loss = par.contact_update(q, qd, dd0, inc, parameters)
    disc = ca.Function("discrete", [t, y, z], [ca.vertcat(dd0n, incn, losses + loss, parameters, settings, peaks)],
                       ["t", "y", "z"], ["z_next"])
    # the peaks, at every step's end: normal forces (their maxima and minima), penetrations,
    # and in torque mode the efforts' magnitudes; what they need of the equations only (no
    # constraint solve: the contact laws and the efforts)
    contact = par.acceleration(q=q, qd=qd, **refs_in)
    fn, pen = contact["normal_force"], contact["penetration"]
    values = ca.vertcat(fn, -fn, pen, *([ca.fabs(effort)] if eqs.mode == "torque" else []))
    peak_values = ca.Function("peaks", [t, y, z, u], [values], ["t", "y", "z", "u"], ["peaks"])
    control = None
    if loop.kind == "held":
        # the inputs before theta, theta_d (the frame's row: see rrr4.simulation.input_layout)
        ym, zm, uf = ca.MX.sym("y", y.shape[0]), ca.MX.sym("z", z.shape[0]), ca.MX.sym("u_frame", U.width)
        pm = zm[L.parameters]
        meas = measured(model, *configuration(ym, pm), par, pm)
        args = [uf[b] for b in U.step_inputs()] if U.step else [uf[U.reference(name)] for name in HELD]
        eff = loop.control(*args, *meas, zm[L.settings])
        eff = eff[0] if isinstance(eff, (list, tuple)) else eff
        control = ca.Function("control", [ym, zm, uf], [ca.vertcat(uf[TIMES], eff)], ["y", "z", "u_frame"], ["u"])
    return System(ode, disc, control, loop.sources, n_events=L.events,
                  peaks=peak_values if L.n_peaks else None, layout=L)


def state_layout(eqs: Equations, loop: Loop, tree: bool) -> StateLayout:
    """The :class:`~rrr4.simulation.state_layout.StateLayout` of the System these equations, loop and
    coordinates build (see :func:`system_of`)."""
    nc, n = len(eqs.clearance_joints), eqs.n_actuators
    nq = eqs.parametric.tree_acceleration.size1_in(0) if tree else eqs.nq  # the coordinates stepped
    return StateLayout(nq=nq, n_wear=sum(m for *_, m in eqs.worn), nc=nc, n_parameters=len(eqs.parameters),
                  n_settings=len(loop.settings), n_peaks=3 * nc + (n if eqs.mode == "torque" else 0))


def extremes(eqs: Equations, maxima) -> dict:
    """The extremes over every step of a run, named, from the running maxima (m,) of its last
    state (see :func:`system_of`): normal_force_max, normal_force_min, penetration_max (nc,
    each) [N, N, m] per clearance joint and, in torque mode, tau_abs_max (n,) [N m or N]
    per actuator."""
    nc = len(eqs.clearance_joints)
    maxima = np.asarray(maxima, float)
    out = {"normal_force_max": maxima[:nc], "normal_force_min": -maxima[nc:2 * nc],
           "penetration_max": maxima[2 * nc:3 * nc]}
    if eqs.mode == "torque":
        out["tau_abs_max"] = maxima[3 * nc:]
    return out


def loop_of(problem: Problem, eqs: Equations, controller: str, references: str, given) -> Loop:
    """How this run's efforts are made (see :class:`Loop`), with its frame inputs' layout."""
    loop = _loop(problem, eqs, controller, references, given)
    step = [loop.control.size1_in(i) for i in range(loop.control.n_in() - 3)] if loop.pointwise else []
    return replace(loop, inputs=InputLayout(loop.kind, eqs.n_actuators, tuple(step) if loop.kind == "held" else ()))


def _loop(problem: Problem, eqs: Equations, controller: str, references: str, given) -> Loop:
    """How this run's efforts are made (see :class:`Loop`) by the controller of `problem` (the
    controller's model); raises SceneError for a combination that does not exist (a
    generated controller without a closed form or rate)."""
    held = eqs.mode == "torque" and problem.scene.actuation.control_rate is not None
    if controller == "generated" and eqs.mode != "torque":
        raise SceneError(f"controller: 'generated' is not allowed here (actuation.mode is {eqs.mode!r}: the generated "
                         "controller step commands torques; choose the default controller)")
    if eqs.mode != "torque":
        kind = "sampled" if references == "sampled" or (not problem.closed_form and problem.model.task) else "exact"
        return Loop(kind, None, False, problem.path, key=("none",))
    given_why = ("a feed-forward is given (preload=)" if given is not None else "") or (
        "references='sampled' tabulates the references" if references == "sampled" else "")
    why = pointwise_controller(problem) or given_why
    if controller == "generated":
        if given_why:
            raise SceneError(f"controller: 'generated' is not allowed here ({given_why}; the generated C is the "
                             "scene's own controller step)")
        if not held:
            raise SceneError("controller: 'generated' is not allowed without actuation.control_rate (the generated "
                             "controller runs as a sampled controller with zero-order hold: set a rate in Hz)")
        step, source = generated_controller(problem)
        held_step = problem.memo(("generated_step", str(source)), lambda: _without_settings(step))
        return Loop("held", held_step, True, None, (source,), key=("generated", str(source)))
    if why:
        return Loop("held" if held else "sampled", parametric_feedback(problem), False, None,
                    settings=tuple(feedback_settings(problem)), key=("feedback", tuple(
                        problem.joint(j).type for j in problem.model.actuated_joints)))
    return Loop("held" if held else "exact", parametric_controller(problem), True,
                problem.path if not held else None, settings=tuple(controller_settings(problem)),
                key=("controller", problem.controller_key))


def _without_settings(step: ca.Function) -> ca.Function:
    """`step` with an empty last input ``settings`` (the generated C holds the scene's numbers);
    kept on the problem (one per generated source), so that the systems built on it are found
    again."""
    ins = [ca.MX.sym(step.name_in(i), step.sparsity_in(i)) for i in range(step.n_in())]
    return ca.Function(step.name(), [*ins, ca.MX.sym("settings", 0)], step(*ins), [*step.name_in(), "settings"],
                       step.name_out())


def problem_system(problem: Problem, references: str = "exact", controller: str = "python") -> System:
    """The ODE System :func:`rrr4.simulate` steps for `problem` (torque mode: its controller
    continuous or held, see :class:`Loop`), e.g. to time its right-hand side."""
    eqs = problem.equations()
    loop = loop_of(problem, eqs, controller, references, None)
    refs = reference_function(problem) if eqs.mode == "prescribed" else None
    return system_of(problem, eqs, loop, refs if loop.kind == "exact" else None, in_tree(problem, eqs))


def in_tree(problem: Problem, eqs: Equations) -> bool:
    """Whether the integrator steps tree coordinates (``integrator.coordinates``: 'auto' takes
    them wherever the ideal joints form a tree); raises SceneError for 'tree' without one."""
    c = problem.scene.integrator.coordinates
    if c == "tree" and eqs.tree_acceleration is None:
        raise SceneError("integrator.coordinates: 'tree' is not allowed here (no ideal joint joins a body to the "
                         "ground or to a placed body; use auto or reference-point)")
    return c != "reference-point" and eqs.tree_acceleration is not None

