"""Clearance compensation: the controller's references closed around the predicted journal
seats (DESIGN section 7).

Under preload each clearance journal rests on the side of its bearing that the planned
reaction pushes it to (:func:`rrr4.contact.seat_gap`, with the friction law's coefficient
at the planned slip velocity). An n-RRR chain closes around its two gaps exactly like an
ideal chain whose platform point is moved by -(g_B + g_C)
(:func:`rrr4.mechanism.kinematics.chain_ik`), so its compensated IK is closed form; any
other graph closes its loops around the gaps by Newton (:func:`compensated_ik`). The seated
journals' friction moments are overcome by a minimum-norm feed-forward, by virtual power.

How a seat follows friction (``actuation.seat_model``):

- ``quasi_static`` (default): the friction force is the friction law's at the planned slip
  velocity, so it reverses with the slip, at once.
- ``rolling`` (:func:`rolling_friction`): when the slip reverses, the journal does not slide
  back at once: it rolls on its bearing from one friction angle to the other (the slip
  velocity at the contact is R_J w_J - R_B w_B + c dpsi/dt, zero while it rolls), and the
  friction force turns with the contact angle. Rolling through the friction angle phi =
  atan(mu) takes a slip of phi c (c: the radial clearance), so the friction coefficient
  along the path is lambda mu with lambda' = w(s) s / (phi c), clipped to [-1, 1] (s: the
  planned slip velocity; w(s): the share of mu the friction law gives at s, so that a slip
  the law leaves without friction rolls nothing; lambda = 0 at the path's start, where the
  journals rest centred in their friction cone). This is Dahl's friction model with the rolling
  distance as its characteristic displacement; nothing in it is fitted. It depends on the
  slip's history, so the controller's references are tabulated along the path (as a graph
  scene's are) rather than computed by the closed-form step.
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from ..contact import friction_force, seat_gap
from ..dynamics.inverse import joint_reactions_function
from ..dynamics.layout import JOINT_PARAMETERS
from ..mechanism import kinematics as kin
from ..problem import Problem
from ..scene import FrictionEffect
from ..trajectory import trajectory_function

__all__ = ["seat_gaps", "seats", "contact_numbers", "nrrr_slip", "friction_feed_forward", "slip_rows",
           "compensated_ik", "rolling_friction", "seat_function", "planned_slip", "rolled_fraction",
           "ROLLING_GRID"]


def contact_numbers(problem: Problem, contact) -> tuple[dict, FrictionEffect]:
    """({clearance joint: (K [N/m^n], journal radius, bearing radius [m])}, the friction law
    with its coefficients) read from `contact`, a vector like ``Problem.contact_parameters``
    (numbers or symbols)."""
    at = problem.parameter_layout.index
    per = {name: tuple(contact[at(f"joints.{name}.{key}")] for key in JOINT_PARAMETERS)
           for name in problem.clearance_joints}
    mu, mu_s, v0, v1, v_s = (contact[at(f"contact.{key}")] for key in ("friction_coefficient", "static_coefficient",
                                                                       "v0", "v1", "stribeck_velocity"))
    fe = replace(problem.scene.effects.friction, coefficient=mu, static_coefficient=mu_s, v0=v0, v1=v1,
                 stribeck_velocity=v_s)
    return per, fe


def seats(problem: Problem, r, slip, contact, mu=None):
    """(gaps (2, nj) [m], friction forces f_t (nj,) [N]) of the passive revolute joints
    (``Model.preload_joints`` order) under their planned reactions r (2, nj) [N] and slip
    velocities slip (nj,) [m/s] (None: frictionless), symbolic, with the contact numbers
    from `contact` (see :func:`contact_numbers`); 0 at ideal joints. mu (nj,): the signed
    friction coefficients to use instead of the friction law's at the slip (e.g.
    :func:`rolling_friction`'s)."""
    names = problem.model.preload_joints
    per, fe = contact_numbers(problem, contact) if problem.clearance_joints else ({}, problem.scene.effects.friction)
    n_exp = problem.scene.effects.contact.exponent
    cols, f_t = [], []
    for j, name in enumerate(names):
        if name not in per:
            cols.append(ca.DM.zeros(2))
            f_t.append(0.0)
            continue
        stiffness, r_journal, r_bearing = per[name]
        if mu is not None:
            mu_j = mu[j]
        else:
            mu_j = 0.0 if slip is None or fe.law == "none" else friction_force(fe, slip[j], 1.0)
        gap, f_n = seat_gap(r[:, j], r_bearing - r_journal, stiffness, n_exp, mu_j)
        cols.append(gap)
        f_t.append(mu_j * f_n)
    return ca.horzcat(*cols), ca.vertcat(*f_t)


