"""The initial state of a simulation: the mechanism at the path's start (or the drivers'
initial values), with the path's start velocity plus ``initial.platform_velocity``; every
clearance journal centred, or with ``initial.journals: seated`` resting on its bearing
wall under the ideal reaction at t = 0 of the controller's efforts there
(:func:`rrr4.contact.seat_gap`, frictionless)."""

from __future__ import annotations

import numpy as np

from ..contact import seat_gap_function
from ..contact.wear import depth_at
from ..dynamics.builder import Equations, profiles_of
from ..dynamics.family import graph_family
from ..problem import Problem
from ..trajectory import trajectory_function
from .state_layout import StateLayout

__all__ = ["initial_state", "seated_offsets"]


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
    for joint, by_surface in profiles_of(eqs).items():  # on a worn profile: the seat lies deeper by w(psi)
        k, gap = joints.index(joint), gaps[joints.index(joint)]
        size = np.linalg.norm(gap)
        if size > 0:
            spec = problem.joint(joint)
            bodies = {"bearing": spec.bearing_body, "journal": spec.journal_body}
            e = gap if spec.journal == 1 else -gap  # the eccentricity, journal - bearing
            angle = np.arctan2(e[1], e[0])
            depth = sum(float(depth_at(d, angle - _angle(problem, q0, bodies[s]))) for s, d in by_surface.items())
            gaps[k] = gap * (size + depth) / size
    return gaps


def _angle(problem: Problem, q, body: str) -> float:
    """The rotation [rad] of `body` in the coordinates q (0 for the ground)."""
    i = problem.model.rotation_index(body)
    return 0.0 if i is None else float(q[i])


def initial_state(problem: Problem, eqs: Equations, efforts, tree: bool, settings) -> np.ndarray:
    """x0 = [t = 0, y0, W_in, D_damping, D_friction = 0, the wear quadratures = 0, delta_dot0 = v_min, in_contact,
    losses = 0 (nc each), the equations' parameters, the controller's settings]; y0 = [q,
    qd], or the tree coordinates with `tree`. efforts(t, q, qd): the controller's efforts at
    states (torque mode), for the seated journals' loads."""
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
    seated = np.zeros(nc)
    if scene.initial.journals == "seated" and nc and (eqs.mode != "free" or scene.graph.drivers):
        tau0 = efforts(np.array([0.0]), q0[None, :], qd0[None, :])[0] if eqs.mode == "torque" else \
            np.zeros(eqs.n_actuators)
        offsets = seated_offsets(problem, eqs, q0, qdd0, tau0)
        q0 = problem.seated_coordinates(target, offsets, guess=q0)
        seated = np.any(offsets != 0, axis=1).astype(float)
    y0 = np.r_[q0, qd0] if not tree else np.hstack([np.array(v).ravel() for v in eqs.tree_coordinates(q0, qd0)])
    L = StateLayout(nq=len(y0) // 2, n_wear=sum(m for *_, m in eqs.worn), nc=nc, n_parameters=len(eqs.parameters),
               n_settings=len(settings))  # without the peaks: System.started appends them
    x0 = np.zeros(1 + L.ny + L.nz)  # t, the energy and wear quadratures and the losses start at 0
    x0[L.in_x("motion")], x0[L.in_x("delta_dot0")], x0[L.in_x("in_contact")] = y0, eqs.v_min, seated
    x0[L.in_x("parameters")], x0[L.in_x("settings")] = eqs.parameters, settings
    return x0
