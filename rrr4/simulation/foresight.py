"""What a run can resolve, said before it starts (``rrr4 check``, ``rrr4 run``).

Two one-line warnings, each naming what to use instead:

- a contact law outside the range it was derived for (:func:`rrr4.contact.validity.law_outside_range`:
  Lankarani-Nikravesh or Hunt-Crossley at low restitution);
- a step too coarse for the stiffest vibration of the contact. A journal pressed into its
  bearing by the load F is a spring of stiffness k = dF/d(delta) = n K^(1/n) F^(1 - 1/n)
  (the contact law's elastic part K delta^n at the penetration that carries F). Against the
  lightest body at a clearance joint, m, it vibrates at omega = sqrt(k / m). The load is
  the largest planned reaction of a clearance joint along the path (the ideal inverse
  dynamics, with the preload where the controller preloads). A fixed step h takes
  2 pi / (omega h) steps per period of that vibration: with fewer than
  :data:`STEPS_PER_PERIOD` it cannot represent it (an implicit method damps it away
  numerically, and the energy audit then flags the run), and an explicit method is
  unstable beyond omega h = :data:`EXPLICIT_STABILITY` (RK4: 2 sqrt 2, its stability
  bound on the imaginary axis).

- an oil film whose squeeze damping an explicit step cannot follow. At the eccentricity where
  the film hands over to the dry laws (``threshold``, where it is stiffest) the film resists
  a squeeze of the journal with C = |F_n(A = 1)| / c [N s/m] (:func:`rrr4.contact.film_force`,
  A = eps_dot); against the lightest body at the joint its rate C / m [1/s] times h beyond
  RK4's stability bound on the negative real axis (2.785) leaves RK4 unable to follow the film
  where it is stiffest (unstable there; the energy audit flags the run).

A scene without a task body (the drivers set the motion) has no planned load: its step is
judged after the run, by the energy audit (:mod:`.verdict`) and the half-step rerun of its
study. Adaptive methods and error-controlled steps choose their own step and are not judged
here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..contact import film_force
from ..contact.validity import law_outside_range
from ..dynamics.builder import lubricated_joints
from ..integrators import METHODS, FixedStepIntegrator
from ..problem import Problem
from ..scene import GROUND
from ..trajectory import sample_path

__all__ = ["foresight_lines", "stiffest_vibration", "Vibration", "STEPS_PER_PERIOD", "EXPLICIT_STABILITY"]

STEPS_PER_PERIOD = 2.0                        # fewer fixed steps per period cannot represent a vibration
EXPLICIT_STABILITY = {"rk4": 2 * math.sqrt(2)}  # omega h beyond which an explicit method is unstable
EXPLICIT_DAMPING = {"rk4": 2.785}  # lambda h on the negative real axis beyond which it is unstable


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


def _largest_load(problem: Problem, preload=None) -> float | None:
    """The largest planned reaction [N] of any clearance joint along the path: the preload's
    reactions when given, else those of the minimum-norm efforts; None without a task body."""
    if problem.model.task is None:
        return None
    if preload is not None:
        names, r = list(preload.joint_names), np.asarray(preload.reactions)
    else:
        s = sample_path(problem.path)
        names, r = list(problem.model.passive_joints), problem.effort_family(s.pose, s.pose_d, s.pose_dd).r_p
    cols = [names.index(j) for j in problem.clearance_joints if j in names]
    return float(np.max(np.linalg.norm(r[:, cols], axis=-1))) if cols and r.size else None


def stiffest_vibration(problem: Problem, preload=None) -> Vibration | None:
    """The stiffest contact vibration of `problem` (see the module docstring); None without
    clearance joints, without a task body or with a law that has no elastic part to speak of."""
    joints = problem.clearance_joints
    load = _largest_load(problem, preload) if joints else None
    if not load or load <= 0:
        return None
    n = problem.scene.effects.contact.exponent
    joint = max(joints, key=problem.joint_stiffness)
    K = problem.joint_stiffness(joint)
    k = n * K ** (1.0 / n) * load ** (1.0 - 1.0 / n)
    mass = {b.name: b.mass for b in problem.scene.graph.bodies}
    body = min((b for j in joints for b in problem.joint(j).bodies if b != GROUND), key=mass.__getitem__)
    return Vibration(math.sqrt(k / mass[body]), k, load, joint, body, mass[body])


def _step_line(problem: Problem, step: float, method: str, preload=None) -> str | None:
    """One line when a fixed `step` [s] of `method` cannot resolve the stiffest contact vibration."""
    cls = METHODS.get(method)
    if cls is None or not issubclass(cls, FixedStepIntegrator) or problem.scene.integrator.tolerance is not None:
        return None
    v = stiffest_vibration(problem, preload)
    if v is None:
        return None
    wh = v.omega * step
    bound = EXPLICIT_STABILITY.get(method)
    what = (f"integrator.step: {step:g} s with {method}: the stiffest contact vibration (K = "
            f"{problem.joint_stiffness(v.joint):.3g} at {v.joint} under {v.load:.3g} N, k = {v.stiffness:.3g} N/m, "
            f"against {v.body} of {v.mass:g} kg) has omega = {v.omega:.3g} rad/s, omega h = {wh:.3g}")
    if bound is not None and wh > bound:
        return f"{what}: {method} is unstable beyond {bound:.3g}; use a step <= {bound / v.omega:.2g} s"
    if wh > 2 * math.pi / STEPS_PER_PERIOD:
        return (f"{what}: fewer than {STEPS_PER_PERIOD:g} steps per period, the run cannot be accurate; use a step "
                f"<= {2 * math.pi / STEPS_PER_PERIOD / v.omega:.2g} s or integrator.tolerance")
    return None


def _film_line(problem: Problem, step: float, method: str) -> str | None:
    """One line when an explicit `method` at `step` [s] cannot follow the stiffest oil film's
    squeeze damping (see the module docstring)."""
    bound = EXPLICIT_DAMPING.get(method)
    films = lubricated_joints(problem.model, problem.scene.effects) if bound is not None else ()
    if not films or problem.scene.integrator.tolerance is not None:
        return None
    mass = {b.name: b.mass for b in problem.scene.graph.bodies}

    def rate(jf):
        j, f = jf
        spec = problem.joint(j)
        c = spec.radial_clearance
        damping = abs(float(film_force(f.law, f.threshold, 1.0, 0.0, spec.journal_radius, f.length, f.viscosity,
                                       c)[0])) / c
        body = min((b for b in spec.bodies if b != GROUND), key=mass.__getitem__)
        return damping / mass[body], damping, j, body
    lam, damping, joint, body = max(map(rate, films))
    if lam * step <= bound:
        return None
    return (f"integrator.step: {step:g} s with {method}: the oil film at {joint} damps a squeeze with {damping:.3g} "
            f"N s/m at eps = its threshold, against {body} of {mass[body]:g} kg a rate of {lam:.3g} 1/s, lambda h = "
            f"{lam * step:.3g}: beyond {bound:g} {method} cannot follow the film where it is stiffest; use a step "
            f"<= {bound / lam:.2g} s or an implicit method (--integrator bathe)")


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
