"""rrr4 wear from the periodic steady state: a run continued from another's end, the start
transient run once and reported apart, the peak pressure of the steady cycle, a jump that
keeps each journal in its seat, and a clear value where nothing wore (issue 43, section 3)."""

import dataclasses
import math

import numpy as np
import pytest

import rrr4
from rrr4 import SceneError
from rrr4.contact.wear import depth_at
from rrr4.results.figures.wear import _magnification
from rrr4.results.wear import PERIODIC, jump_line, wear_summary, write_wear
from rrr4.studies.wear import JUMP_TOLERANCE, jump_cycles, periodicity, suggested_max_change, wear_study
from tests.conftest import ROOT

# Archard's check scene (docs/wear.md) at a step of 1e-5 s: 5 times its own, still 10 steps per period of
# its stiffest contact vibration and inside RK4's stable step (rrr4.simulation.foresight)
JOURNAL = rrr4.load_scene(ROOT / "problems" / "wear_journal.yaml").with_values({"integrator.step": 1e-5})
W = (2.0 + 0.5e-3) * 9.81              # the sleeve's weight and half the link's [N]
C0 = 1.0e-4                            # radial clearance [m]
T = 0.1                                # one revolution of the shaft at 600 rpm [s]


@pytest.fixture(scope="module")
def first_cycle():
    return rrr4.simulate(JOURNAL, t_end=T)


def test_a_run_continued_from_another_starts_at_its_end_and_the_cycle_is_periodic(first_cycle):
    """The shaft turned once: the continued run starts at the first's end with the shaft's
    angle 2 pi back (its driver starts again at its initial value); everything else, and the
    contact memory, as the first ended. Under a constant load the cycle is then periodic:
    it ends where it started."""
    a = first_cycle
    b = rrr4.simulate(JOURNAL, t_end=T, start=a)
    shift = np.zeros_like(a.q[-1])
    shift[2] = 2 * math.pi  # the shaft, the first body
    assert np.allclose(b.q[0], a.q[-1] - shift, rtol=0, atol=1e-12)
    assert np.allclose(b.qd[0], a.qd[-1], rtol=0, atol=1e-12)
    assert b.stats["end_contact"]["in_contact"][0] == a.stats["end_contact"]["in_contact"][0] == 1.0
    assert periodicity(b) < 1e-6  # [radial clearances]
    assert np.linalg.norm(b.q[-1] - shift - b.q[0]) < 1e-9 and np.linalg.norm(b.qd[-1] - b.qd[0]) < 1e-6
    assert b.extremes["normal_force_max"][0] == pytest.approx(W, rel=2e-3)  # no start impact


def test_a_deeper_profile_keeps_the_continued_journal_in_its_seat(first_cycle):
    """A cycle jump deepens the bore where the journal sits: the continued run moves the
    journal by that depth along its eccentricity, so it starts as deep in its bore as the last
    run ended (no drop onto the bore, no impact): its force stays the static load."""
    a = first_cycle
    e = a.eccentricity[-1, 0]
    # a groove as steady wear makes it: depth d cos(psi - 90 deg) over the half the shaft presses
    # (the bore's surface there moved rigidly by d: a uniform sink, DESIGN.md section 12)
    psi = 2 * np.pi * np.arange(36) / 36
    groove = 2e-6 * np.maximum(np.cos(psi - np.pi / 2), 0.0)
    b = rrr4.simulate(JOURNAL, t_end=0.02, start=a, wear={"S": {"bearing": groove, "journal": np.zeros(36)}})
    deeper = float(depth_at(groove, math.atan2(e[1], e[0]) - a.q[-1, 5]))  # in the sleeve's frame
    assert deeper > 1e-6
    assert np.linalg.norm(b.eccentricity[0, 0]) == pytest.approx(np.linalg.norm(e) + deeper, rel=1e-6)
    assert b.penetration[0, 0] == pytest.approx(a.penetration[-1, 0], rel=1e-2)
    assert b.extremes["normal_force_max"][0] == pytest.approx(W, rel=5e-3)


def test_a_start_that_is_not_a_run_is_refused_in_one_line():
    with pytest.raises(SceneError, match=r"^start: .* is not allowed \(a Simulation of a scene of the same"):
        rrr4.simulate(JOURNAL, t_end=T, start="last run")


@pytest.fixture(scope="module")
def dropped():
    """The sleeve starts centred: it drops through the clearance onto the shaft (a start
    impact), then rests on it under its weight; the shaft at 3000 rpm (cycles of 20 ms)."""
    scene = JOURNAL.with_values({"initial.journals": "centred", "mechanism.drivers[0].speed_rpm": 3000.0})
    return wear_study(scene, 1000, check=False)


