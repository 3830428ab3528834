"""The initial state of a simulation: the mechanism at the path's start (or the drivers'
initial values), with the path's start velocity plus ``initial.platform_velocity``; every
clearance journal centred, or with ``initial.journals: seated`` resting on its bearing
wall under the ideal reaction at t = 0 of the controller's efforts there
(:func:`rrr4.contact.seat_gap`, frictionless)."""

from __future__ import annotations

import numpy as np

from ..checks import describe
from ..contact import seat_gap_function
from ..contact.wear import depth_at
from ..dynamics.builder import Equations, profiles_of, with_profiles
from ..dynamics.family import graph_family
from ..errors import SceneError
from ..problem import Problem
from ..trajectory import trajectory_function
from .state_layout import StateLayout

__all__ = ["initial_state", "seated_offsets", "continued_motion", "RESEAT_TOLERANCE"]

# a continued journal's elastic force after a cycle jump matches the one it ended with to this
# fraction of it (or of 1 N), within RESEAT_ITERATIONS iterations
RESEAT_TOLERANCE = 1e-6
RESEAT_ITERATIONS = 40


def seated_offsets(problem: Problem, eqs: Equations, q0, qdd0, tau0) -> np.ndarray:
    """Offsets (nc, 2) [m] (second joint point - first) of the clearance joints with each
    journal seated (:func:`rrr4.contact.seat_gap`, no friction) under the ideal reaction r_j
    at the state (q0, qdd0) of the efforts tau0 (n,) and the scene's force elements at t = 0
    (dampers at rest); joints carrying less than
    ``SEAT_FORCE`` stay centred."""
    loads = problem.plant_forces  # the force elements at t = 0 (the ideal motion's qd, 0 here, is not known)
    external = None if loads is None else np.array(loads(q0, np.zeros_like(q0), 0.0)).T
    fam = graph_family(problem.mechanism, np.atleast_2d(q0), np.atleast_2d(qdd0), problem.gravity, external)
    tau_n = fam.tau_n[0]
    alpha = np.linalg.pinv(tau_n) @ (tau0 - fam.tau_p[0]) if tau_n.size else np.zeros(0)
    r = fam.r_p[0] + (fam.r_n[0] @ alpha if alpha.size else 0.0)
    names, joints = problem.model.preload_joints, eqs.clearance_joints
    if not joints:
        return np.zeros((0, 2))
    rj = np.array([r[names.index(j)] for j in joints]).T  # (2, nc)
    clearance = np.array([[problem.joint(j).radial_clearance for j in joints]])
    gaps, _ = seat_gap_function().map(len(joints))(rj, clearance, np.array([eqs.stiffness]),
                                                    problem.scene.effects.contact.exponent, 0.0)
    gaps = np.array(gaps).T
    return _deepened(problem, q0, gaps, profiles_of(eqs))


def _deepened(problem: Problem, q, offsets: np.ndarray, profiles: dict) -> np.ndarray:
    """`offsets` (nc, 2) (second joint point - first) at the coordinates q with each journal
    moved along its eccentricity by the depth of `profiles` (joint -> surface -> coefficients)
    in that direction: a journal on the worn profile lies deeper by w(psi)."""
    return _sunk(offsets, _depths(problem, q, offsets, profiles))


def _depths(problem: Problem, q, offsets: np.ndarray, profiles: dict) -> np.ndarray:
    """The depth (nc,) [m] of `profiles` along each joint's offset (0 where none is given)."""
    joints = problem.model.clearance_joints
    out = np.zeros(len(joints))
    for joint, by_surface in profiles.items():
        k = joints.index(joint)
        spec = problem.joint(joint)
        bodies = {"bearing": spec.bearing_body, "journal": spec.journal_body}
        e = offsets[k] if spec.journal == 1 else -offsets[k]  # the eccentricity, journal - bearing
        angle = np.arctan2(e[1], e[0])
        out[k] = sum(float(depth_at(d, angle - _angle(problem, q, bodies[s]))) for s, d in by_surface.items())
    return out


def _sunk(offsets: np.ndarray, sinks: np.ndarray) -> np.ndarray:
    """`offsets` (nc, 2) each lengthened by its sink [m] (a centred joint stays centred)."""
    size = np.linalg.norm(offsets, axis=1)
    return np.where(size[:, None] > 0, offsets * ((size + sinks) / np.where(size > 0, size, 1.0))[:, None], offsets)


def _elastic_forces(eqs: Equations, q) -> np.ndarray:
    """The clearance joints' normal forces (nc,) [N] at the coordinates q at rest (no damping)."""
    return np.array(eqs.acceleration.call({"q": q, "qd": np.zeros_like(q)})["normal_force"]).ravel()


def _force_vectors(eqs: Equations, q) -> np.ndarray:
    """The clearance joints' contact forces (nc, 2) [N] at the coordinates q at rest (no damping,
    no slip: no friction)."""
    return np.array(eqs.acceleration.call({"q": q, "qd": np.zeros_like(q)})["contact_force"]).T


