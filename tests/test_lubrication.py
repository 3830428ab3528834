"""Lubricated clearance joints: the film's force against Reynolds' equation and the classic
closed forms (Sommerfeld number and attitude angle of a steadily loaded journal, the
squeeze-film drop), the energy audit, bad input, and dry scenes left exactly as they were."""

import copy
import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid, quad, solve_ivp, trapezoid

import rrr4
from rrr4 import SceneError
from rrr4.contact.lubrication import film_force, film_weight
from rrr4.problem import Problem
from rrr4.scene import parse_scene, read_yaml, set_key
from tests.conftest import ROOT

R, L, MU, C = 0.01, 0.02, 0.05, 1e-4  # journal radius, bearing length [m], viscosity [Pa s], clearance [m]
LAWS = ("long-bearing", "short-bearing")


def reynolds_force(law, eps, A, B):
    """(F_n, F_t) by quadrature of Reynolds' equation with half-Sommerfeld cavitation: the
    short bearing's p = max(p_full, 0); the long bearing's pi film with p = 0 at its ends."""
    a = -math.atan2(B, A) - 0.5 * math.pi
    th = np.linspace(a, a + math.pi, 40001)
    h3 = (1 - eps * np.cos(th)) ** 3
    if law == "short-bearing":
        def p(x):
            return max(MU * L**3 / C**2 * (A * math.cos(x) - B * math.sin(x)) / (1 - eps * math.cos(x)) ** 3, 0.0)
        return tuple(-R * quad(lambda x, f=f: p(x) * f(x), -math.pi, math.pi, limit=400, points=[a, a + math.pi])[0]
                     for f in (math.cos, math.sin))
    g = -B * np.cos(th) - A * np.sin(th)
    g = g - trapezoid(g / h3, th) / trapezoid(1 / h3, th)
    p = cumulative_trapezoid(12 * MU * R**2 / C**2 * g / h3, th, initial=0.0)
    return -R * L * trapezoid(p * np.cos(th), th), -R * L * trapezoid(p * np.sin(th), th)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("eps,A,B", [(0.5, 0.0, 10.0), (0.5, 10.0, 0.0), (0.7, 3.0, -5.0), (0.3, -4.0, 2.0),
                                     (0.9, -2.0, -7.0), (0.0, 1.0, 0.0)])
def test_film_force_matches_reynolds_equation_by_quadrature(law, eps, A, B):
    got = np.array([float(v) for v in film_force(law, eps, A, B, R, L, MU, C)])
    want = np.array(reynolds_force(law, eps, A, B))
    assert np.allclose(got, want, rtol=1e-6, atol=1e-9 * np.abs(want).max())


# ---- a journal (one body) in a lubricated bearing on the ground, loaded by "gravity"

def journal_scene(law, load, mass=1.0, viscosity=MU, threshold=0.95, inertia=1e-3):
    return parse_scene({
        "name": "journal", "mechanism": {"kind": "graph", "ground": {"points": {"O": [0.0, 0.0]}},
                                         "bodies": [{"name": "journal", "mass": mass, "inertia": inertia,
                                                     "points": {"O": [0.0, 0.0]}}],
                                         "joints": [{"name": "J", "type": "revolute", "bodies": ["ground", "journal"],
                                                     "points": ["O", "O"],
                                                     "clearance": {"journal_radius": R, "radial_clearance": C}}],
                                         "task": "none"},
        "effects": {"lubrication": {"law": law, "viscosity": viscosity, "length": L, "threshold": threshold},
                    "gravity": [0.0, -load / mass]},
        "path": {"type": "none", "duration": 1.0}, "integrator": {"method": "radau", "step": 1e-4}})


def run(scene, omega, t_end, start=0.0):
    """q (3,), qd (3,) at t_end from the journal at rest at eccentricity (0, -start) [m],
    turning at omega [rad/s] (the film exerts no moment on it)."""
    f = Problem.from_scene(scene).equations().acceleration
    y = ca.SX.sym("y", 6)
    ydot = ca.vertcat(y[3:], f(q=y[:3], qd=y[3:], delta_dot0=1e-3, in_contact=0)["qdd"])
    rhs, jac = ca.Function("rhs", [y], [ydot]), ca.Function("rhs_jacobian", [y], [ca.jacobian(ydot, y)])
    sol = solve_ivp(lambda _, x: np.array(rhs(x)).ravel(), (0.0, t_end), [0, -start, 0, 0, 0, omega],
                    method="Radau", rtol=1e-10, atol=1e-14, jac=lambda _, x: np.array(jac(x)))
    assert sol.success
    return sol.y[:3, -1], sol.y[3:, -1]


