"""Integrators: order, spectral radius at infinite stiffness, compiled cache, adaptive agreement."""

import dataclasses
import itertools

import casadi as ca
import numpy as np
import pytest

import rrr4
from rrr4.integrators import METHODS, RK4, Bathe, Cvodes, GeneralizedAlpha, NewmarkTrapezoidal, System
from rrr4.integrators.bathe import bathe_weights

from .conftest import ROOT


def oscillator(omega: float) -> System:
    """y = [q, v, e]: q'' = -omega^2 q, e' = v^2 (a quadrature); no discrete state, u = [t_a, t_b]."""
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 3), ca.SX.sym("z", 0), ca.SX.sym("u", 2)
    ode = ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], -omega**2 * y[0], y[1] ** 2)])
    return System(ode, ca.Function("discrete", [t, y, z], [z]))


def run(method, system, h, t_end, y0=(1.0, 0.0, 0.0)):
    n = max(int(round(t_end / h)), 1)
    u = np.array([[0.0, t_end]])
    return method.run(system, np.r_[0.0, y0], u, t_end / n, n).states[-1]


def test_bathe_weights_reduce_to_bathe_baig_and_trapezoidal():
    assert np.allclose(bathe_weights(0.5, 0.0), (1 / 3, 1 / 3, 1 / 3))
    assert np.allclose(bathe_weights(0.5, 1.0), (0.25, 0.5, 0.25))


@pytest.mark.parametrize("method,rho", [(Bathe(), 0.0), (Bathe(rho_inf=0.5), 0.5), (Bathe(gamma=0.3, rho_inf=0.2), 0.2),
                                        (NewmarkTrapezoidal(), 1.0), (GeneralizedAlpha(rho_inf=0.3), 0.3)])
def test_spectral_radius_at_infinite_stiffness_is_rho_inf(method, rho):
    omega, h = 1e6, 1e-2        # omega h = 1e4

    def amplitude(n):
        y = run(method, oscillator(omega), h, n * h)
        return np.hypot(y[1], y[2] / omega)

    if rho == 0:                # annihilated in one step up to O(1/(omega h))
        assert amplitude(2) < 1e-3
    else:                       # per-step decay of the asymptotic amplitude (Jordan blocks give (n+1)/n factors)
        assert amplitude(61) / amplitude(60) == pytest.approx(rho, rel=0.05)


@pytest.mark.parametrize("method", [Bathe(), Bathe(gamma=0.4, rho_inf=0.6), NewmarkTrapezoidal(),
                                    GeneralizedAlpha(rho_inf=0.5), RK4()])
def test_error_falls_at_the_method_order_on_a_smooth_oscillator(method):
    sys_ = oscillator(2 * np.pi)
    w, t = 2 * np.pi, 0.7
    exact = np.array([np.cos(w * t), -w * np.sin(w * t)])
    errs = [np.linalg.norm(run(method, sys_, h, t)[1:3] - exact) for h in (0.007, 0.0035, 0.00175)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - method.order) < 0.25), orders


def test_implicit_methods_report_newton_iterations_and_converge():
    m = Bathe()
    stats = m.run(oscillator(50.0), np.r_[0.0, 1.0, 0.0, 0.0], np.array([[0.0, 0.1]]), 1e-3, 100).stats
    assert stats["newton_failures"] == 0
    assert 2 <= stats["newton_iterations_per_step"] <= 2 * m.max_newton


def test_compiled_stepping_matches_the_vm_and_is_cached_on_disk(tmp_path, monkeypatch):
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    sys_ = oscillator(3.0)
    y_vm = run(Bathe(), sys_, 1e-3, 0.5)
    y_c = run(Bathe(jit=True), sys_, 1e-3, 0.5)
    libs = sorted(p.name for p in tmp_path.glob("*.so"))
    assert len(libs) == 1
    stamp = (tmp_path / libs[0]).stat().st_mtime_ns
    y_c2 = run(Bathe(jit=True), sys_, 1e-3, 0.5)
    assert sorted(p.name for p in tmp_path.glob("*.so")) == libs
    assert (tmp_path / libs[0]).stat().st_mtime_ns == stamp
    assert np.allclose(y_c, y_vm, rtol=1e-12, atol=1e-14) and np.array_equal(y_c, y_c2)