def seat_gaps(problem: Problem, r, slip=None):
    """Predicted gaps (2, nj) [m] (second joint point - first) of the passive revolute joints
    under their planned reactions r (2, nj) [N] (force of the first body on the second) and
    slip velocities slip (nj,) [m/s] (R_J omega_J - R_B omega_B; None: mu = 0), with the
    problem's contact numbers. SX or numeric."""
    gaps, _ = seats(problem, r, slip, problem.contact_parameters)
    return np.array(ca.evalf(gaps)) if not isinstance(r, (ca.SX, ca.MX)) else gaps


def nrrr_slip(problem: Problem, pose, pose_d, contact=None):
    """Slip velocities (2n,) [m/s] R_J omega_J - R_B omega_B of the passive joints B1..Bn,
    C1..Cn of an n-RRR at the desired motion (journals on the outboard bodies); the radii of
    the clearance joints from `contact` (default: the problem's, see :func:`contact_numbers`)."""
    mech = problem.mechanism
    per = {} if not problem.clearance_joints else contact_numbers(
        problem, problem.contact_parameters if contact is None else contact)[0]

    def radii(name):
        j = problem.joint(name)
        return per[name][1:] if name in per else (j.journal_radius, j.bearing_radius)

    cs = (ca.cos(pose[2]), ca.sin(pose[2]))
    b, c = [], []
    for i, ch in enumerate(mech.data.chains):
        u1, e, _, cd_rel, _, _ = kin.chain_motion(ch, pose[0:2], pose_d[2], 0, cs)
        w1, w2 = kin.link_rates(ch, u1, e, pose_d[0:2] + cd_rel, kin.transmission(ch, u1, e)[2])
        (rb_j, rb_b), (rc_j, rc_b) = radii(f"B{i + 1}"), radii(f"C{i + 1}")
        b.append(rb_j * w2 - rb_b * w1)
        c.append(rc_j * pose_d[2] - rc_b * w2)
    return ca.vertcat(*b, *c)


def friction_feed_forward(problem: Problem, pose, pose_d, slip, f_t):
    """Actuator torques (n,) [N m] that overcome the friction moments of the seated clearance
    journals (minimum norm): by virtual power, J^T dtau = -G^T f_t with f_t (nj,) [N] the
    friction forces at the planned normal forces and G = d slip / d pose_d (slip is linear
    in the platform twist)."""
    G = ca.jacobian(slip, pose_d)
    J = joint_reactions_function(problem.mechanism, problem.gravity)(pose, pose_d, pose_d)[5]  # J: the pose only
    return J @ ca.solve(J.T @ J, -G.T @ f_t)


def slip_rows(problem: Problem) -> np.ndarray:
    """W (nj, nq): slip velocities R_J omega_J - R_B omega_B = W qd of the passive revolute
    joints (``Model.preload_joints``; zero rows for ideal joints)."""
    model = problem.model
    W = np.zeros((len(model.preload_joints), model.nq))
    for j, name in enumerate(model.preload_joints):
        spec = problem.joint(name)
        if not spec.clearance:
            continue
        for body, radius in ((spec.journal_body, spec.journal_radius), (spec.bearing_body, -spec.bearing_radius)):
            i = model.rotation_index(body)
            if i is not None:
                W[j, i] += radius
    return W


