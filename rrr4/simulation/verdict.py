"""Whether a simulation can be trusted: the verdict of its energy audit.

Every simulation already keeps its energy balance (:mod:`rrr4.dynamics.energy`): along an
exact solution the actuator work W_in equals the change of the stored energy E (kinetic and
contact potential) plus the dissipation D, so the largest imbalance
max_t |W_in - (E - E(0)) - D| [J] is integration error. Its tolerance is scaled to the energy
the run exchanges, E_x [J], the largest of |T|, |V|, |E|, |W_in| and D over the run: the
run has converged when

    max_t |W_in - (E - E(0)) - D| <= AUDIT_TOLERANCE * E_x,

i.e. when its energy audit residual (the ratio) is at most :data:`AUDIT_TOLERANCE` = 1e-2.
Nothing is recomputed: the verdict reads the energy terms the run wrote anyway.

The threshold sits between what the shipped scenes reach and what a run that is wrong
reaches (docs/checks.md, "Is a run converged?"): every committed result has a residual at most
2.9e-3 (the time-optimal replay without preload; the reference scene 1e-5 to 8e-5 over 1 s,
4.8e-3 over its first 0.1 s), while the hard variants whose numbers move by more than their
size when the step is refined reach 1.7e-2 (4 g driving links) to 1.2 (the same without
preload), and a law used outside its range (Lankarani-Nikravesh at c_r = 0.05) 0.14 to 0.2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..dynamics.energy import energy_audit

__all__ = ["Verdict", "energy_verdict", "remedy", "AUDIT_TOLERANCE", "REMEDY"]

AUDIT_TOLERANCE = 1e-2  # largest energy imbalance allowed, as a share of the energy the run exchanges

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
