"""Kinematics and inverse dynamics of any graph against references rrr4 does not compute.

On random mechanisms (tests/random_mechanisms.py: body and point tasks, revolute and
prismatic joints, clearance joints, gravity, springs, dampers and loads) and on the shipped
task scenes:

- body velocities and accelerations (``Mechanism.motion``) against central differences of
  the position analysis (``Mechanism.assemble``) along a smooth motion, Richardson-
  extrapolated, converging as the step shrinks;
- the effort family (``Problem.effort_family``, any alpha) against the virtual work of
  inertia, gravity and the force elements on each task direction (displacements by
  differences of the assembly; coordinates, forces and work by hand in numpy), and along the
  motion's own velocity the power balance: actuator power = d(kinetic + potential)/dt +
  damper power - load power; the null-space efforts do no work;
- the passive joints' reactions against Newton-Euler of every body they alone hold.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import rrr4
from rrr4.errors import KinematicsError
from rrr4.problem import build
from rrr4.scene import parse_scene
from rrr4.trajectory import trajectory_function

from .random_mechanisms import Bodies, random_mechanism


class Case:
    """A problem, a motion x(t) of its task through t = 0 (rates v, a there) and its assembly
    q0 at t = 0 from `guess`, with differences along the motion and the task's directions."""

    def __init__(self, problem, x, v, a, guess):
        self.problem, self.x, self.v, self.a = problem, x, np.asarray(v, float), np.asarray(a, float)
        self.mech = problem.mechanism
        self.k = self.mech.n_task
        self.bodies = Bodies(problem.scene, problem.force_parameters)
        self.x0 = np.asarray(x(0.0), float)
        self.q0 = self.mech.assemble(self.x0, guess=guess)

    def assembly(self, target):
        """The assembly at `target` from q0, polished by two more Newton steps (the rootfinder
        stops at a residual of 1e-13, which second differences at 1e-3 s would amplify to 1e-7)."""
        q = self.mech.assemble(target, guess=self.q0)
        p = np.r_[target, np.zeros(self.mech.nq - self.k)]
        for _ in range(2):
            A = np.array(self.mech.constraint_jacobian_function(q, np.zeros_like(q))[0])
            q = q - np.linalg.solve(A, np.array(self.mech.closure_function(q, p)).ravel())
        return q

    def q(self, t):
        return self.assembly(self.x(t))

    def differences(self, h):
        """(qd, qdd) at t = 0 by central differences of step h, Richardson-extrapolated with 2h."""
        qs = {m: self.q(m * h) for m in (-2, -1, 1, 2)}
        d1 = [(qs[m] - qs[-m]) / (2 * m * h) for m in (1, 2)]
        d2 = [(qs[m] - 2 * self.q0 + qs[-m]) / (m * h) ** 2 for m in (1, 2)]
        return (4 * d1[0] - d1[1]) / 3, (4 * d2[0] - d2[1]) / 3

    def rate(self, f, h=5e-5):
        """d/dt f(q(t)) at t = 0 (central, Richardson)."""
        return _derivative(lambda e: f(self.q(e)), h)

    def task_derivative(self, f, i, eps=1e-5):
        """d f(q) / d x_i at x0 (central, Richardson)."""
        e = np.zeros(self.k)
        e[i] = 1.0
        return _derivative(lambda d: f(self.assembly(self.x0 + d * e)), eps)

    def family(self):
        pad = np.zeros(3 - self.k)
        return self.problem.effort_family(np.r_[self.x0, pad][None], np.r_[self.v, pad][None],
                                          np.r_[self.a, pad][None], q=self.q0[None])


def _derivative(f, h):
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