def test_the_start_transient_is_run_once_and_reported_apart_from_the_steady_peak(dropped):
    summary = wear_summary(dropped)
    arm = summary["arms"]["with_clearance"]
    start = arm["start_transient"]
    assert start["periodic"] and start["periodicity"][-1] <= PERIODIC
    assert start["joints"]["S"]["peak_contact_force_N"] > 3 * W  # the drop
    steady = arm["joints"]["S"]
    # the steady cycle: the weight alone, to 3 % (after a jump the conformal seat settles within the
    # cycle: the groove deepens as a lune, not as a uniform sink by its deepest depth)
    assert steady["peak_contact_force_N"] == pytest.approx(W, rel=3e-2)
    assert steady["peak_pressure_Pa"] < start["joints"]["S"]["peak_pressure_Pa"]
    a = dropped.arms["with_clearance"]
    assert a.cycles[0] == len(a.transient) and a.cycles[-1] == 1000  # the jumps begin after the transient
    assert all(r["periodicity"] < PERIODIC for r in a.records)  # each cycle starts where the last ended


def test_a_joint_that_did_not_wear_says_so_rather_than_nan(dropped, tmp_path):
    arm = dropped.arms["with_clearance"]
    unworn = dataclasses.replace(arm, profiles={"S": {s: np.zeros_like(c) for s, c in arm.profiles["S"].items()}})
    study = dataclasses.replace(dropped, arms={"with_clearance": unworn})
    summary, names = write_wear(study, tmp_path / "w")
    assert summary["arms"]["with_clearance"]["joints"]["S"]["concentration"] is None
    report = (tmp_path / "w" / "report.md").read_text()
    assert "nan" not in report and "| no wear |" in report
    assert "Start transient, run once and not scaled" in report
    assert "wear_profiles.png" in names
    assert "The cycles are not periodic" not in report  # the sleeve rests: every steady cycle ends where it began
    rattling = dataclasses.replace(arm, records=[{**r, "periodicity": 0.3} for r in arm.records])
    summary, _ = write_wear(dataclasses.replace(dropped, arms={"with_clearance": rattling}), tmp_path / "r")
    assert summary["arms"]["with_clearance"]["steady_periodicity_max"] == 0.3
    said = (tmp_path / "r" / "report.md").read_text()
    assert "The cycles are not periodic: a steady cycle ended up to 0.3 radial" in said
    assert "(no contact was lost: the mechanism settling" in said  # the sleeve never lifted
    lifting = dataclasses.replace(rattling, records=[{**r, "contact_loss_events": 3} for r in rattling.records])
    write_wear(dataclasses.replace(dropped, arms={"with_clearance": lifting}), tmp_path / "l")
    assert "started (rattling)" in (tmp_path / "l" / "report.md").read_text()


@pytest.mark.parametrize("deepest,radius", [(1.75e-6, 0.0101), (2.3e-4, 0.01), (3e-8, 0.005)])
def test_the_drawn_wear_is_magnified_by_a_round_factor_to_a_fifth_of_the_radius(deepest, radius):
    M = _magnification(deepest, radius)
    mantissa = M / 10 ** math.floor(math.log10(M))
    assert min(abs(mantissa - f) for f in (1, 2, 5)) < 1e-9
    assert 0.04 * radius < M * deepest <= 0.2 * radius
    assert _magnification(0.0, radius) == 1.0


def test_a_jump_error_beyond_its_tolerance_names_a_max_change_that_meets_it():
    """The closed-form wear dw/dN = r / (1 + w / b) (tests/test_wear.py): jumps of 0.5 c err
    by more than 2 %; the max_change suggested from their difference to jumps of 0.25 c keeps
    the true error (against the closed form) within 2 %."""
    r, b, N, c = np.array([1e-9, 2e-9]), 2e-6, 200000, 1e-4
    exact = b * (np.sqrt(1 + 2 * r * N / b) - 1)

    def cycle(profiles):
        w = np.zeros(2) if profiles is None else profiles["J"]["bearing"]
        return {"J": {"bearing": r / (1 + w / b)}}, {}

    def worn(f):
        return jump_cycles(cycle, {"J": c}, N, f)[0]["J"]["bearing"]
    coarse, half = worn(0.5), worn(0.25)
    difference = np.max(np.abs(coarse - half)) / np.max(half)
    assert np.max(np.abs(coarse - exact)) / exact.max() > JUMP_TOLERANCE
    f = suggested_max_change(0.5, difference)
    assert f is not None and f < 0.25
    assert np.max(np.abs(worn(f) - exact)) / exact.max() <= JUMP_TOLERANCE
    assert suggested_max_change(0.02, 0.5 * JUMP_TOLERANCE) is None
    line = jump_line({"max_change": 0.5, "profile_error": difference, "tolerance": JUMP_TOLERANCE,
                      "suggested_max_change": f})
    assert line.startswith("max_change: 0.5 lets the profile differ by") and f"--max-change {f:.2g}" in line


