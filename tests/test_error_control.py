"""Error control of the implicit methods (integrator.tolerance): steps that shrink through an
impact and grow after it, errors that fall with the tolerance, rejected steps that write
nothing, a failure that names the time, the joint and the step, and bad values refused."""

import dataclasses

import casadi as ca
import numpy as np
import pytest
import yaml

import rrr4
from rrr4.errors import Rrr4Error, SceneError, SimulationError
from rrr4.integrators import RK4, Bathe, GeneralizedAlpha, NewmarkTrapezoidal, System
from rrr4.scene import parse_scene

from .conftest import ROOT


def bouncing_ball(stiffness: float = 1e9) -> System:
    """y = [q, v, e]: a ball falling from 1 cm onto a Hertzian floor (k/m = stiffness,
    exponent 1.5): free flight, a contact of a fraction of a millisecond, free flight again."""
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 3), ca.SX.sym("z", 0), ca.SX.sym("u", 2)
    a = -9.81 + stiffness * ca.fmax(-y[0], 0) ** 1.5
    return System(ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], a, y[1] ** 2)]),
                  ca.Function("discrete", [t, y, z], [z]))


X0, T_END = np.r_[0.0, 0.01, 0.0, 0.0], 0.1


def ball(method, h: float, frames: int = 10):
    """The ball over T_END in `frames` output frames of steps h (the largest step, with a tolerance)."""
    t = np.linspace(0.0, T_END, frames + 1)
    spf = int(round(T_END / frames / h))
    return method.run(bouncing_ball(), X0, np.c_[t[:-1], t[1:]], T_END / frames / spf, spf)


@pytest.fixture(scope="module")
def ball_reference():
    return ball(RK4(jit=True), 1e-6).states


@pytest.mark.parametrize("method,constant", [(NewmarkTrapezoidal(), 1 / 12), (Bathe(), 1 / 24),
                                             (GeneralizedAlpha(), 1 / 3)])
def test_error_constant_is_the_methods_local_error_coefficient(method, constant):
    assert method.error_constant() == pytest.approx(constant, rel=1e-9)


@pytest.mark.parametrize("method", [Bathe, NewmarkTrapezoidal, GeneralizedAlpha])
def test_error_falls_with_the_tolerance_through_an_impact(method, ball_reference):
    """Largest step 1 ms against a shorter impact: the fixed step misses the contact force's
    peak (an error of centimetres per second); with a tolerance the steps shrink through the
    impact (some rejected) and grow after it, and the error of the whole bounce falls as the
    tolerance falls, to 1e-3 of the fixed step's."""
    fixed = ball(method(jit=True), 1e-3)
    fixed_error = np.max(np.abs(fixed.states[:, 1:3] - ball_reference[:, 1:3]))
    errors, steps = [], []
    for tol in (1e-6, 1e-8, 1e-10):
        r = ball(method(jit=True, tolerance=tol), 1e-3)
        assert np.all(np.isfinite(r.states)) and "failure" not in r.stats
        errors.append(np.max(np.abs(r.states[:, 1:3] - ball_reference[:, 1:3])))
        steps.append(r.stats["steps"])
        assert r.stats["rejected_steps"] > 0 and r.stats["smallest_step"] <= 1e-3 / 8
        assert r.stats["steps"] < 5 * T_END / 1e-3  # large steps away from the impact
    assert errors[2] < errors[1] < errors[0] < fixed_error / 2
    assert errors[2] < 1e-3 * fixed_error
    assert steps[0] < steps[1] < steps[2]


def test_a_step_that_cannot_go_on_fails_at_its_time_and_writes_no_nan():
    """The acceleration turns NaN after t = 0.05 s: each step across it is rejected and
    retried smaller down to h / 2^12; then the run stops there, reports the time and the step,
    and every state it wrote is finite."""
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 3), ca.SX.sym("z", 0), ca.SX.sym("u", 2)
    ode = ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], -y[0] + ca.sqrt(0.05 - t), 0)])
    sys_ = System(ode, ca.Function("discrete", [t, y, z], [z]))
    tt = np.linspace(0.0, T_END, 11)
    r = Bathe(tolerance=1e-6).run(sys_, X0, np.c_[tt[:-1], tt[1:]], 1e-3, 10)
    failure = r.stats["failure"]
    assert failure["step"] == pytest.approx(1e-3 / 2 ** 12)
    assert 0.05 - 2 * failure["step"] < failure["t"] <= 0.05
    assert np.all(np.isfinite(r.states))


