"""Journal bearings reported as journal bearings (issue 43, section 4): the film's shear torque
against Petroff's and Ocvirk's closed forms and the energy audit with it, the minimum film
thickness against the film model's eccentricity, the film in the run's summary and
timeseries, and the largest stable explicit step against a measured divergence."""

import csv
import math

import numpy as np
import pytest
from scipy.integrate import quad

import rrr4
from rrr4 import SimulationError
from rrr4.contact.lubrication import film_torque, min_film_thickness
from rrr4.integrators.stability import largest_stable_step, oscillator_eigenvalues, stability_function
from rrr4.problem import Problem
from rrr4.simulation.foresight import foresight_lines, stiffest_vibration
from tests.conftest import ROOT
from tests.test_lubrication import MU, C, L, R, journal_scene, run, sommerfeld


@pytest.mark.parametrize("eps", [0.0, 0.3, 0.6, 0.9])
def test_film_torque_is_petroffs_and_the_short_bearings_shear_integral(eps):
    """T = mu w R^3 L / c int dtheta / (1 - eps cos theta) (the Couette shear mu R w / h over
    the film, by quadrature); at eps = 0 Petroff's 2 pi mu w R^3 L / c."""
    w = 150.0
    shear = quad(lambda th: MU * R * w / (C * (1 - eps * math.cos(th))) * R * R * L, 0, 2 * math.pi)[0]
    assert float(film_torque(eps, w, R, L, MU, C)) == pytest.approx(-shear, rel=1e-10)
    if eps == 0.0:
        assert float(film_torque(eps, w, R, L, MU, C)) == pytest.approx(-2 * math.pi * MU * w * R**3 * L / C,
                                                                        rel=1e-12)


@pytest.mark.parametrize("law", ["long-bearing", "short-bearing"])
def test_the_equations_brake_the_journal_with_the_film_torque_at_its_eccentricity(law):
    """The built equations: a journal at rest at eps, turning at w in a fixed bore, turns
    ever slower at T(eps) / I (the film's force passes through its centre)."""
    scene = journal_scene(law, 0.0)
    f = Problem.from_scene(scene).equations().acceleration
    for eps in (0.0, 0.5, 0.9):
        out = f(q=[0, -eps * C, 0], qd=[0, 0, 100.0], delta_dot0=1e-3, in_contact=0)
        want = -2 * math.pi * MU * 100.0 * R**3 * L / (C * math.sqrt(1 - eps**2))
        assert float(out["film_torque"]) == pytest.approx(want, rel=1e-9)
        assert float(out["qdd"][2]) * 1e-3 == pytest.approx(want, rel=1e-9)
        assert float(out["power_friction"]) == pytest.approx(-want * 100.0, rel=1e-9)  # dissipated, >= 0


def test_a_spinning_centred_journal_slows_down_as_petroff_says():
    """No load: the journal stays centred and its spin decays as w0 exp(-t / tau), tau =
    c I / (2 pi mu R^3 L) (Petroff)."""
    inertia, w0, t = 1e-3, 100.0, 2.0
    q, qd = run(journal_scene("short-bearing", 0.0, inertia=inertia), w0, t)
    tau = C * inertia / (2 * math.pi * MU * R**3 * L)
    assert np.linalg.norm(q[:2]) < 1e-15
    assert qd[2] == pytest.approx(w0 * math.exp(-t / tau), rel=1e-8)


def test_the_energy_audit_closes_with_the_films_shear():
    """Flores's lubricated slider-crank: the shear now dissipates too (the friction
    dissipation, the scene being frictionless, is the film's shear alone) and the audit closes."""
    sim = rrr4.simulate(ROOT / "problems" / "flores_slider_crank_lubricated.yaml", t_end=0.006)
    assert sim.energy["dissipated_friction"][-1] > 0.0
    assert sim.energy_audit_residual < 1e-6


def test_min_film_thickness_is_the_clearance_left_at_the_film_models_eccentricity():
    """A steadily loaded journal settles at the Sommerfeld eccentricity eps of its load;
    h_min = c (1 - eps) there (Hamrock's short-bearing minimum film thickness)."""
    law, omega, eps_want = "short-bearing", 200.0, 0.6
    s, _ = sommerfeld(law, eps_want)
    load = (R / C) ** 2 * MU * omega / (2 * math.pi) * 2 * R * L / s
    q, _ = run(journal_scene(law, load, mass=0.05, inertia=1e3), omega, 0.3, start=0.5 * C)
    h = min_film_thickness(q[None, :2], C)[0]
    assert h == pytest.approx(C * (1 - eps_want), rel=2e-4)
    assert min_film_thickness(np.array([[0.0, 1.2 * C]]), C)[0] == 0.0  # touching: no film left