def test_compiled_fmax_and_fmin_compute_what_the_c_library_computes(tmp_path, monkeypatch):
    """The compiled stepping's inline fmax/fmin (:func:`rrr4.integrators.compiled.inline_min_max`)
    against the same C calling the C library's fmax/fmin: every pair of special values gives
    the same bits (signed zeros included; NaN where the library gives NaN). (CasADi's virtual
    machine differs from both on the sign of fmax(-0, +0).)"""
    from rrr4.integrators import compiled as module
    if not module.INLINE_MIN_MAX:
        pytest.skip("the inline fmax/fmin is glibc's x86-64 rule, made only there")
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path))
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    f = ca.Function("min_max_probe", [x, y], [ca.vertcat(ca.fmax(x, y), ca.fmin(x, y), ca.norm_inf(ca.vertcat(x, y)))])
    inline = module.compiled(f)
    monkeypatch.setattr(module, "INLINE_MIN_MAX", False)
    library = module.compiled(f)
    assert len(list(tmp_path.glob("*.so"))) == 2  # two texts: the rewrite applied
    values = [np.nan, -np.inf, -1.5, -0.0, 0.0, 2.0, np.inf]
    for a, b in itertools.product(values, values):
        lib, c = (np.array(g(a, b)).ravel() for g in (library, inline))
        assert np.array_equal(np.isnan(lib), np.isnan(c)), (a, b, lib, c)
        ok = ~np.isnan(lib)
        assert np.array_equal(lib[ok], c[ok]) and np.array_equal(np.signbit(lib[ok]), np.signbit(c[ok])), (a, b)


@pytest.mark.parametrize("name", ["erk", "rosenbrock", "cvodes", "idas", "rk45", "radau"])
def test_adaptive_methods_meet_their_tolerance_on_a_smooth_oscillator(name):
    m = METHODS[name](rtol=1e-8, atol=1e-10)
    r = m.run(oscillator(2 * np.pi), np.r_[0.0, 1.0, 0.0, 0.0], np.array([[0.0, 1.0]]), 1e-3, 1000)
    y = r.states[-1]
    assert abs(y[1] - 1.0) < 1e-5 and abs(y[2]) < 1e-4
    assert r.stats["steps"] > 0


def test_unknown_integrator_raises_scene_error(paper_scene):
    with pytest.raises(rrr4.SceneError, match="integrator"):
        rrr4.simulate(paper_scene, "euler", t_end=1e-3)


def test_bad_bathe_parameters_raise_user_errors():
    with pytest.raises(rrr4.Rrr4Error, match="gamma"):
        Bathe(gamma=1.5)
    with pytest.raises(rrr4.Rrr4Error, match="rho_inf"):
        GeneralizedAlpha(rho_inf=-0.1)
    with pytest.raises(rrr4.Rrr4Error, match="rtol"):
        Cvodes(rtol=0.0)


@pytest.fixture(scope="module")
def ideal_scene(paper_data_module):
    paper_data_module["joints"]["clearance"] = []
    paper_data_module["actuation"].pop("control_rate")  # continuous: steps longer than a control period
    return rrr4.scene.parse_scene(paper_data_module)


@pytest.fixture(scope="module")
def paper_data_module():
    import yaml

    from tests.conftest import PAPER
    return yaml.safe_load(PAPER.read_text())


def test_bathe_is_second_order_on_the_ideal_mechanism(ideal_scene):
    """Richardson: successive differences of the platform pose at t_end fall by 4x per halving."""
    poses = [rrr4.simulate(ideal_scene, "bathe", t_end=0.2, step=h, output_rate=5).q[-1]
             for h in (4e-3, 2e-3, 1e-3)]
    d1, d2 = np.max(np.abs(poses[0] - poses[1])), np.max(np.abs(poses[1] - poses[2]))
    assert 1.6 < np.log2(d1 / d2) < 2.5


def test_onset_refinement_resolves_the_first_impacts_better_per_step(paper_scene):
    """Centred journals fall onto their bearings in the first milliseconds (onsets and losses).
    Re-taking only the steps with a contact event as 4 sub-steps must beat the plain step by
    more than 4x in platform error against a fine reference; it adds 4 sub-steps per event step
    only, far fewer than dividing every step by 4."""
    scene = dataclasses.replace(paper_scene, initial=dataclasses.replace(paper_scene.initial, journals="centred"),
                                actuation=dataclasses.replace(paper_scene.actuation, control_rate=None))
    kw = {"t_end": 0.004, "output_rate": 1000, "preload": rrr4.solve_preload(scene)}
    ref = rrr4.simulate(scene, "rk4", step=2.5e-7, **kw)
    assert sum(ref.contact_loss_events.values()) > 0          # the window holds impacts, not only seating

    def error(method):
        s = rrr4.simulate(scene, method, step=1e-5, **kw)
        return np.max(np.linalg.norm(s.pose[:, :2] - ref.pose[:, :2], axis=1))

    plain, refined = error(RK4()), error(RK4(refine=4))
    assert refined < plain / 4, (plain, refined)