def test_a_jump_onto_a_groove_flank_keeps_the_journal_as_loaded_as_it_was(first_cycle):
    """A groove whose deepening is not a uniform sink under the journal (here centred 25 deg
    beside where the journal sits, as a groove that early wear made narrower than the arc):
    moved by the added depth along its eccentricity, the journal would press into the side
    that deepened less (27.4 N against the 19.6 N static load); it moves instead until the
    deeper bore carries the force vector it ended with (to RESEAT_TOLERANCE): the groove's
    slope turns the force off the line of centres, so it also slides toward the groove's
    bottom. The continued run keeps the static load, without an impact or a lift, and the
    cycle stays where it started."""
    a = first_cycle
    e = a.eccentricity[-1, 0]
    at = math.atan2(e[1], e[0]) - a.q[-1, 5]  # where the journal sits, in the sleeve's frame
    psi = 2 * np.pi * np.arange(36) / 36
    groove = 3e-6 * np.exp(-0.5 * (((psi - at - math.radians(25)) + np.pi) % (2 * np.pi) - np.pi) ** 2 / 0.35 ** 2)
    b = rrr4.simulate(JOURNAL, t_end=0.02, start=a, wear={"S": {"bearing": groove, "journal": np.zeros(36)}})
    e_b = b.eccentricity[0, 0]
    turned = math.atan2(e_b[1], e_b[0]) - math.atan2(e[1], e[0])
    assert 0 < turned < math.radians(25)  # toward the groove's bottom
    assert np.linalg.norm(b.contact_force[0, 0] - a.contact_force[-1, 0]) < 1e-3 * W
    assert b.extremes["normal_force_max"][0] == pytest.approx(W, rel=5e-3)
    assert b.contact_loss_events["S"] == 0
    assert periodicity(b) < 1e-3


def test_the_default_jumps_adapt_when_their_measured_error_exceeds_the_tolerance(monkeypatch, tmp_path):
    """With the default max_change the study checks its jumps against half as large ones and,
    where the difference exceeds JUMP_TOLERANCE, runs again with the max_change the check
    names (here a tolerance lowered to 1e-9 makes the default fail and the refinement stop at
    its floor, DEFAULT_MAX_CHANGE / MAX_REFINEMENT, set to 2 to keep the test short): the finer
    study's own jump error is smaller, as first-order jumps make it; a max_change given is kept
    as it is."""
    import rrr4.studies.wear as study_module
    monkeypatch.setattr(study_module, "JUMP_TOLERANCE", 1e-9)
    monkeypatch.setattr(study_module, "MAX_REFINEMENT", 2)
    scene = JOURNAL.with_values({"mechanism.drivers[0].speed_rpm": 3000.0})
    adapted = wear_study(scene, 12000)
    first = adapted.adapted_from
    assert first is not None and first["max_change"] == study_module.DEFAULT_MAX_CHANGE
    assert adapted.max_change == pytest.approx(study_module.DEFAULT_MAX_CHANGE / study_module.MAX_REFINEMENT)
    assert adapted.jump_error["profile_error"] < 0.8 * first["profile_error"]
    write_wear(adapted, tmp_path / "a")
    assert "Adapted: the default jumps (0.02 c) differed by" in (tmp_path / "a" / "report.md").read_text()
    assert wear_study(scene, 3000, max_change=0.05).adapted_from is None


def test_the_layers_peak_pressure_is_the_winkler_closed_form_of_the_resting_sleeve(dropped):
    """The sleeve rests on the unworn shaft under its weight W: the conformal layer's peak
    pressure K_w delta^m at delta = (W / K)^(1/n) is W / (L R_B sqrt(2 delta / c0) B(m)) (the
    layer's force integral over |a| < sqrt(2 delta / c0), docs/wear.md), below the Hertz line
    pressure of the same force (the layer is matched to the dry law's force, not its pressure)."""
    from rrr4.contact.conformal import arc_factor
    summary = wear_summary(dropped)
    r = summary["arms"]["with_clearance"]["joints"]["S"]
    spec, scene = dropped.scene.graph.joint("S"), dropped.scene
    n = scene.effects.contact.exponent
    K = rrr4.build(scene).equations().stiffness[0]
    delta = (W / K) ** (1 / n)
    L, R_B = scene.effects.wear_of(spec).length, spec.bearing_radius
    closed = W / (L * R_B * math.sqrt(2 * delta / C0) * arc_factor(n - 0.5))
    assert r["peak_layer_pressure_Pa"] == pytest.approx(closed, rel=3e-2)
    assert r["peak_layer_pressure_Pa"] < r["peak_pressure_Pa"]