def sommerfeld(law, eps):
    """Closed forms (half-Sommerfeld): Sommerfeld number S = (R/c)^2 mu N / P (N [rev/s],
    P = W / (2 R L)) and attitude angle [rad] against the eccentricity ratio (Hamrock,
    Schmid, Jacobson 2004, Fundamentals of Machine Elements / of Fluid Film Lubrication, ch. 10)."""
    if law == "long-bearing":
        s = (2 + eps**2) * (1 - eps**2) / (6 * math.pi * eps * math.sqrt(math.pi**2 * (1 - eps**2) + 4 * eps**2))
        return s, math.atan(math.pi * math.sqrt(1 - eps**2) / (2 * eps))
    s = (R / L) ** 2 * 4 * (1 - eps**2) ** 2 / (math.pi * eps * math.sqrt(math.pi**2 * (1 - eps**2) + 16 * eps**2))
    return s, math.atan(math.pi * math.sqrt(1 - eps**2) / (4 * eps))


@pytest.mark.parametrize("law", LAWS)
def test_steadily_loaded_journal_settles_on_the_closed_form_eccentricity_and_attitude(law):
    omega, eps_want = 200.0, 0.6
    s, phi_want = sommerfeld(law, eps_want)
    load = (R / C) ** 2 * MU * omega / (2 * math.pi) * 2 * R * L / s  # the load of that Sommerfeld number
    # a heavy flywheel keeps the spin that the film's shear torque brakes (by 2e-7 of it over the run)
    q, qd = run(journal_scene(law, load, mass=0.05, inertia=1e3), omega, 0.3, start=0.5 * C)
    e = q[:2]
    eps = np.linalg.norm(e) / C
    phi = math.acos(np.dot(e, [0.0, -1.0]) / np.linalg.norm(e))  # from the load line to the line of centres
    assert abs(eps - eps_want) < 1e-4
    assert abs(phi - phi_want) < 1e-4
    assert np.linalg.norm(qd[:2]) < 1e-9 and abs(qd[2] - omega) < 1e-6 * omega  # at rest, still turning
    assert e[0] > 0  # off the load line (-y) in the sense of rotation (counterclockwise)


def test_squeeze_film_drop_follows_its_closed_form():
    """Short bearing, no rotation, constant load W from the centred journal: quasi-static
    mu R L^3 eps_dot / c^2 [(1 + 2 e^2)(pi/2 + asin e) + 3 e sqrt(1 - e^2)] / (1 - e^2)^(5/2) = W,
    so t(eps) = mu R L^3 / (W c^2) [eps (pi/2 + asin eps) / (1 - eps^2)^(3/2) + 1 / (1 - eps^2) - 1]."""
    load = 50.0
    scene = journal_scene("short-bearing", load, mass=1e-4)
    tau = MU * R * L**3 / (load * C**2)

    def t_of(eps):
        return tau * (eps * (0.5 * math.pi + math.asin(eps)) / (1 - eps**2) ** 1.5 + 1 / (1 - eps**2) - 1)
    for eps_want in (0.3, 0.6, 0.9):
        q, qd = run(scene, 0.0, t_of(eps_want))
        assert abs(np.linalg.norm(q[:2]) / C - eps_want) < 2e-4
        assert abs(q[0]) < 1e-15 and abs(qd[2]) == 0.0  # straight down, no rotation


def test_film_hands_over_to_the_dry_laws_continuously_and_stays_finite():
    eps = np.linspace(0.0, 1.0, 2001)
    w = np.array([float(film_weight(x, 0.9)) for x in eps])
    assert w[eps <= 0.9].min() == 1.0 and w[-1] == 0.0 and np.all(np.diff(w) <= 0)
    assert np.abs(np.diff(w)).max() <= 1.5 * (eps[1] - eps[0]) / 0.1 + 1e-12  # C1: the cubic step's slope
    for law in LAWS:  # what the equations apply: w(eps) F(min(eps, threshold)); at eps -> 1 and beyond: 0
        f = [float(film_weight(x, 0.9)) * float(film_force(law, min(x, 0.9), 5.0, 50.0, R, L, MU, C)[0])
             for x in (0.9, 0.95, 0.999999, 1.0, 1.2)]
        assert all(math.isfinite(v) for v in f) and f[-2] == pytest.approx(0.0, abs=1e-9 * abs(f[0])) and f[-1] == 0.0