def test_refine_must_be_a_positive_integer():
    with pytest.raises(rrr4.Rrr4Error, match="refine"):
        RK4(refine=0)


def test_work_precision_measures_all_methods_against_one_checked_reference_and_marks_blow_ups(paper_scene, tmp_path):
    """A tiny window: RK4 at 1e-3 s (10x beyond its stability limit) is a row marked unstable,
    not a failure; the reference's two cross-checks agree with it far below 1 um; the figure
    and the CSV are written."""
    import csv

    from rrr4.studies.bench import work_precision, write_work_precision
    plan = {"rk4": ("step", [1e-3, 5e-5]), "cvodes": ("rtol", [1e-6])}
    rows = work_precision(paper_scene, t_end=0.005, plan=plan)
    status = {(r["method"], r["setting"]): r["status"] for r in rows}
    assert status[("rk4", 1e-3)] == "unstable" and status[("rk4", 5e-5)] == "ok"
    assert status[("cvodes", 1e-6)] == "ok"
    checks = [r for r in rows if r["status"] == "cross-check"]
    assert len(checks) == 2 and all(r["error_m"] < 1e-9 for r in checks)
    assert len({r["reference"] for r in rows}) == 1
    assert all(r["error_m"] < 1e-6 and r["cpu_s"] > 0 for r in rows if r["status"] == "ok")
    png, table = write_work_precision(rows, paper_scene, tmp_path, 0.005)
    assert png.stat().st_size > 0
    assert [r["status"] for r in csv.DictReader(table.open())] == [r["status"] for r in rows]


@pytest.mark.parametrize("method", [Bathe, NewmarkTrapezoidal, GeneralizedAlpha])
def test_simplified_newton_reuses_its_factors_and_agrees_with_full_newton(method):
    """A nonlinear oscillator (q'' = -w^2 (q + q^3), omega h = 1): the simplified iterations
    land on the same step solutions as full Newton (to the Newton tolerance) with far fewer
    Jacobians, and the counters say so."""
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 3), ca.SX.sym("z", 0), ca.SX.sym("u", 2)
    w = 100.0
    ode = ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], -w**2 * (y[0] + y[0] ** 3), y[1] ** 2)])
    sys_ = System(ode, ca.Function("discrete", [t, y, z], [z]))
    x0, u = np.r_[0.0, 0.1, 0.0, 0.0], np.array([[0.0, 0.2]])
    full = method(newton="full", newton_tol=1e-12).run(sys_, x0, u, 1e-2, 20)
    simp = method(newton_tol=1e-12).run(sys_, x0, u, 1e-2, 20)
    assert np.allclose(simp.states, full.states, rtol=0, atol=1e-9)
    assert simp.stats["newton_failures"] == full.stats["newton_failures"] == 0
    assert full.stats["jacobians"] == full.stats["newton_iterations"]
    assert simp.stats["jacobians"] < full.stats["jacobians"] / 10


def test_bathe_at_gamma_two_minus_sqrt_two_shares_one_iteration_matrix():
    assert Bathe(gamma=2 - np.sqrt(2)).matrices == 1 and Bathe().matrices == 2


def test_simplified_newton_renews_its_factors_after_a_contact_event(paper_scene):
    """On the reference scene's first milliseconds (journals falling onto their bearings, 16
    contact losses): the factors are renewed after contact events, so the stages that reach
    the Newton tolerance are no fewer than with full Newton (the non-smooth impacts defeat
    both a few times), with fewer Jacobians, and the motion agrees far below 1 um. A NaN
    Jacobian at zero penetration once passed here for convergence: the state must stay finite."""
    scene = dataclasses.replace(paper_scene, initial=dataclasses.replace(paper_scene.initial, journals="centred"))
    kw = {"t_end": 0.005, "step": 1e-4}
    simp = rrr4.simulate(scene, "bathe", **kw)
    full = rrr4.simulate(dataclasses.replace(scene, integrator=dataclasses.replace(scene.integrator, newton="full")),
                         "bathe", **kw)
    assert simp.stats["newton"] == "simplified" and full.stats["newton"] == "full"
    assert sum(full.contact_loss_events.values()) > 0
    assert simp.stats["newton_failures"] <= full.stats["newton_failures"]
    assert 1 <= simp.stats["jacobians"] < 0.7 * full.stats["jacobians"]
    assert np.max(np.linalg.norm(simp.pose[:, :2] - full.pose[:, :2], axis=1)) < 1e-8


