"""Whether a simulation can be trusted: the verdict of its energy audit.

Every simulation already keeps its energy balance (:mod:`rrr4.dynamics.energy`): along an
exact solution the actuator work W_in equals the change of the stored energy E (kinetic and
contact potential) plus the dissipation D, so the largest imbalance
max_t |W_in - (E - E(0)) - D| [J] is integration error. Its tolerance is scaled to the energy
the run exchanges, E_x [J], the largest of |T|, |V|, |E|, |W_in| and D over the run: the
run has converged when

    max_t |W_in - (E - E(0)) - D| <= AUDIT_TOLERANCE * E_x,

i.e. when its energy audit residual (the ratio) is at most :data:`AUDIT_TOLERANCE` = 1e-2.
Nothing is recomputed: the verdict reads the energy terms the run wrote anyway. Where the
audit is not decisive, :func:`halving_check` judges a run against its half-step rerun (a
driven scene's study, which reruns its clearance arm anyway).

The threshold sits between what the shipped scenes reach and what a run that is wrong
reaches (docs/checks.md, "Is a run converged?"): every committed result has a residual at most
2.9e-3 (the time-optimal replay without preload; the reference scene 1e-5 to 8e-5 over 1 s,
4.8e-3 over its first 0.1 s), while the hard variants that a smaller step shows to be wrong
(4 g driving links: the platform 26 % off its converged error) reach 1.7e-2 (4 g driving links) to 1.2 (the same without
preload), and the first impacts from centred journals of Lankarani-Nikravesh at c_r = 0.05
0.14 to 0.2; each converges at a smaller step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..dynamics.energy import energy_audit

__all__ = ["Verdict", "energy_verdict", "remedy", "halving_check", "AUDIT_TOLERANCE", "REMEDY", "HALVING_WINDOW",
           "HALVING_TOLERANCE"]

AUDIT_TOLERANCE = 1e-2  # largest energy imbalance allowed, as a share of the energy the run exchanges

# Where the energy audit is not decisive (an error that conserves energy, e.g. a shifted impact), a
# rerun at half the step decides: a driven scene's clearance arm (its study reruns it anyway) has
# converged only if no body's centre of mass moves by more than HALVING_TOLERANCE of the smallest
# radial clearance between the two runs over the first HALVING_WINDOW [s] (later a rattling
# journal's impacts amplify any difference: the motion is chaotic). Flores's slider-crank at its
# 1e-6 s: 6.3e-8 m over the first 1 ms, 80x inside 1 % of its 0.5 mm; at 2e-5 s: 1.0e-4 m.
HALVING_WINDOW = 1e-3
HALVING_TOLERANCE = 1e-2

# what would converge an unconverged run, in the words of the command line and the scene
REMEDY = ("a smaller step (--step {smaller:g}), the error-controlled step (integrator.tolerance: 1e-8 in the "
          "scene, --integrator bathe) or a contact law inside its range (rrr4 check says)")


@dataclass(frozen=True)
class Verdict:
    """The energy audit's verdict on one simulation: converged when the largest imbalance
    [J] is at most `tolerance` times the energy the run exchanges [J]."""
    converged: bool
    residual: float
    tolerance: float
    imbalance_J: float
    energy_exchanged_J: float

    def as_dict(self) -> dict:
        """The numbers behind the verdict, JSON-ready (units in the keys)."""
        return {"converged": self.converged, "energy_audit_residual": self.residual, "tolerance": self.tolerance,
                "energy_imbalance_J": self.imbalance_J, "energy_exchanged_J": self.energy_exchanged_J}

    def text(self) -> str:
        """'converged' or 'not converged', with the residual against its tolerance."""
        word, sign = ("converged", "<=") if self.converged else ("not converged", ">")
        return f"{word} (energy audit residual {self.residual:.3g} {sign} {self.tolerance:g})"


def energy_verdict(energy: dict, tolerance: float = AUDIT_TOLERANCE) -> Verdict:
    """The verdict of a run's energy terms (dict of (N,) arrays [J], :attr:`rrr4.Simulation.energy`).
    A run with a non-finite term has not converged; one that exchanges no energy has."""
    imbalance, scale = energy_audit(energy)
    residual = imbalance / scale if scale > 0 else (0.0 if math.isfinite(imbalance) else math.inf)
    ok = math.isfinite(residual) and math.isfinite(scale) and residual <= tolerance
    return Verdict(bool(ok), float(residual), float(tolerance), float(imbalance), float(scale))


def remedy(step: float) -> str:
    """What would converge a run at `step` [s] (:data:`REMEDY`)."""
    return REMEDY.format(smaller=step / 4)


def halving_check(difference: float, window: float, clearance: float) -> dict:
    """The step-halving check (:data:`HALVING_TOLERANCE`): `difference` [m], the largest
    centre-of-mass distance between a run and its half-step rerun over its first `window` [s];
    `clearance` [m], the smallest radial clearance. JSON-ready, with ``passes``."""
    tol = HALVING_TOLERANCE * clearance
    return {"window_s": float(window), "difference_m": float(difference), "tolerance_m": float(tol),
            "passes": bool(math.isfinite(difference) and difference <= tol)}
