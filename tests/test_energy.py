"""Energy bookkeeping: the conservative scene keeps its energy, the audit closes with dissipation."""

import numpy as np
import pytest

from rrr4 import load_scene, simulate

from .conftest import ROOT

CONSERVATIVE = ROOT / "problems" / "conservative_free.yaml"


def _drift(step):
    r = simulate(load_scene(CONSERVATIVE), step=step)
    e = r.energy["total"]
    return r, float(np.max(np.abs(e - e[0])) / e[0])


def test_energy_is_conserved_without_dissipation_and_drift_shrinks_under_refinement():
    """Bound: max |E(t) - E(0)| / E(0) < 1e-8 over 20 ms at a 1 us RK4 step, with >= 8
    contact periods; halving the step cuts the drift at least 4-fold (measured: 2.5e-9 at
    2 us, 2.7e-10 at 1 us)."""
    coarse, d_coarse = _drift(2e-6)
    fine, d_fine = _drift(1e-6)
    assert fine.penetration.max() > 0 and sum(fine.contact_loss_events.values()) >= 8
    assert fine.energy["potential"].max() > 1e-5 * fine.energy["total"][0]   # contact energy was stored
    assert d_fine < 1e-8
    assert d_fine < d_coarse / 4
    assert np.all(fine.energy["work_in"] == 0) and np.all(fine.energy["dissipated"] == 0)


def test_energy_audit_closes_with_dissipation_on_the_reference_scene(paper_scene):
    r = simulate(paper_scene, integrator="rk4", step=1e-5, t_end=0.05)
    e = r.energy
    assert e["dissipated_damping"][-1] > 0 and e["dissipated_friction"][-1] > 0
    assert np.all(np.diff(e["dissipated"]) >= 0)
    assert np.max(np.abs(e["work_in"])) > e["dissipated"][-1]
    assert r.energy_audit_residual < 1e-4
    assert set(r.contact_loss_events) == {"B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4"}


def test_energy_audit_detects_an_imbalance():
    from rrr4.dynamics.energy import energy_audit_residual
    zeros = np.zeros(3)
    energy = {"kinetic": np.array([1.0, 1.0, 1.0]), "potential": zeros, "total": np.array([1.0, 1.0, 1.0]),
              "work_in": np.array([0.0, 0.1, 0.2]), "dissipated": zeros}
    assert energy_audit_residual(energy) == pytest.approx(0.2)


def test_held_and_interpolated_references_inject_no_energy(paper_scene):
    """Without dissipation (restitution 1, no friction) the actuators' work is the only energy
    that enters. With the default path's held torques (references interpolated once per
    control period) and with references interpolated inside the right-hand side, the audit
    closes to the integrator's error and that error falls with the step (measured: 4.4e-7 at
    1e-5 s, 1.4e-8 at 5e-6 s; interpolated in the RHS 8.1e-8 at 1e-5 s)."""
    from dataclasses import replace
    effects = replace(paper_scene.effects, contact=replace(paper_scene.effects.contact, restitution=1.0),
                      friction=replace(paper_scene.effects.friction, law="none"))
    held = replace(paper_scene, effects=effects)
    coarse, fine = (simulate(held, integrator="rk4", step=h, t_end=0.05) for h in (1e-5, 5e-6))
    inside = simulate(replace(held, actuation=replace(held.actuation, control_rate=None)), integrator="rk4",
                      step=1e-5, t_end=0.05, references="sampled")
    assert coarse.stats["references"] == "held" and inside.stats["references"] == "sampled"
    for r in (coarse, fine, inside):
        assert np.all(r.energy["dissipated"] == 0) and np.max(np.abs(r.energy["work_in"])) > 1e-5
        assert r.energy_audit_residual < 1e-6
    assert fine.energy_audit_residual < coarse.energy_audit_residual / 8