def test_the_reference_scene_reports_its_failure_in_one_line(paper_scene):
    """A Newton that cannot converge (one full iteration to 1e-300) fails every step: the
    message names the time, the joint pressed deepest and the smallest step."""
    scene = dataclasses.replace(paper_scene, integrator=dataclasses.replace(
        paper_scene.integrator, tolerance=1e-7, max_newton=1, newton_tol=1e-300))
    with pytest.raises(SimulationError, match=r"^integrator.tolerance: bathe cannot go on at t = 0 s at joint "
                                              r"[BC]\d \(penetration .* m\): even its smallest step, 2.44e-08 s,"):
        rrr4.simulate(scene, t_end=2e-3, jit=False)


def test_error_control_on_the_reference_scene_keeps_its_steps_and_motion(paper_scene):
    """With the preload holding every journal, the estimate stays below 1e-7 m at the control
    period: the adaptive run takes the fixed run's steps, to the rare step a Newton stage
    does not converge (it is retried smaller instead of accepted), and the same motion."""
    fixed = rrr4.simulate(paper_scene, t_end=0.05)
    adaptive = rrr4.simulate(dataclasses.replace(paper_scene, integrator=dataclasses.replace(
        paper_scene.integrator, tolerance=1e-7)), t_end=0.05)
    assert adaptive.stats["tolerance"] == 1e-7
    assert fixed.stats["steps"] <= adaptive.stats["steps"] <= fixed.stats["steps"] + 10
    assert adaptive.stats["newton_failures"] <= adaptive.stats["rejected_steps"] + fixed.stats["newton_failures"]
    assert np.max(np.linalg.norm(adaptive.pose[:, :2] - fixed.pose[:, :2], axis=1)) < 1e-8


@pytest.mark.parametrize("value,method,expected", [
    (-1.0, "bathe", "integrator.tolerance: -1 is not allowed (must be > 0)"),
    (0.0, "bathe", "integrator.tolerance: 0 is not allowed (must be > 0)"),
    ("1e-7", "bathe", "integrator.tolerance: '1e-7' is text, not a number"),
    (float("nan"), "newmark", "integrator.tolerance: nan is not finite"),
    (1e-7, "rk4", "integrator.tolerance: 1e-07 is not allowed with method 'rk4' (error control is for bathe, "
                  "newmark, generalized-alpha; the adaptive methods take rtol, atol)"),
])
def test_bad_tolerance_is_one_line(value, method, expected):
    data = yaml.safe_load((ROOT / "problems" / "paper_circle.yaml").read_text())
    data["integrator"].update(tolerance=value, method=method)
    with pytest.raises(SceneError) as e:
        parse_scene(data)
    assert str(e.value).startswith(expected) and "\n" not in str(e.value)


def test_bad_tolerance_in_python_is_one_line():
    with pytest.raises(Rrr4Error, match=r"^integrator.tolerance: -1 is not allowed \(a local position error"):
        Bathe(tolerance=-1)


@pytest.mark.parametrize("jit", [False, True])
def test_the_newton_norm_is_infinite_for_nan_and_inf(jit):
    """The finiteness guard of every Newton update and error estimate: norm_inf alone drops NaN
    (C's fmax), and the obvious sum - sum == 0 is simplified away by CasADi."""
    from rrr4.integrators.compiled import compiled

    # a private helper on purpose: the guard is an implementation detail of the Newton loop,
    # and no public name should expose it
    from rrr4.integrators.implicit import _norm
    x = ca.MX.sym("x", 3)
    f = ca.Function("norm_probe", [x], [_norm(x)])
    f = compiled(f) if jit else f
    assert float(f([1.0, -3.0, 2.0])) == 3.0
    for bad in ([np.nan, 1.0, 2.0], [1.0, np.inf, 2.0], [-np.inf, 0.0, 0.0]):
        assert float(f(bad)) == np.inf