def test_energy_audit_closes_with_the_film():
    sim = rrr4.simulate(ROOT / "problems" / "flores_slider_crank_lubricated.yaml", t_end=0.012)
    assert "lubrication (long-bearing) at B" in sim.terms
    assert np.abs(sim.film_force).max() > 100.0  # the film carries load
    assert sim.energy["dissipated_damping"][-1] > 0.0
    assert sim.energy_audit_residual < 1e-6


def test_dry_scene_builds_exactly_the_equations_it_built_before():
    dry = Problem.from_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    data = read_yaml(ROOT / "problems" / "flores_slider_crank.yaml")
    set_key(data, "effects.lubrication", {"law": "none"})
    said_none = Problem.from_scene(parse_scene(data))
    a, b = dry.equations(), said_none.equations()
    assert a.acceleration.serialize() == b.acceleration.serialize()
    assert not any("lubrication" in t for t in a.terms)
    assert "film_force" not in a.acceleration.name_out() and len(a.parameters) == 3 + 7
    assert a.acceleration.n_instructions() == 626  # as on the branch point, before lubrication existed


def test_a_joint_overrides_the_scenes_film_and_viscosity_is_an_input_not_structure():
    data = read_yaml(ROOT / "problems" / "paper_circle.yaml")
    set_key(data, "effects.lubrication", {"law": "short-bearing", "viscosity": 0.1, "length": 0.01})
    data["joints"].setdefault("per_joint", {})["B1"] = {"lubrication": {"law": "none"}}
    p = Problem.from_scene(parse_scene(data))
    assert [t for t in p.equations().terms if "lubrication" in t] == ["lubrication (short-bearing) at B2 B3 B4 "
                                                                     "C1 C2 C3 C4"]
    set_key(data, "effects.lubrication.viscosity", 0.3)
    q = Problem.from_scene(parse_scene(data))
    assert q.equations().parametric is p.equations().parametric  # one structure: a viscosity sweep compiles once
    assert q.contact_parameters[-3] == 0.3 and p.contact_parameters[-3] == 0.1


@pytest.mark.parametrize("key,value,says", [
    ("viscosity", 0.0, "effects.lubrication.viscosity: 0 is not allowed (must be > 0)"),
    ("viscosity", -1.0, "effects.lubrication.viscosity: -1 is not allowed (must be > 0)"),
    ("length", 0.0, "effects.lubrication.length: 0 is not allowed (must be > 0)"),
    ("threshold", 0.0, "effects.lubrication.threshold: 0 is out of range (allowed: (0, 1))"),
    ("threshold", 1.0, "effects.lubrication.threshold: 1 is out of range (allowed: (0, 1))"),
    ("threshold", 1.5, "effects.lubrication.threshold: 1.5 is out of range (allowed: (0, 1))"),
    ("law", "petroff", "effects.lubrication.law: unknown value 'petroff'"),
])
def test_bad_lubrication_is_refused_in_one_line(key, value, says):
    data = copy.deepcopy(read_yaml(ROOT / "problems" / "flores_slider_crank_lubricated.yaml"))
    set_key(data, f"effects.lubrication.{key}", value)
    with pytest.raises(SceneError) as err:
        parse_scene(data)
    assert str(err.value).startswith(says) and "\n" not in str(err.value)


def test_film_keys_without_a_film_are_refused():
    data = read_yaml(ROOT / "problems" / "flores_slider_crank.yaml")
    set_key(data, "effects.lubrication", {"law": "none", "viscosity": 0.1})
    with pytest.raises(SceneError, match=r"^effects.lubrication.viscosity: not used by law 'none'"):
        parse_scene(data)


def test_film_force_is_symbolic_like_every_contact_law():
    x = ca.SX.sym("x", 3)
    fn, ft = film_force("short-bearing", x[0], x[1], x[2], R, L, MU, C)
    f = ca.Function("f", [x], [fn, ft])
    assert np.allclose([float(v) for v in f([0.5, 10.0, 0.0])], reynolds_force("short-bearing", 0.5, 10.0, 0.0))


def test_equations_and_their_jacobian_stay_finite_for_a_centred_journal_at_rest():
    """What implicit integrators need at the start of a lubricated run: finite derivatives
    where the film's rates (A, B) vanish and the line of centres is undefined."""
    f = Problem.from_scene(journal_scene("long-bearing", 10.0)).equations().acceleration
    q, qd = ca.SX.sym("q", 3), ca.SX.sym("qd", 3)
    qdd = f(q=q, qd=qd, delta_dot0=1e-3, in_contact=0)["qdd"]
    jac = ca.Function("jacobian_qdd", [q, qd], [ca.jacobian(qdd, ca.vertcat(q, qd))])
    assert np.all(np.isfinite(np.array(jac(np.zeros(3), np.zeros(3)))))