def test_bad_newton_choice_is_one_line():
    with pytest.raises(rrr4.Rrr4Error, match="integrator.newton: 'quasi' is not allowed"):
        Bathe(newton="quasi")


def test_default_path_agrees_with_the_exact_reference_path_within_a_micrometre(paper_scene):
    """The default path (controller sampled at 10 kHz on references interpolated once per
    period, Bathe at the period, simplified Newton) against the old exact path (the
    closed-form controller in every right-hand side, RK4 at 1e-5 s): 0.2 s of the reference
    scene within 1 um (measured 1.5e-7 m)."""
    new = rrr4.simulate(paper_scene, t_end=0.2)
    old = rrr4.simulate(dataclasses.replace(paper_scene, actuation=dataclasses.replace(
        paper_scene.actuation, control_rate=None)), "rk4", step=1e-5, t_end=0.2, references="exact")
    assert new.stats["references"] == "held" and old.stats["references"] == "exact"
    assert np.max(np.linalg.norm(new.pose[:, :2] - old.pose[:, :2], axis=1)) < 1e-6


def test_slider_crank_default_path_agrees_with_a_fine_reference_within_a_micrometre():
    """Flores's slider-crank over its first impacts (2 ms): the scene's path (RK4 at 1e-6 s,
    contact events re-taken in 16 sub-steps) within 1 um of the slider's position at a 4x
    finer step (measured 2.8e-7 m)."""
    scene = rrr4.load_scene(ROOT / "problems" / "flores_slider_crank.yaml")
    fine = rrr4.simulate(scene, step=2.5e-7, t_end=2e-3)
    default = rrr4.simulate(scene, t_end=2e-3)
    assert sum(fine.contact_loss_events.values()) >= 3
    assert np.max(np.abs(default.body("slider")[:, 0] - fine.body("slider")[:, 0])) < 1e-6


def _compile_in_child(cache: str, queue) -> None:
    import os as _os
    _os.environ["RRR4_CACHE"] = cache
    from rrr4.codegen.build import compilations
    from rrr4.integrators.compiled import compiled
    x = ca.SX.sym("x", 20)
    y = x
    for k in range(300):  # enough C that gcc takes a few seconds: the two processes overlap
        y = ca.sin(y * (1 + k % 7)) + ca.cos(ca.dot(y, x) * y)
    f = ca.Function("lock_probe", [x], [y])
    compiled(f)
    queue.put(compilations())


def test_two_processes_that_need_one_library_compile_it_once(tmp_path):
    """Sweep workers share the on-disk cache: a lock per library makes the second process wait
    for the first one's library instead of compiling its own."""
    import multiprocessing as mp
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    procs = [ctx.Process(target=_compile_in_child, args=(str(tmp_path), queue)) for _ in range(2)]
    for p in procs:
        p.start()
    counts = sorted(queue.get(timeout=120) for _ in procs)
    for p in procs:
        p.join(timeout=30)
    assert counts == [0, 1] and len(list(tmp_path.glob("lock_probe_*.so"))) == 1


@pytest.mark.parametrize("method", [RK4(), Bathe()], ids=["rk4", "bathe"])
def test_a_run_gives_the_same_states_in_any_number_of_calls_and_builds_them_once(method):
    """A run is split into calls from Python (about CALLS of them by default); how it is split
    changes nothing in the states, and a second run of the same system builds no new call."""
    sys_ = oscillator(7.0)
    t = np.linspace(0.0, 0.6, 121)
    u = np.c_[t[:-1], t[1:]]
    x0 = np.r_[0.0, 1.0, 0.0, 0.0]
    runs = {chunk: method.run(sys_, x0, u, 1e-3, 5, chunk=chunk, every=2).states for chunk in (None, 2, 14, 1000)}
    assert runs[None].shape[0] == 60
    for chunk, states in runs.items():
        assert np.array_equal(states, runs[None]), chunk
    built = len(sys_.frames)
    again = method.run(sys_, x0, u, 1e-3, 5, every=2).states
    assert len(sys_.frames) == built and np.array_equal(again, runs[None])


