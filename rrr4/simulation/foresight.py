"""What a run can resolve, said before it starts (``rrr4 check``, ``rrr4 run``).

Two one-line warnings, each naming what to use instead:

- a contact law outside the range it was derived for (:func:`rrr4.contact.validity.law_outside_range`:
  Lankarani-Nikravesh or Hunt-Crossley at low restitution);
- a step too coarse for the stiffest vibration of the contact. A journal pressed into its
  bearing by the load F is a spring of stiffness k = dF/d(delta) = n K^(1/n) F^(1 - 1/n)
  (the contact law's elastic part K delta^n at the penetration that carries F) and a
  damper c = dF/d(delta_dot): Kelvin-Voigt's damping; a hysteresis law's chi F / v_min where
  the journals start seated (a lasting contact, whose captured approach velocity is the
  floor V_MIN), else 0 (a contact entered by an impact captures its speed, unknown before
  the run, and damps far less). Against the
  lightest body at a clearance joint, m, it vibrates at omega = sqrt(k / m). The load is
  the largest planned reaction of a clearance joint along the path (the ideal inverse
  dynamics, with the preload where the controller preloads), or for a scene moved by its
  drivers the largest reaction of its ideal twin over one driver revolution. A fixed step h
  takes 2 pi / (omega h) steps per period of that vibration: with fewer than
  :data:`STEPS_PER_PERIOD` it cannot represent it (an implicit method damps it away
  numerically, and the energy audit then flags the run), and an explicit method is unstable
  beyond the largest step that keeps both eigenvalues of m x'' + c x' + k x = 0 inside its
  stability region (:func:`rrr4.integrators.stability.largest_stable_step`; RK4 undamped:
  omega h = 2 sqrt 2).
- an oil film an explicit step cannot follow. At the eccentricity where the film hands
  over to the dry laws (``threshold``, where it is stiffest) the film resists a squeeze of
  the journal with C = |F_n(A = 1)| / c [N s/m] (:func:`rrr4.contact.film_force`, A =
  eps_dot) and a radial displacement with the wedge's stiffness |dF_n/d eps| / c (the journal
  turning at the fastest driver's speed); against the lightest body at the joint, the
  explicit method's largest stable step for that spring-damper (RK4, damping alone: C h / m
  <= 2.785) bounds the step.

Adaptive methods and error-controlled steps choose their own step and are not judged here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..contact import film_force
from ..contact.normal import V_MIN, hysteresis_factor
from ..contact.validity import law_outside_range
from ..dynamics.builder import lubricated_joints
from ..dynamics.family import graph_family
from ..integrators import METHODS, FixedStepIntegrator
from ..integrators.stability import STABILITY_POLYNOMIALS, largest_stable_step, oscillator_eigenvalues
from ..problem import Problem
from ..scene import GROUND
from ..trajectory import sample_path

__all__ = ["foresight_lines", "stiffest_vibration", "Vibration", "STEPS_PER_PERIOD", "film_oscillator"]

STEPS_PER_PERIOD = 2.0                        # fewer fixed steps per period cannot represent a vibration


@dataclass(frozen=True)
class Vibration:
    """The stiffest contact vibration of a problem: omega [rad/s] of the contact stiffness
    k [N/m] at `joint` under the load [N], against the body of mass [kg]."""
    omega: float
    stiffness: float
    load: float
    joint: str
    body: str
    mass: float
    damping: float = 0.0  # [N s/m]: the law's d F / d delta_dot (see the module docstring)


def _largest_load(problem: Problem, preload=None) -> float | None:
    """The largest planned reaction [N] of any clearance joint along the path: the preload's
    reactions when given, else those of the minimum-norm efforts; without a task body, the
    ideal twin's reactions over one cycle of its drivers (:func:`_driven_load`)."""
    if problem.model.task is None:
        return _driven_load(problem)
    if preload is not None:
        names, r = list(preload.joint_names), np.asarray(preload.reactions)
    else:
        s = sample_path(problem.path)
        names, r = list(problem.model.passive_joints), problem.effort_family(s.pose, s.pose_d, s.pose_dd).r_p
    cols = [names.index(j) for j in problem.clearance_joints if j in names]
    return float(np.max(np.linalg.norm(r[:, cols], axis=-1))) if cols and r.size else None


def _driven_load(problem: Problem, samples: int = 72) -> float | None:
    """The largest reaction [N] of a clearance joint of the ideal twin moved by its drivers,
    over one revolution of the first driver (a revolute one at a constant speed) or the path's
    duration; None without drivers."""
    model, drivers = problem.model, problem.scene.graph.drivers
    if not drivers:
        return None
    d = drivers[0]
    turns = problem.scene.graph.joint(d.joint).type == "revolute" and d.time_law == "constant" and d.speed != 0
    t_end = 2 * math.pi / abs(d.speed) if turns else problem.path.duration
    motion = [problem.body_motion(*(np.array(v, float).ravel() for v in model.driver_values(t)))
              for t in np.linspace(0.0, t_end, samples, endpoint=False)]
    q, qdd = np.array([m[0] for m in motion]), np.array([m[2] for m in motion])
    r = graph_family(problem.mechanism, q, qdd, problem.gravity, None).r_p
    names = list(model.preload_joints)
    cols = [names.index(j) for j in problem.clearance_joints if j in names]
    return float(np.max(np.linalg.norm(r[:, cols], axis=-1))) if cols and r.size else None