def _reseated(problem: Problem, eqs: Equations, before: Equations, q, offsets: np.ndarray, target,
              added: dict) -> np.ndarray:
    """q after a cycle jump deepened the profiles from those of `before` to those of `eqs`: each
    loaded journal sinks along its eccentricity until the deeper profile carries the elastic
    force the old one carried at q. The force grows with the sink, which lies between 0 (the
    overlap can only have fallen) and twice the deepest added depth (the overlap can only have
    grown over the old arc, within 60 deg of the eccentricity): safeguarded secant iterations
    in that bracket, from the added depth along the eccentricity, which is exact for a uniform
    sink. A groove narrower than the journal's arc, as early wear makes it, would press a
    journal moved by that depth into its flanks (4 to 6 times its load on the reference
    scene's grooves, and it bounced off). Then :func:`_equilibrium` matches the force vector.
    A journal out of contact moves by the added depth (it keeps its distance from the wall)."""
    target_force = _elastic_forces(before, q)
    loaded = target_force > 0
    sinks = _depths(problem, q, offsets, added)
    grid = np.linspace(0.0, 2.0 * np.pi, 721)
    joints = problem.model.clearance_joints
    lo, hi = np.zeros(len(joints)), np.zeros(len(joints))
    for joint, by_surface in added.items():
        hi[joints.index(joint)] = 2.0 * sum(float(np.max(depth_at(d, grid))) for d in by_surface.values())
    prev = None
    for _ in range(RESEAT_ITERATIONS):
        q_new = problem.seated_coordinates(target, _sunk(offsets, sinks), guess=q)
        miss = np.where(loaded, _elastic_forces(eqs, q_new) - target_force, 0.0)
        if np.all(np.abs(miss) <= RESEAT_TOLERANCE * np.maximum(target_force, 1.0)):
            break
        lo, hi = np.where(miss < 0, sinks, lo), np.where(miss > 0, sinks, hi)
        step = np.full(len(joints), np.nan)
        if prev is not None:
            ds, dm = sinks - prev[0], miss - prev[1]
            step = np.where((ds != 0) & (dm != 0), -miss * ds / np.where(dm != 0, dm, 1.0), np.nan)
        guess = sinks + step
        inside = np.isfinite(guess) & (guess > lo) & (guess < hi)
        prev = (sinks, miss)
        sinks = np.where(loaded, np.where(inside, guess, 0.5 * (lo + hi)), sinks)
    return _equilibrium(problem, eqs, _force_vectors(before, q), q_new, _sunk(offsets, sinks), target, loaded,
                        float(np.max(hi)))


