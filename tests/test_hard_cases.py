"""Hard cases (problems/hard/): each stays finite, keeps its energy audit within a stated bound
and converges under step refinement (successive differences shrink, or are already below 1 % of
the radial clearance: the contact-onset capture is first order, so nearly plastic impacts
need not shrink monotonically at these steps)."""

from pathlib import Path

import numpy as np
import pytest

import rrr4
from rrr4.preload.solve import PreloadWarning

HARD = Path(__file__).resolve().parents[1] / "problems" / "hard"
# scene -> (t_end [s], steps [s] coarse to fine, energy-audit bound at the finest step)
CASES = {
    "clearance_1um": (0.005, (2e-6, 1e-6, 5e-7), 0.05),
    "high_speed": (0.002, (2e-6, 1e-6, 5e-7), 0.05),
    "restitution_0": (0.005, (1e-5, 5e-6, 2.5e-6), 0.05),
    "restitution_1": (0.005, (1e-5, 5e-6, 2.5e-6), 0.05),
    "tiny_preload": (0.005, (1e-5, 5e-6, 2.5e-6), 0.05),
    "grazing": (0.05, (2e-5, 1e-5, 5e-6), 1e-3),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_hard_case_stays_finite_audits_energy_and_converges_under_refinement(name):
    scene = rrr4.load_scene(HARD / f"{name}.yaml")
    t_end, steps, audit_bound = CASES[name]
    pre = rrr4.solve_preload(scene) if scene.actuation.mode == "torque" else None
    sims = [rrr4.simulate(scene, "rk4", t_end=t_end, step=h, preload=pre) for h in steps]
    for s in sims:
        assert np.all(np.isfinite(s.q)) and np.all(np.isfinite(s.normal_force))
        assert np.all(s.normal_force >= 0)
    assert sims[-1].energy_audit_residual < audit_bound
    d1 = np.max(np.abs(sims[0].pose[:, :2] - sims[1].pose[:, :2]))
    d2 = np.max(np.abs(sims[1].pose[:, :2] - sims[2].pose[:, :2]))
    clearance = min(j.bearing_radius - j.journal_radius for j in scene.joints if j.clearance)
    assert d2 <= d1 or d2 < 1e-2 * clearance   # shrinking, or already below 1 % of the radial clearance


@pytest.mark.slow
def test_long_horizon_energy_audit_stays_bounded_over_10_s():
    scene = rrr4.load_scene(HARD / "long_horizon.yaml")
    s = rrr4.simulate(scene, "rk4", step=1e-5, preload=rrr4.solve_preload(scene), jit=True)
    assert np.all(np.isfinite(s.q))
    assert s.energy_audit_residual < 0.05


def test_near_singular_path_stays_finite_audits_energy_and_converges():
    """Chain 3 nearly stretched at t = 0.5 s (transmission 0.108, condition number 74): compiled RK4
    through the near-singular pose; successive pose differences at t = 0.55 s shrink with the step."""
    scene = rrr4.load_scene(HARD / "near_singular.yaml")
    with pytest.warns(PreloadWarning):  # f_min cannot be held near the stretched pose: reported, not hidden
        pre = rrr4.solve_preload(scene)
    bad = pre.t[~pre.feasible]
    assert bad.size and np.all(np.abs(bad - 0.5) < 0.2)  # only around the near-singular pose
    sims = [rrr4.simulate(scene, "rk4", t_end=0.55, step=h, preload=pre, jit=True) for h in (2e-5, 1e-5, 5e-6)]
    for s in sims:
        assert np.all(np.isfinite(s.q)) and np.all(s.normal_force >= 0)
    assert sims[-1].energy_audit_residual < 1e-3
    d1, d2 = (np.max(np.abs(a.pose[-1] - b.pose[-1])) for a, b in zip(sims[:-1], sims[1:], strict=True))
    assert d2 < d1 / 4, (d1, d2)


@pytest.mark.parametrize("name", sorted(CASES) + ["near_singular"])
def test_hard_case_stays_finite_under_the_default_implicit_path(name):
    """Bathe with the simplified Newton (the reference scene's default) at 1e-4 s, ten times the
    hard cases' own step: stiff impacts, plastic and elastic contact, a 1 um clearance, a grazing
    path and a near-singular pose keep every state finite and every normal force >= 0."""
    import warnings
    scene = rrr4.load_scene(HARD / f"{name}.yaml")
    t_end = CASES[name][0] if name in CASES else 0.55
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PreloadWarning)
        s = rrr4.simulate(scene, "bathe", t_end=t_end, step=1e-4)
    assert s.stats["newton"] == "simplified"
    assert np.all(np.isfinite(s.q)) and np.all(np.isfinite(s.qd)) and np.all(np.isfinite(s.normal_force))
    assert np.all(s.normal_force >= 0)