def compensated_ik(problem: Problem, task: np.ndarray, r: np.ndarray, slip: np.ndarray,
                   guess: np.ndarray, mu: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Actuator coordinates (N, n) that put the task at `task` (N, k) with every clearance
    joint opened by its predicted seat under the reactions r (N, nj, 2) and slip velocities
    (N, nj), by Newton from `guess` (N, nq); and the seated journals' friction forces f_t
    (N, nj) [N]. mu (N, nj): signed friction coefficients instead of the law's at the slip
    (see :func:`seats`)."""
    mech, model = problem.mechanism, problem.model
    names = model.preload_joints
    clear = [names.index(j) for j in model.clearance_joints]
    N, nj = len(task), len(names)
    out = np.empty((N, mech.n))
    given = mu is not None
    f = seat_function(problem, given).map(N)
    r_cols = np.asarray(r, float).transpose(2, 0, 1).reshape(2, N * nj)  # (2, nj) blocks, one per instant
    args = [r_cols, np.asarray(slip, float).T, *([np.asarray(mu, float).T] if given else []),
            np.repeat(problem.contact_parameters[:, None], N, axis=1)]
    gaps, f_t = (np.array(v) for v in f(*args))
    gaps = gaps.reshape(2, N, nj)
    f_t = f_t.T
    for i in range(N):
        qi = mech.assemble(task[i], gaps[:, i, :].T[clear], guess=guess[i])
        out[i] = np.array(model.actuator_coordinates_function(qi)[0]).ravel()
    return out, f_t


def seat_function(problem: Problem, given_mu: bool = False) -> ca.Function:
    """SX Function 'seats' of :func:`seats`: r (2, nj) [N], slip (nj,) [m/s], (with given_mu:
    mu (nj,)), contact (the vector of ``Problem.contact_parameters``) -> gaps (2, nj) [m],
    f_t (nj,) [N]; built once per controller structure."""
    structure = problem.structure("controller")

    def build():
        nj = len(structure.model.preload_joints)
        r, slip = ca.SX.sym("r", 2, nj), ca.SX.sym("slip", nj)
        mu = [ca.SX.sym("mu", nj)] if given_mu else []
        contact = ca.SX.sym("contact", problem.contact_parameters.size)
        gaps, f_t = seats(structure, r, slip, contact, *(mu or [None]))
        return ca.Function("seats", [r, slip, *mu, contact], [gaps, f_t],
                           ["r", "slip", *(["mu"] if given_mu else []), "contact"], ["gaps", "f_t"])
    return structure.memo(("seat_function", given_mu), build)


def planned_slip(problem: Problem, t: np.ndarray) -> np.ndarray:
    """Slip velocities (N, nj) [m/s] R_J omega_J - R_B omega_B of the passive revolute joints
    (``Model.preload_joints``) in the planned motion along the path at the times t (N,) [s]."""
    mech, k = problem.mechanism, problem.mechanism.n_task
    p, pd, pdd = (np.array(v).T for v in trajectory_function(problem.path).map(len(t))(np.asarray(t, float)[None, :]))
    q = problem.path_coordinates(p, pd, pdd)
    return mech.motion(q, pd[:, :k], pdd[:, :k])[0] @ slip_rows(problem).T


ROLLING_GRID = 1e-3  # [s] the largest step on which rolling_friction integrates the rolling from the path's start


def rolling_friction(problem: Problem, t: np.ndarray) -> np.ndarray:
    """Signed friction coefficients (N, nj) of the passive revolute joints
    (``Model.preload_joints``) at the times t (N,) [s] of the path, by the rolling seat model
    (module docstring): lambda mu with lambda' = s w(s) / (atan(mu) c) clipped to [-1, 1] (s
    the planned slip velocity, :func:`planned_slip`; w(s) = |f_law(s)| / (mu f_n), the share
    of mu the friction law gives at s: a slip the law leaves without friction, e.g. below
    Ambrosio's v0, rolls nothing), integrated (trapezoidal) from lambda = 0 at
    the path's start on a grid of at most :data:`ROLLING_GRID` and interpolated to t, so
    that it does not depend on the grid asked for; opposing the slip as every friction law
    does; 0 at ideal joints and without friction. Only the law's coefficient mu enters (its
    transition speeds and a Stribeck law's static coefficient do not)."""
    t = np.asarray(t, float)
    out = np.zeros((len(t), len(problem.model.preload_joints)))
    fe = problem.scene.effects.friction
    if not problem.clearance_joints or fe.law == "none" or fe.coefficient <= 0 or not len(t):
        return out
    per, fe = contact_numbers(problem, problem.contact_parameters)
    mu = float(fe.coefficient)
    end = max(float(t.max()), 0.0)
    grid = np.linspace(0.0, end, max(int(np.ceil(end / ROLLING_GRID)) + 1, 2))
    slip = planned_slip(problem, grid)
    v = ca.SX.sym("v")
    acting = np.abs(np.array(ca.Function("law", [v], [friction_force(fe, v, 1.0)]).map(slip.size)(
        slip.reshape(1, -1))).reshape(slip.shape)) / mu  # the share of mu the law gives at the slip
    for j, name in enumerate(problem.model.preload_joints):
        if name not in per:
            continue
        _, r_journal, r_bearing = (float(v) for v in per[name])
        lam = rolled_fraction(grid, slip[:, j] * acting[:, j], np.arctan(mu) * (r_bearing - r_journal))
        out[:, j] = -mu * np.interp(t, grid, lam)  # friction opposes the slip
    return out


def rolled_fraction(t: np.ndarray, slip: np.ndarray, distance: float) -> np.ndarray:
    """lambda (N,) at the times t (N,) [s]: from 0 at t[0], lambda' = slip / distance clipped
    to [-1, 1] (trapezoidal in the slip velocity slip (N,) [m/s]); distance [m]: the slip that
    rolls a journal through one friction angle (see :func:`rolling_friction`)."""
    lam = np.zeros(len(t))
    step = 0.5 * (slip[1:] + slip[:-1]) * np.diff(t) / distance
    for i in range(1, len(t)):
        lam[i] = min(1.0, max(-1.0, lam[i - 1] + step[i - 1]))
    return lam