def random_case(seed: int, family: str, chains: int) -> Case:
    """A random mechanism (tests/random_mechanisms.py) moving as x0 + v t + a t^2/2 + j t^3/6
    with v, a, j up to 0.5 m/s, 2 m/s^2, 5 m/s^3 (rad for an angle)."""
    data = random_mechanism(seed, family, chains)
    problem = build(parse_scene(data, data["name"]))
    rng = np.random.default_rng(seed)
    k = problem.mechanism.n_task
    x0 = np.array(data["path"]["start"], float)[:k]
    v, a, j = rng.uniform(-0.5, 0.5, k), rng.uniform(-2, 2, k), rng.uniform(-5, 5, k)
    guess = [c for b in data["mechanism"]["bodies"] for c in b["pose"]]
    return Case(problem, lambda t: x0 + v * t + a * t**2 / 2 + j * t**3 / 6, v, a, guess)


def path_case(problem, t0: float, guess=None) -> Case:
    """The problem's own path through t0."""
    traj = trajectory_function(problem.path)
    k = problem.mechanism.n_task

    def x(t):
        return np.array(traj(t0 + t)[0]).ravel()[:k]
    _, v, a = (np.array(r).ravel()[:k] for r in traj(t0))
    if guess is None:
        guess = problem.mechanism.assemble(x(0.0))
    return Case(problem, x, v, a, guess)


def well_conditioned(case: Case) -> bool:
    """The pose is away from singular poses: the closure's and the task map's Jacobians are
    well conditioned there and the motion assembles over the differences' span."""
    A = np.array(case.mech.constraint_jacobian_function(case.q0, np.zeros_like(case.q0))[0])
    J = case.mech.path_jacobians(case.q0[None])[0]
    if np.linalg.cond(A) > 1e3 or np.linalg.svd(J, compute_uv=False)[-1] < 1e-2:
        return False
    try:
        for t in (-2e-3, 2e-3):
            case.q(t)
    except KinematicsError:
        return False
    return True


def check_kinematics(case: Case, steps=(1e-3, 5e-4, 2.5e-4), rtol=1e-6):
    """motion's rates against differences of the assembly: within rtol at one of the steps
    (truncation falls and rounding grows as the step shrinks), or converging to them as h^4
    (Richardson) where the motion is fast for the steps. Returns the relative errors
    (velocity, acceleration) at each step."""
    qd, qdd, th_d, _ = (v.ravel() for v in case.mech.motion(case.q0[None], case.v[None], case.a[None]))
    errors = []
    for h in steps:
        qd_fd, qdd_fd = case.differences(h)
        errors.append((np.abs(qd - qd_fd).max() / (1 + np.abs(qd_fd).max()),
                       np.abs(qdd - qdd_fd).max() / (1 + np.abs(qdd_fd).max())))
    for which in (0, 1):
        e = [x[which] for x in errors]
        assert min(e) < rtol or all(f < c / 8 for c, f in zip(e, e[1:], strict=False)), (which, errors)
    th_d_fd = case.rate(case.bodies.actuator_coordinates)
    assert np.allclose(th_d, th_d_fd, rtol=rtol, atol=rtol * 0.1 * (1 + np.abs(th_d_fd).max()))
    return errors


def check_dynamics(case: Case, seed: int = 0, rtol: float = 2e-6):
    """The effort family (alpha drawn) against virtual work and the power balance, and the
    reactions against Newton-Euler; the kinematics (checked apart) from ``motion``."""
    qd, qdd, _, _ = (v.ravel() for v in case.mech.motion(case.q0[None], case.v[None], case.a[None]))
    fam = case.family()
    alpha = np.random.default_rng(seed + 1).uniform(-5, 5, fam.tau_n.shape[2])
    u = fam.tau_p[0] + fam.tau_n[0] @ alpha
    b = case.bodies
    s, sd = b.element_coordinates(case.q0), case.rate(b.element_coordinates)
    scale = 1.0 + np.abs(u).max()
    for i in range(case.k):  # virtual work on every task direction: u . d theta = -W
        d_theta = case.task_derivative(b.actuator_coordinates, i)
        work = b.generalised_work(case.q0, case.task_derivative(lambda q: q, i), qdd, s, sd,
                                  case.task_derivative(b.element_coordinates, i), known_only=True)
        assert u @ d_theta == pytest.approx(-work, abs=rtol * scale * (1 + np.abs(d_theta).max())), i
    th_d = case.rate(b.actuator_coordinates)  # the power balance along the motion
    power = -b.generalised_work(case.q0, qd, qdd, s, sd, sd, known_only=True)
    assert u @ th_d == pytest.approx(power, abs=rtol * scale * (1 + np.abs(th_d).max()))
    assert np.max(np.abs(fam.tau_n[0].T @ th_d), initial=0.0) < rtol * (1 + np.abs(th_d).max())
    return _check_reactions(case, fam, alpha, qdd)