def test_a_compiler_that_refuses_the_fast_flags_builds_a_portable_library(tmp_path, monkeypatch):
    """Where the C compiler refuses -march=native (a cross or older compiler), the stepping is
    compiled with the portable flags instead and computes the same states."""
    from rrr4.codegen.build import PORTABLE_FLAGS
    from rrr4.files import c_compiler
    real = c_compiler()
    if real is None:
        pytest.skip("no C compiler")
    cc = tmp_path / "cc-without-native"
    log = tmp_path / "calls"
    cc.write_text(f'#!/bin/sh\necho "$*" >> "{log}"\n'
                  f'case " $* " in *" -march=native "*) echo "unsupported -march" >&2; exit 1;; esac\n'
                  f'exec "{real}" "$@"\n')
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    monkeypatch.setenv("RRR4_CACHE", str(tmp_path / "cache"))
    y_vm = run(Bathe(), oscillator(2.5), 1e-3, 0.2)
    y_c = run(Bathe(jit=True), oscillator(2.5), 1e-3, 0.2)
    calls = log.read_text().splitlines()
    assert len(calls) == 2 and "-march=native" in calls[0] and calls[1].startswith(" ".join(PORTABLE_FLAGS))
    assert len(list((tmp_path / "cache").glob("*.so"))) == 1
    assert np.allclose(y_c, y_vm, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("method", [RK4(), Bathe(), Cvodes()], ids=["rk4", "bathe", "cvodes"])
def test_frame_inputs_made_a_block_at_a_time_give_the_states_of_the_whole_array(method, monkeypatch):
    """A long run's frame inputs are made while it steps (FrameInputs), a block of frames at a
    time, never all at once, and give the states the whole array gives."""
    from rrr4.integrators import FrameInputs
    monkeypatch.setattr(FrameInputs, "BLOCK", 16)  # frames per block where a run asks frame by frame
    sys_ = oscillator(7.0)
    t = np.linspace(0.0, 0.5, 101)
    u = np.c_[t[:-1], t[1:]]
    asked = []

    def rows(a, b):
        asked.append((a, b))
        return u[a:b]

    x0 = np.r_[0.0, 1.0, 0.0, 0.0]
    whole = method.run(sys_, x0, u, 1e-3, 5, every=4).states
    blocks = method.run(sys_, x0, FrameInputs(len(u), u.shape[1], rows), 1e-3, 5, every=4).states
    assert np.array_equal(blocks, whole) and whole.shape[0] == 25
    assert len(asked) > 1 and max(b - a for a, b in asked) < len(u) and min(a for a, _ in asked) == 0


def test_frame_ends_made_by_index_are_linspace_bit_for_bit():
    from rrr4.simulation import frame_times
    rng = np.random.default_rng(3)
    for t_end, n in [(1.0, 10000), (0.252, 2520), (60.0, 600000), *zip(rng.uniform(1e-3, 100, 20),
                                                                         rng.integers(1, 10**6, 20), strict=True)]:
        k = np.r_[0:min(n + 1, 5000), max(n - 5000, 0):n + 1]
        assert np.array_equal(frame_times(t_end, n, k), np.linspace(0.0, t_end, n + 1)[k])


@pytest.mark.parametrize("method", [RK4(), Bathe(), Cvodes()], ids=["rk4", "bathe", "cvodes"])
def test_a_run_returns_t_y_and_the_events_of_z_not_its_constants(method):
    """The discrete state's constant tail (a scene's parameters and settings) is the initial
    state's at every output, so a run does not store it (System.kept)."""
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 2), ca.SX.sym("z", 3), ca.SX.sym("u", 2)
    ode = ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], -z[1] * y[0] - z[2] * y[1])])
    disc = ca.Function("discrete", [t, y, z], [ca.vertcat(z[0] + (y[0] < 0), z[1], z[2])])
    sys_ = System(ode, disc, n_events=1)
    x0 = np.r_[0.0, 1.0, 0.0, 0.0, 25.0, 0.5]
    u_frames = np.c_[np.arange(40) * 0.05, np.arange(1, 41) * 0.05]
    states = method.run(sys_, x0, u_frames, 1e-3, 50, every=2).states
    assert sys_.kept == 4 and states.shape == (20, 4)
    assert np.all(np.isfinite(states)) and states[-1, 3] >= 1  # the event counter counted