def test_the_run_reports_the_film_its_total_force_and_thinnest_gap(tmp_path):
    """rrr4 run on the lubricated slider-crank (short): summary.json and report.md name the
    film's peak force, the total force and h_min per lubricated joint; timeseries.csv holds
    the film's force and h_min, which agrees with the eccentricity columns."""
    from rrr4.results.animation import save_motion
    from rrr4.results.output import write_results
    from rrr4.studies.study import run_study
    # changed in memory: no file describes it, the animation's data comes from the scene itself (Scene.data)
    scene = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank_lubricated.yaml").with_values(
        {"effects.lubrication.viscosity": 0.3})
    study = run_study(scene, t_end=0.0015)
    summary, names = write_results(study, tmp_path / "r", animate=False)
    assert save_motion(study, tmp_path / "motion.npz") is not None
    with np.load(tmp_path / "motion.npz") as z:
        total, t = z["total_force_with_clearance"][:, 0], z["t"]
        assert rrr4.scene.parse_scene(rrr4.scene.load_yaml(str(z["scene_yaml"]), "motion")) == scene
    sim_total = np.linalg.norm(study.arms["with_clearance"].simulation.contact_force[:, 0], axis=1)
    rows = np.searchsorted(study.arms["with_clearance"].simulation.t, t)
    assert np.allclose(total, sim_total[rows]) and total.max() > 10.0  # the colour: dry + film
    film = summary["with_clearance"]["film"]["B"]
    sim = study.arms["with_clearance"].simulation
    assert film["peak_film_force_N"] == pytest.approx(np.linalg.norm(sim.film_force[:, 0], axis=1).max())
    assert film["peak_film_force_N"] > 10.0 and film["peak_total_force_N"] >= film["peak_film_force_N"] - 1e-9
    assert 0.0 <= film["min_film_thickness_m"] < 5e-4
    report = (tmp_path / "r" / "report.md").read_text()
    assert "peak film force at B [N]" in report and "min film thickness h_min = c (1 - eps) at B [um]" in report
    with open(tmp_path / "r" / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    ex = np.array([float(r["with_clearance_ex_B_m"]) for r in rows])
    ey = np.array([float(r["with_clearance_ey_B_m"]) for r in rows])
    h = np.array([float(r["with_clearance_h_min_B_m"]) for r in rows])
    assert np.allclose(h, np.maximum(5e-4 - np.hypot(ex, ey), 0.0), rtol=0, atol=1e-12)
    assert "with_clearance_film_Fx_B_N" in rows[0]


def test_rk4s_stable_step_is_its_stability_polynomials_bound():
    """RK4: 2.785 / |lambda| on the negative real axis, 2 sqrt 2 / omega on the imaginary one;
    the implicit methods have no bound."""
    assert largest_stable_step("rk4", [-1000.0]) == pytest.approx(2.785293563 / 1000.0, rel=1e-8)
    assert largest_stable_step("rk4", [1j * 500.0]) == pytest.approx(2 * math.sqrt(2) / 500.0, rel=1e-8)
    assert largest_stable_step("bathe", [-1.0]) is None
    lam = oscillator_eigenvalues(2.0, 1e8, 2e3)
    h = largest_stable_step("rk4", lam)
    assert np.max(np.abs(stability_function("rk4", 0.999 * h * lam))) <= 1.0
    assert np.max(np.abs(stability_function("rk4", 1.01 * h * lam))) > 1.0


# the sleeve on the shaft through a linear Kelvin-Voigt contact (k, c exact at any load), seated under
# its weight; the shaft 5 kg so that the sleeve (2 kg) is the lightest body at the joint
STIFF = rrr4.load_scene(ROOT / "problems" / "wear_journal.yaml").with_values({
    "effects.contact": {"law": "kelvin-voigt", "stiffness": 1e8, "exponent": 1.0, "damping": 2e3},
    "effects.wear": {"surfaces": "none"}, "mechanism.bodies[0].mass": 5.0})


def test_the_stable_step_estimate_matches_a_measured_divergence():
    """The estimate from the contact's stiffness and damping against the sleeve: just below it
    the seated sleeve stays at rest on the shaft over 2000 steps (force = its weight, audit
    closed); just above it the rounding grows (the audit breaks); well above it blows up."""
    v = stiffest_vibration(Problem.from_scene(STIFF))
    assert v.body == "sleeve" and v.stiffness == 1e8 and v.damping == 2e3
    h = largest_stable_step("rk4", oscillator_eigenvalues(v.mass, v.stiffness, v.damping))
    assert foresight_lines(Problem.from_scene(STIFF), step=0.95 * h, method="rk4") == []
    line, = foresight_lines(Problem.from_scene(STIFF), step=1.05 * h, method="rk4")
    assert "rk4 is unstable beyond a step of" in line and f"use a step <= {h:.2g} s" in line

    def run_at(f):
        return rrr4.simulate(STIFF, "rk4", step=f * h, output_rate=1 / (f * h), t_end=2000 * f * h)
    below = run_at(0.95)
    assert below.energy_audit_residual < 1e-9 and below.extremes["normal_force_max"][0] < 1.001 * 19.625
    assert run_at(1.05).energy_audit_residual > 1e-4
    with pytest.raises(SimulationError, match="lets the state blow up"):
        run_at(1.5)