def stiffest_vibration(problem: Problem, preload=None) -> Vibration | None:
    """The stiffest contact vibration of `problem` (see the module docstring); None without
    clearance joints, without a planned load or with a law that has no elastic part to speak of."""
    joints = problem.clearance_joints
    load = _largest_load(problem, preload) if joints else None
    if not load or load <= 0:
        return None
    contact = problem.scene.effects.contact
    n = contact.exponent
    joint = max(joints, key=problem.joint_stiffness)
    K = problem.joint_stiffness(joint)
    k = n * K ** (1.0 / n) * load ** (1.0 - 1.0 / n)
    chi = hysteresis_factor(contact.law, contact.restitution)
    seated = problem.scene.initial.journals == "seated"  # a lasting contact from the start: delta_dot0 = V_MIN
    damping = contact.damping if chi is None else chi * load / V_MIN if seated else 0.0
    mass = {b.name: b.mass for b in problem.scene.graph.bodies}
    body = min((b for j in joints for b in problem.joint(j).bodies if b != GROUND), key=mass.__getitem__)
    return Vibration(math.sqrt(k / mass[body]), k, load, joint, body, mass[body], float(damping))


def _step_line(problem: Problem, step: float, method: str, preload=None) -> str | None:
    """One line when a fixed `step` [s] of `method` cannot resolve the stiffest contact vibration."""
    cls = METHODS.get(method)
    if cls is None or not issubclass(cls, FixedStepIntegrator) or problem.scene.integrator.tolerance is not None:
        return None
    v = stiffest_vibration(problem, preload)
    if v is None:
        return None
    wh = v.omega * step
    bound = largest_stable_step(method, oscillator_eigenvalues(v.mass, v.stiffness, v.damping))
    what = (f"integrator.step: {step:g} s with {method}: the stiffest contact vibration (K = "
            f"{problem.joint_stiffness(v.joint):.3g} at {v.joint} under {v.load:.3g} N, k = {v.stiffness:.3g} N/m, "
            f"c = {v.damping:.3g} N s/m, against {v.body} of {v.mass:g} kg) has omega = {v.omega:.3g} rad/s, "
            f"omega h = {wh:.3g}")
    if bound is not None and step > bound:
        return (f"{what}: {method} is unstable beyond a step of {bound:.2g} s (omega h = {v.omega * bound:.3g}); use "
                f"a step <= {bound:.2g} s or an implicit method (--integrator bathe)")
    if wh > 2 * math.pi / STEPS_PER_PERIOD:
        return (f"{what}: fewer than {STEPS_PER_PERIOD:g} steps per period, the run cannot be accurate; use a step "
                f"<= {2 * math.pi / STEPS_PER_PERIOD / v.omega:.2g} s or integrator.tolerance")
    return None


def film_oscillator(problem: Problem, joint: str) -> tuple[float, float, float, str]:
    """(mass [kg], stiffness [N/m], damping [N s/m], body) of the oil film at `joint` where
    it is stiffest, at its hand-over threshold: the squeeze damping C = |F_n(A = 1)| / c and
    the wedge's radial stiffness |d F_n / d eps| / c with the journal turning at the fastest
    driver's speed (0 without drivers), against the lightest body at the joint."""
    spec, f = problem.joint(joint), problem.scene.effects.lubrication_of(problem.joint(joint))
    c, R = spec.radial_clearance, spec.journal_radius
    w = max((abs(d.speed) for d in problem.scene.graph.drivers), default=0.0)

    def radial(eps, A, B):
        return float(film_force(f.law, eps, A, B, R, f.length, f.viscosity, c)[0])
    damping = abs(radial(f.threshold, 1.0, 0.0)) / c
    d_eps = 1e-6
    stiffness = abs(radial(f.threshold + d_eps, 0.0, 0.5 * (f.threshold + d_eps) * w)
                    - radial(f.threshold - d_eps, 0.0, 0.5 * (f.threshold - d_eps) * w)) / (2 * d_eps * c)
    mass = {b.name: b.mass for b in problem.scene.graph.bodies}
    body = min((b for b in spec.bodies if b != GROUND), key=mass.__getitem__)
    return mass[body], stiffness, damping, body


def _film_line(problem: Problem, step: float, method: str) -> str | None:
    """One line when an explicit `method` at `step` [s] cannot follow the stiffest oil film
    (see the module docstring)."""
    films = lubricated_joints(problem.model, problem.scene.effects)
    if not films or problem.scene.integrator.tolerance is not None or method not in STABILITY_POLYNOMIALS:
        return None

    def bound(jf):
        m, k, c, body = film_oscillator(problem, jf[0])
        return largest_stable_step(method, oscillator_eigenvalues(m, k, c)), jf[0], m, k, c, body
    h_max, joint, m, k, c, body = min(map(bound, films))
    if step <= h_max:
        return None
    return (f"integrator.step: {step:g} s with {method}: the oil film at {joint} at eps = its threshold damps a "
            f"squeeze with {c:.3g} N s/m and stiffens with {k:.3g} N/m, against {body} of {m:g} kg: {method} "
            f"cannot follow the film where it is stiffest beyond a step of {h_max:.2g} s; use a step <= "
            f"{h_max:.2g} s or an implicit method (--integrator bathe)")


def foresight_lines(problem: Problem, step: float | None = None, method: str | None = None,
                    preload=None) -> list[str]:
    """The one-line warnings of `problem` run at `step` [s] with `method` (default the
    scene's): a contact law outside its range, a step that cannot resolve the stiffest
    contact vibration, an explicit step that cannot follow an oil film (see the module
    docstring). preload: the run's PreloadSolution, whose
    reactions are the planned loads (default: those of the minimum-norm efforts)."""
    sc = problem.scene
    c = sc.effects.contact
    lines = []
    if problem.clearance_joints and (law := law_outside_range(c.law, c.restitution, c.exponent)):
        lines.append(law)
    h, method = sc.integrator.step if step is None else step, method or sc.integrator.method
    return lines + [x for x in (_step_line(problem, h, method, preload), _film_line(problem, h, method)) if x]