def _check_reactions(case: Case, fam, alpha, qdd) -> int:
    """Newton-Euler of every body held only by passive revolute joints and carrying no force
    element; the number of bodies checked."""
    b, names = case.bodies, list(case.problem.model.preload_joints)
    r = fam.r_p[0] + fam.r_n[0] @ alpha if alpha.size else fam.r_p[0]  # force of bodies[0] on bodies[1]
    loaded = {x for e, _ in b.forces for x in e.bodies}
    scale = 1 + np.max(np.abs(r), initial=0.0)
    checked = 0
    for k, body in enumerate(b.names):
        held = [j for j in b.joints.values() if body in j.bodies]
        if body in loaded or any(j.name not in names for j in held):
            continue
        centre, _ = b.pose(case.q0, body)
        force, moment = b.mass[k] * b.gravity, 0.0
        for j in held:
            f = r[names.index(j.name)] * (1 if j.bodies[1] == body else -1)
            force = force + f
            d = b.point(case.q0, body, j.points[j.bodies.index(body)]) - centre
            moment += d[0] * f[1] - d[1] * f[0]
        assert np.allclose(force, b.mass[k] * qdd[3 * k:3 * k + 2], atol=1e-6 * scale), body
        assert moment == pytest.approx(b.inertia[k] * qdd[3 * k + 2], abs=1e-6 * scale), body
        checked += 1
    return checked


FAMILIES = st.sampled_from([("body", 3), ("body", 4), ("point", 3)])


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**31), family=FAMILIES)
def test_random_mechanisms_rates_and_inverse_dynamics(seed, family):
    """Property: on any drawn mechanism, motion agrees with differences of the assembly, and
    the effort family (with any preload) with the virtual work, the power balance and
    Newton-Euler of the bodies held by passive joints."""
    case = random_case(seed, *family)
    assume(well_conditioned(case))
    check_kinematics(case)
    check_dynamics(case, seed)


TASK_SCENES = ["paper_circle", "paper_circle_graph", "redundant_five_bar", "rrr3_circle", "xyt_table",
               "process_load_circle", "ideal_circle"]


@pytest.mark.parametrize("name", TASK_SCENES)
def test_shipped_scenes_rates_and_inverse_dynamics(name):
    """Every shipped scene with a task, at points along its own path: the same checks."""
    problem = build(rrr4.load_scene(f"problems/{name}.yaml"))
    duration = problem.path.duration
    checked = 0
    for t0 in (0.21 * duration, 0.5 * duration, 0.83 * duration):
        case = path_case(problem, t0)
        check_kinematics(case, steps=(1e-2, 5e-3, 2.5e-3))  # slow paths: rounding dominates below 1e-3 s
        checked += check_dynamics(case)
    assert checked > 0 or not problem.model.preload_joints  # some body is held by passive joints alone


def test_five_bar_accelerations_along_a_line():
    """The reported case: the five-bar's point moving along a straight line at a constant
    (0.3, -0.2) m/s. The point's acceleration is zero, and every body's acceleration agrees
    with second differences of the assembly to 1e-6 relative (it missed omega^2 u before)."""
    problem = build(rrr4.load_scene("problems/redundant_five_bar.yaml"))
    v = np.array([0.3, -0.2])
    case = Case(problem, lambda t: v * t, v, np.zeros(2), problem.mechanism.assemble(np.zeros(2)))
    errors = check_kinematics(case, steps=(2e-3, 1e-3), rtol=1e-6)
    assert min(e[1] for e in errors) < 1e-6
    check_dynamics(case)
