"""Every run judges its own accuracy (rrr4.simulation.verdict), and says before it starts what
it cannot resolve (rrr4.simulation.foresight, rrr4.contact.validity).

References the verdict does not compute itself: hand-made energy balances; every committed
summary (each converged); the effective restitution of one impact integrated by a plain
fixed-step loop in physical units; the contact stiffness as a finite difference of the law's
elastic force. The hard variants of the reference scene and their verdicts are in
tests/test_hard_cases.py."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from rrr4.cli import main
from rrr4.contact import elastic_force, hysteresis_factor
from rrr4.contact.validity import RESTITUTION_MISS, effective_restitution, law_outside_range
from rrr4.problem import Problem
from rrr4.results.summary import target_checks, verdict_line
from rrr4.results.tables import report_markdown
from rrr4.scene.vocabulary import CONTACT_LAW_KEYS
from rrr4.simulation import AUDIT_TOLERANCE, energy_verdict
from rrr4.simulation.foresight import foresight_lines, stiffest_vibration

ROOT = Path(__file__).resolve().parents[1]


def _energy(kinetic, work_in, dissipated):
    k, w, d = (np.asarray(v, float) for v in (kinetic, work_in, dissipated))
    return {"kinetic": k, "potential": 0 * k, "total": k, "work_in": w, "dissipated": d}


def test_verdict_passes_a_balanced_run_and_flags_an_imbalance_above_one_percent_of_the_energy_exchanged():
    # 2 J put in: 1.5 J stored, 0.5 J dissipated; then the same with 1.5 % and 0.5 % of 2 J missing
    balanced = energy_verdict(_energy([0, 1.0, 1.5], [0, 1.2, 2.0], [0, 0.2, 0.5]))
    assert balanced.converged and balanced.residual == pytest.approx(0.0, abs=1e-15)
    assert balanced.energy_exchanged_J == pytest.approx(2.0)
    off = energy_verdict(_energy([0, 1.0, 1.47], [0, 1.2, 2.0], [0, 0.2, 0.5]))
    assert not off.converged and off.imbalance_J == pytest.approx(0.03) and off.residual == pytest.approx(0.015)
    assert energy_verdict(_energy([0, 1.0, 1.49], [0, 1.2, 2.0], [0, 0.2, 0.5])).converged
    assert not energy_verdict(_energy([0, 1.0, np.nan], [0, 1.2, 2.0], [0, 0.2, 0.5])).converged
    assert energy_verdict(_energy([0, 0, 0], [0, 0, 0], [0, 0, 0])).converged  # nothing exchanged, nothing wrong
    assert "not converged (energy audit residual 0.015 > 0.01)" == off.text()


def _summaries():
    return sorted(ROOT.glob("results/**/summary.json"))


def _arms(summary: dict):
    """(name, metrics) of every simulated arm in a study summary (an optimization's replay included)."""
    for k, v in summary.items():
        if isinstance(v, dict) and "energy_audit_residual" in v:
            yield k, v
        elif isinstance(v, dict):
            yield from ((f"{k}.{a}", m) for a, m in _arms(v))


def test_every_committed_result_would_pass_the_verdict():
    """The threshold against the shipped scenes: each committed arm's residual is within it, with
    a margin of 2 (the largest, the reference scene's point-to-point replay without preload, 184
    contact losses in 0.12 s: 4.7e-3; the time-optimal replay without preload 2.9e-3)."""
    arms = [(f.parent.name, a, m["energy_audit_residual"]) for f in _summaries()
            for a, m in _arms(json.loads(f.read_text()))]
    assert len(arms) >= 30
    worst = max(arms, key=lambda r: r[2])
    assert worst[2] <= AUDIT_TOLERANCE / 2, worst  # with a margin of 2 below the tolerance
    for _, _, r in arms:
        assert energy_verdict(_energy([0, 1.0], [0, 1.0 + r], [0, 0])).converged


def test_every_committed_driven_result_passes_the_step_halving_check():
    """Flores's slider-crank, dry and lubricated: the half-step rerun within 1 % of the 0.5 mm
    clearance over the first millisecond (6.3e-8 m and 3.7e-10 m against 5e-6 m)."""
    from rrr4.simulation import halving_check
    driven = [json.loads(f.read_text()) for f in _summaries()]
    driven = [s for s in driven if s.get("step_convergence")]
    assert len(driven) >= 2
    for s in driven:
        d = s["step_convergence"]["trajectory_difference_m"]["first_1_ms"]
        assert halving_check(d, 1e-3, 5e-4)["passes"] and d < 5e-6 / 50


def _summary(converged_without: bool) -> dict:
    s = json.loads((ROOT / "results" / "paper_circle" / "summary.json").read_text())
    for arm in ("with_preload", "with_preload_compensated", "without_preload"):
        s[arm].update(converged=True, energy_audit_tolerance=AUDIT_TOLERANCE)
    s["without_preload"].update(converged=converged_without, energy_audit_residual=1.23)
    s["targets"] = target_checks(s)
    return s


def test_no_target_is_claimed_on_an_unconverged_arm_and_the_report_and_one_line_say_so():
    good = _summary(True)
    assert good["targets"]["rms_error_at_most_half"] and "not_claimed" not in good["targets"]
    assert verdict_line(good) is None and "not converged" not in report_markdown(good)
    bad = _summary(False)
    tg = bad["targets"]
    assert "rms_error_ratio_with_to_without" not in tg and "zero_losses_with_preload" not in tg
    assert "without_preload" in tg["not_claimed"] and tg["zero_losses_compensated"]  # the compensated arm stands
    line = verdict_line(bad)
    assert "\n" not in line and "without_preload (energy audit residual 1.23 > 0.01)" in line
    assert "--step 2.5e-05" in line and "integrator.tolerance" in line
    report = report_markdown(bad)
    assert "**not converged**" in report and "Targets: **not claimed**" in report
    assert "RMS error with/without" not in report


def test_compare_treats_a_changed_verdict_as_a_difference_at_any_tolerance(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    for d, ok in ((a, True), (b, False)):
        d.mkdir()
        s = json.loads((ROOT / "results" / "paper_circle" / "summary.json").read_text())
        s["with_preload"]["converged"] = True
        s["without_preload"]["converged"] = ok
        s["with_preload"]["platform_error_rms_m"] *= 1.0 if ok else 1.5
        (d / "summary.json").write_text(json.dumps(s))
    assert main(["compare", str(a), str(b), "--rtol", "1"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert "1 differ" in out[0] and out[1].strip() == "without_preload.converged: True | False  (the verdict changed)"
    shutil.copy(a / "summary.json", b / "summary.json")
    assert main(["compare", str(a), str(b)]) == 0


def _impact(law: str, c_r: float, n: float = 1.5, m: float = 0.3, K: float = 7.7e10, v0: float = 0.5) -> float:
    """Restitution of one impact of a mass m [kg] at v0 [m/s] on the law, by classic RK4 in
    physical units with a step of 1/2000 of the Hertz contact time."""
    chi = hysteresis_factor(law, c_r)
    t_hertz = 3.2145 * (m * m / (K * K * v0)) ** (1 / 5) * (n + 1) / 2.5  # Hertz's contact duration, about
    h = t_hertz / 2000

    def acc(x, v):
        return -max(K * max(x, 0.0) ** n * (1 + chi * v / v0), 0.0) / m
    x, v = 0.0, v0
    for _ in range(200000):
        k1 = (v, acc(x, v))
        k2 = (v + h / 2 * k1[1], acc(x + h / 2 * k1[0], v + h / 2 * k1[1]))
        k3 = (v + h / 2 * k2[1], acc(x + h / 2 * k2[0], v + h / 2 * k2[1]))
        k4 = (v + h * k3[1], acc(x + h * k3[0], v + h * k3[1]))
        x, v = x + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]), v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        if x < 0:
            return -v / v0
    raise AssertionError("no separation")


@pytest.mark.parametrize("law,c_r", [("lankarani-nikravesh", 0.05), ("lankarani-nikravesh", 0.9),
                                     ("hunt-crossley", 0.3), ("flores", 0.05), ("gonthier", 0.5)])
def test_effective_restitution_matches_one_impact_in_physical_units(law, c_r):
    assert effective_restitution(law, c_r, 1.5) == pytest.approx(_impact(law, c_r), abs=2e-3)


def test_laws_derived_for_restitution_near_one_are_flagged_below_it_and_the_others_never():
    hyst = [law for law, keys in CONTACT_LAW_KEYS.items() if "restitution" in keys]
    for c_r in (0.05, 0.2, 0.5, 0.8, 0.9, 0.95):
        for law in hyst:
            line = law_outside_range(law, c_r, 1.5)
            missed = abs(effective_restitution(law, c_r, 1.5) - c_r) > RESTITUTION_MISS
            assert (line is not None) == missed
            if law in ("flores", "gonthier"):
                assert line is None, line
    line = law_outside_range("lankarani-nikravesh", 0.05, 1.5)
    assert line.startswith("effects.contact.law: lankarani-nikravesh at restitution 0.05 is outside its range")
    assert "use law gonthier" in line and "\n" not in line
    assert law_outside_range("lankarani-nikravesh", 0.9, 1.5) is None  # the reference scene's
    assert law_outside_range("hunt-crossley", 0.1, 1.5) is not None
    assert law_outside_range("hertz", 0.1, 1.5) is None


def test_stiffest_vibration_is_the_law_linearised_at_the_planned_load(paper_scene):
    problem = Problem.from_scene(paper_scene)
    v = stiffest_vibration(problem)
    K, n = problem.joint_stiffness(v.joint), paper_scene.effects.contact.exponent
    delta = (v.load / K) ** (1 / n)
    eps = 1e-3 * delta
    k_fd = float(elastic_force(delta + eps, K, n) - elastic_force(delta - eps, K, n)) / (2 * eps)
    assert v.stiffness == pytest.approx(k_fd, rel=1e-5)
    assert v.mass == pytest.approx(0.30) and v.body.startswith("following")  # the lightest body at a clearance joint
    assert v.omega == pytest.approx(math.sqrt(k_fd / 0.30), rel=1e-5)
    assert foresight_lines(problem) == []  # the reference scene resolves its contact at its own step
    line, = foresight_lines(problem, step=8 / v.omega)
    assert "fewer than 2 steps per period" in line and f"{math.pi / v.omega:.2g} s" in line
    line, = foresight_lines(problem, step=3 / v.omega, method="rk4")
    assert "rk4 is unstable beyond a step of" in line and "implicit method" in line


def test_an_explicit_step_too_coarse_for_the_oil_film_is_said_before_the_run_and_flagged_after_it():
    """Flores's lubricated slider-crank: RK4 at its own 1e-6 s follows the film (nothing said; its
    committed result converged, residual 5.6e-9); at 1e-5 s the film's squeeze rate times the step
    (9.6) is beyond RK4's bound (2.785): said before the run, and the run over 0.1 s is flagged
    (measured residual 2.5e-2)."""
    import rrr4
    scene = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank_lubricated.yaml")
    problem = Problem.from_scene(scene)
    assert foresight_lines(problem) == []
    line, = foresight_lines(problem, step=1e-5)
    assert "oil film at B" in line and "rk4 cannot follow the film" in line and "use a step <= 2.9e-06 s" in line
    assert not rrr4.simulate(scene, "rk4", t_end=0.1, step=1e-5).verdict.converged


def test_a_sweep_row_carries_its_arms_verdict():
    """run_case (a sweep's case, in the worker): every row ends with `converged`, the arm's
    verdict; the slider-crank at its own step over 2 ms converges, its ideal twin too."""
    from rrr4.studies.sweeps import DRIVEN_METRICS, METRICS, case_scene, parse_spec, run_case
    assert METRICS[-1] == DRIVEN_METRICS[-1] == "converged"
    spec = parse_spec({"scene": str(ROOT / "problems" / "flores_slider_crank.yaml"), "t_end": 0.002,
                       "grid": {"mechanism.joints[2].clearance.radial_clearance": [5.0e-4]}})
    rows, _, _ = run_case(case_scene(spec.scene, spec.cases[0])[1], "flores_slider_crank",
                          spec.t_end, spec.arms)
    assert [r["converged"] for r in rows] == [True, True]


def test_a_bad_convergence_budget_is_one_line_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", str(ROOT / "problems" / "paper_circle.yaml"), "--converge", "-1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["rrr4: error: SceneError: --converge: -1.0 is not allowed (must be a finite number > 0)"]
    assert not out.exists()


def test_where_the_energy_audit_is_not_decisive_the_half_step_rerun_decides():
    """Flores's slider-crank at 2e-5 s (20x its step) over 4 ms: its energy balances (residual
    1.9e-3) but its half-step rerun moves the bodies by 0.1 mm, a fifth of the clearance, in the
    first millisecond: not converged, and the one line says why."""
    import rrr4
    from rrr4.results.summary import study_summary
    from rrr4.studies.study import run_study
    s = study_summary(run_study(rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml"), t_end=0.004,
                                step=2e-5))
    arm = s["with_clearance"]
    assert arm["energy_audit_residual"] < AUDIT_TOLERANCE and not arm["step_halving"]["passes"]
    assert arm["step_halving"]["difference_m"] > 10 * arm["step_halving"]["tolerance_m"]
    assert not arm["converged"] and s["ideal"]["converged"]
    assert "with_clearance (at half the step it moves by" in verdict_line(s)


def test_rrr4_check_says_what_a_run_cannot_resolve_in_one_line_each_and_keeps_its_exit_status(capsys):
    hard = ROOT / "problems" / "hard"
    assert main(["check", str(hard / "low_restitution_ln.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert sum(line.startswith("effects.contact.law: lankarani-nikravesh at restitution 0.05") for line in out) == 1
    assert main(["check", str(hard / "light_links.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    line, = [x for x in out if x.startswith("integrator.step: 0.0001 s with bathe")]
    assert "against driving_1 of 0.004 kg" in line and "use a step <= 2.4e-05 s" in line
    assert main(["check", str(ROOT / "problems" / "paper_circle.yaml")]) == 0
    assert not [x for x in capsys.readouterr().out.splitlines()
                if x.startswith(("integrator.step:", "effects.contact.law:"))]