def _equilibrium(problem: Problem, eqs: Equations, force, q, offsets: np.ndarray, target, loaded, reach: float):
    """q with each loaded journal moved (both components of its offset) until the deeper profile
    carries the force vector `force` (nc, 2) it carried before the jump: a groove's slope turns
    the force off the line of centres, so the journal also slides toward the groove's bottom
    (Newton with a finite-difference Jacobian per joint, steps no longer than `reach`; the
    start, from :func:`_reseated`, carries the force's size). Returns q where it got closest."""
    h = 1e-3 * max(reach, 1e-9)

    def at(o):
        qs = problem.seated_coordinates(target, o, guess=q)
        return qs, _force_vectors(eqs, qs)

    best = (np.inf, q)
    for _ in range(RESEAT_ITERATIONS // 4):
        q, f = at(offsets)
        miss = np.where(loaded[:, None], f - force, 0.0)
        size = float(np.max(np.linalg.norm(miss, axis=1) / np.maximum(np.linalg.norm(force, axis=1), 1.0)))
        if size < best[0]:
            best = (size, q)
        if size <= RESEAT_TOLERANCE:
            break
        columns = []
        for axis in range(2):
            o = offsets.copy()
            o[:, axis] += h
            columns.append((at(o)[1] - f) / h)
        jac = np.stack(columns, axis=2)  # (nc, 2, 2): d force_k / d offset_k
        step = np.zeros_like(offsets)
        for k in np.flatnonzero(loaded):
            try:
                step[k] = -np.linalg.solve(jac[k], miss[k])
            except np.linalg.LinAlgError:
                continue
        length = np.linalg.norm(step, axis=1, keepdims=True)
        offsets = offsets + step * np.minimum(1.0, reach / np.maximum(length, 1e-300))
    return best[1]


def _angle(problem: Problem, q, body: str) -> float:
    """The rotation [rad] of `body` in the coordinates q (0 for the ground)."""
    i = problem.model.rotation_index(body)
    return 0.0 if i is None else float(q[i])


def continued_motion(problem: Problem, eqs: Equations, start, q0: np.ndarray, target) -> tuple:
    """(q, qd, delta_dot0, in_contact) where the run `start` (a Simulation) ended: its last
    output's motion, each body's angle shifted by the whole turns that bring it nearest its
    angle in q0 (the scene's own start), and each journal's contact memory; one line when
    `start` is not a run of a mechanism of this structure. Where the equations' wear profiles
    are deeper than the ones `start` ran on (a cycle jump), each loaded journal moves until the
    deeper profile carries the force vector it ended with (:func:`_reseated`; the task, or the
    drivers, at `target`), so a jump neither drops it onto the bore nor presses it into the
    groove's flanks."""
    joints = problem.model.clearance_joints
    end = getattr(start, "stats", {}).get("end_contact") if hasattr(start, "q") else None
    if end is None and joints or np.shape(getattr(start, "q", None))[1:] != q0.shape or \
            tuple(getattr(start, "clearance_joints", ())) != tuple(joints):
        raise SceneError(f"start: {describe(start)} is not allowed (a Simulation of a scene of the same mechanism, "
                         "whose end the run starts from)")
    q, qd = np.array(start.q[-1], float), np.array(start.qd[-1], float)
    turns = [problem.model.rotation_index(b) for b in problem.model.body_names]
    q[turns] -= 2 * np.pi * np.round((q[turns] - q0[turns]) / (2 * np.pi))
    nc = len(joints)
    if nc:
        before = end.get("profiles", {})
        added = {j: {s: d - before[j][s] if j in before else d for s, d in by.items()}
                 for j, by in profiles_of(eqs).items()}
        if any(np.any(d != 0) for by in added.values() for d in by.values()):
            e = np.asarray(start.eccentricity[-1], float)
            offsets = np.array([e[k] if problem.joint(j).journal == 1 else -e[k] for k, j in enumerate(joints)])
            if problem.model.task is not None:
                target = np.array(problem.model.task_pose_function(q)).ravel()[:len(target)]
            old = {j: {s: before.get(j, {}).get(s, np.zeros_like(d)) for s, d in by.items()}
                   for j, by in profiles_of(eqs).items()}
            q = _reseated(problem, eqs, with_profiles(eqs, old), q, offsets, target, added)
    return q, qd, (end["delta_dot0"] if nc else np.zeros(0)), (end["in_contact"] if nc else np.zeros(0))


def initial_state(problem: Problem, eqs: Equations, efforts, tree: bool, settings, start=None) -> np.ndarray:
    """x0 = [t = 0, y0, W_in, D_damping, D_friction = 0, the wear quadratures = 0, delta_dot0 = v_min, in_contact,
    losses = 0 (nc each), the equations' parameters, the controller's settings]; y0 = [q,
    qd], or the tree coordinates with `tree`. efforts(t, q, qd): the controller's efforts at
    states (torque mode), for the seated journals' loads. start: a Simulation whose end the
    state takes instead (:func:`continued_motion`)."""
    scene, mech, model = problem.scene, problem.mechanism, problem.model
    nc = len(eqs.clearance_joints)
    if model.task is not None:
        pose0, pose_d0, pose_dd0 = (np.array(v).ravel() for v in trajectory_function(scene.path)(0.0))
        k = mech.n_task
        target, target_d, target_dd = (pose0[:k], (pose_d0 + np.asarray(scene.initial.platform_velocity))[:k],
                                       pose_dd0[:k])
    else:
        target, target_d, target_dd = (np.array(v, float).ravel() for v in model.driver_values(0.0))
    q0, qd0, qdd0 = problem.body_motion(target, target_d, target_dd)
    seated, delta_dot0 = np.zeros(nc), np.full(nc, eqs.v_min)
    if start is not None:  # where an earlier run ended (continued_motion)
        q0, qd0, delta_dot0, seated = continued_motion(problem, eqs, start, q0, target)
    elif scene.initial.journals == "seated" and nc and (eqs.mode != "free" or scene.graph.drivers):
        tau0 = efforts(np.array([0.0]), q0[None, :], qd0[None, :])[0] if eqs.mode == "torque" else \
            np.zeros(eqs.n_actuators)
        offsets = seated_offsets(problem, eqs, q0, qdd0, tau0)
        q0 = problem.seated_coordinates(target, offsets, guess=q0)
        seated = np.any(offsets != 0, axis=1).astype(float)
    y0 = np.r_[q0, qd0] if not tree else np.hstack([np.array(v).ravel() for v in eqs.tree_coordinates(q0, qd0)])
    L = StateLayout(nq=len(y0) // 2, n_wear=sum(m for *_, m in eqs.worn), nc=nc, n_parameters=len(eqs.parameters),
               n_settings=len(settings))  # without the peaks: System.started appends them
    x0 = np.zeros(1 + L.ny + L.nz)  # t, the energy and wear quadratures and the losses start at 0
    x0[L.in_x("motion")], x0[L.in_x("delta_dot0")], x0[L.in_x("in_contact")] = y0, delta_dot0, seated
    x0[L.in_x("parameters")], x0[L.in_x("settings")] = eqs.parameters, settings
    return x0
