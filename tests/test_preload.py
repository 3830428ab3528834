"""Preload layer: exact, QP and NLP methods on the reference scene and on hard cases."""

import warnings
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from rrr4 import PreloadSolution, build, solve_preload
from rrr4.preload import PreloadInfeasibleError, PreloadWarning, exact_preload_function, qp_preload_function
from rrr4.preload import qp as qp_module
from rrr4.scene import parse_scene

RATE = 250.0  # Hz: fewer samples than the scene's 1 kHz keep the NLP quick


def _with(scene, **preload):
    limit = preload.pop("torque_limit", None)
    act = replace(scene.actuation, preload=replace(scene.actuation.preload, **preload))
    if limit is not None:
        scene = scene.with_torque_limit(limit)
    return replace(scene, actuation=act)


@pytest.fixture(scope="module")
def solutions(paper_scene):
    return {m: solve_preload(paper_scene, m, sample_rate=RATE) for m in ("exact", "qp", "nlp")}


def _scan_optimum(tau_p, tau_n, r_p, r_n, f_min, limits, weights, span=30.0, k=600001, signed=0):
    """Brute force: the least weighted effort over a dense alpha grid, or None if no grid point is feasible.
    signed = +1 / -1 scans alpha >= 0 / <= 0 only."""
    a = np.linspace(-span, span, k) if signed == 0 else signed * np.linspace(0.0, span, k // 2 + 1)
    tau = tau_p[:, None] + a * tau_n[:, None]
    r = r_p[:, :, None] + a * r_n[:, :, None]
    ok = (np.linalg.norm(r, axis=0).min(axis=0) >= f_min) & np.all(np.abs(tau) <= np.asarray(limits)[:, None], axis=0)
    if not ok.any():
        return None
    cost = np.where(ok, np.asarray(weights) @ tau**2, np.inf)
    return a[np.argmin(cost)], cost.min(), abs(a[1] - a[0])


@pytest.mark.filterwarnings("ignore::rrr4.preload.PreloadWarning")
@pytest.mark.parametrize("limit", [5.0, 3.3])
def test_exact_is_the_global_optimum_of_a_dense_alpha_scan(paper_scene, limit):
    """At sampled instants the closed form's effort equals the dense-scan minimum (to the
    grid's resolution) and never exceeds it; tight limits make the feasible set a union of
    disjoint intervals."""
    scene = _with(paper_scene, weights=(1.0, 2.0, 0.5, 1.5), torque_limit=limit)
    sol = solve_preload(scene, "exact", sample_rate=50.0)
    f = exact_preload_function(build(scene))
    w, f_min = scene.actuation.preload.weights, scene.actuation.preload.min_force
    checked = 0
    for k in range(0, len(sol.t), 5):
        tau_p, tau_n = sol.tau_particular[k], sol.null_space[k]
        r_p = (sol.reactions[k] - sol.alpha[k] * _null_reactions(sol, k)).T
        r_n = _null_reactions(sol, k).T
        alpha, tau, feas, _ = (np.array(v).ravel() for v in f(tau_p, tau_n, r_p, r_n))
        scan = _scan_optimum(tau_p, tau_n, r_p, r_n, f_min, scene.torque_limit, w)
        if scan is None:
            assert feas[0] == 0.0
            continue
        a_scan, c_scan, da = scan
        cost = float(np.dot(w, tau**2))
        assert feas[0] == 1.0
        assert cost <= c_scan + 1e-9
        slope = 2 * abs(np.dot(w, tau * tau_n)) + 2 * np.dot(w, tau_n**2) * da
        assert c_scan - cost <= slope * da + 1e-9
        checked += 1
    assert checked >= 5


def _null_reactions(sol: PreloadSolution, k: int) -> np.ndarray:
    """r_n (8, 2) at sample k from the inverse dynamics (the solution stores the sum)."""
    f = build(_null_reactions.scene).inverse_dynamics()
    return np.array(f(sol.pose[k], sol.pose_d[k], sol.pose_dd[k])[3]).T


@pytest.fixture(autouse=True)
def _scene_for_helper(paper_scene):
    _null_reactions.scene = paper_scene


def test_methods_differ_only_along_the_null_space(solutions):
    """tau_a - tau_b is parallel to the null-space direction for every pair of methods."""
    ref = solutions["exact"]
    for other in ("qp", "nlp"):
        d = solutions[other].tau - ref.tau
        along = np.einsum("ki,ki->k", d, ref.null_space)[:, None] * ref.null_space
        assert np.max(np.abs(d - along)) < 1e-10
        assert np.max(np.abs(d)) > 1e-3  # they do differ


def test_every_passive_reaction_is_at_least_f_min_where_feasible(solutions, paper_scene):
    f_min = paper_scene.actuation.preload.min_force
    for sol in solutions.values():
        assert sol.all_feasible
        mags = sol.reaction_magnitudes[sol.feasible]
        assert mags.min() >= f_min * (1 - 1e-6)
        assert np.all(np.abs(sol.tau) <= np.asarray(sol.torque_limit) * (1 + 1e-6))


def test_nlp_torques_are_smoother_than_pointwise_ones(solutions):
    """Roughness = RMS d^2 tau/dt^2; the exact method jumps between the +-alpha branches."""
    r = {m: s.roughness for m, s in solutions.items()}
    assert r["nlp"] < 0.5 * r["qp"]
    assert r["qp"] < r["exact"]


def test_nlp_bounds_the_turn_rate_of_every_contact_force(solutions, paper_scene):
    sol = solutions["nlp"]
    omega = paper_scene.actuation.preload.max_turn_rate
    ang = np.angle(sol.reactions[..., 0] + 1j * sol.reactions[..., 1])
    turn = np.abs(np.angle(np.exp(1j * np.diff(ang, axis=0))))
    assert np.max(turn) <= omega * np.diff(sol.t)[0] * (1 + 1e-5)


def test_qp_keeps_the_sign_of_each_axial_link_force(solutions, paper_scene):
    """The component of r_j along the following link has one sign over the whole path, >= f_min."""
    sol = solutions["qp"]
    sign = sol.statistics["signs"]
    axial = []
    for k in range(len(sol.t)):
        r_n = _null_reactions(sol, k)
        d = r_n / np.linalg.norm(r_n, axis=1, keepdims=True)
        axial.append(sign * np.einsum("jc,jc->j", d, sol.reactions[k]))
    assert np.min(axial) >= paper_scene.actuation.preload.min_force * (1 - 1e-6)


@pytest.mark.parametrize("solver", ["osqp", "daqp", "qpoases"])
def test_qp_plugins_agree_with_qrqp(paper_scene, solver):
    ref = solve_preload(paper_scene, "qp", sample_rate=100.0, signs=1.0)
    other = solve_preload(paper_scene, "qp", sample_rate=100.0, signs=1.0, qp_solver=solver)
    assert np.max(np.abs(other.alpha - ref.alpha)) < 1e-6


def test_qp_extends_to_two_degrees_of_redundancy():
    """With m = 2 null-space parameters the QP optimum matches a dense 2-D scan
    (synthetic 5-actuator data: the formulation only needs tau_n (n, m) and r_n)."""
    rng = np.random.default_rng(7)
    n, m, f_min = 5, 2, 2.0
    tau_n = np.linalg.qr(rng.normal(size=(n, m)))[0]
    tau_p = rng.normal(size=n)
    e = rng.normal(size=(2, 2 * n))
    e /= np.linalg.norm(e, axis=0)
    s = rng.uniform(0.5, 2.0, size=(2 * n, m))  # axial null-space forces along each link
    r_n = np.hstack([e * s[:, k] for k in range(m)])
    r_p = rng.normal(size=(2, 2 * n))
    # the QP builder itself (private on purpose): a Problem with two degrees of redundancy would
    # need a whole mechanism, and the formulation only sees tau_n and r_n
    f = qp_module._build("daqp", f_min, (1.0,) * n, (10.0,) * n, (1.0,) * (2 * n), m)
    alpha, tau, feas, _ = (np.array(v).ravel() for v in f(tau_p, tau_n, r_p, r_n))
    assert feas[0] == 1.0
    g = np.linspace(-8, 8, 801)
    A1, A2 = np.meshgrid(g, g, indexing="ij")
    al = np.stack([A1.ravel(), A2.ravel()])
    axial = np.einsum("cj,cjp->jp", e, r_p[:, :, None] + r_n[:, :2 * n, None] * al[0] + r_n[:, 2 * n:, None] * al[1])
    taus = tau_p[:, None] + tau_n @ al
    ok = (axial.min(axis=0) >= f_min) & (np.abs(taus).max(axis=0) <= 10.0)
    best = np.min(np.sum(taus**2, axis=0)[ok])
    assert np.sum(tau**2) <= best + 1e-9
    assert best - np.sum(tau**2) < 0.05 * best


def test_too_tight_torque_limits_are_reported_with_time_and_joint(paper_scene):
    scene = _with(paper_scene, torque_limit=0.5)
    for method in ("exact", "qp"):
        with pytest.warns(PreloadWarning, match="INFEASIBLE"):
            sol = solve_preload(scene, method, sample_rate=50.0)
        assert not sol.feasible.any()
        assert {i.joint for i in sol.infeasible} & set(sol.joint_names)
        assert set(np.round([i.t for i in sol.infeasible], 9)) == set(np.round(sol.t, 9))
        assert np.all(np.isfinite(sol.tau)) and np.all(np.isfinite(sol.reactions))
    with pytest.raises(PreloadInfeasibleError, match="f_min"):
        solve_preload(scene, "exact", sample_rate=50.0, strict=True)


def test_unreachable_pose_is_reported_not_returned_as_numbers(paper_data):
    """A path leaving the workspace (scene check skipped) gives 'pose' entries, finite output."""
    paper_data["path"]["radius"] = 0.4
    scene = parse_scene(paper_data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PreloadWarning)
        sol = solve_preload(scene, "exact", sample_rate=20.0)
    bad = [i for i in sol.infeasible if i.joint == "pose"]
    assert bad and not sol.all_feasible
    assert np.all(np.isfinite(sol.tau))
    assert "pose" in sol.report()


def test_exact_preload_is_a_pure_sx_function(paper_scene):
    """Code-generable: an SX Function without free symbols or embedded solver calls."""
    f = exact_preload_function(build(paper_scene))
    assert f.is_a("SXFunction") and not f.has_free()
    assert f.name_in() == ["tau_p", "tau_n", "r_p", "r_n"] and f.name_out() == ["alpha", "tau", "feasible", "margin"]
    q = qp_preload_function(build(paper_scene))
    assert q.name_out()[:2] == ["alpha", "tau"]
    assert isinstance(q, ca.Function)


def test_torque_interpolant_reproduces_the_samples(solutions):
    sol = solutions["qp"]
    f = sol.torque_interpolant()
    k = len(sol.t) // 3
    assert np.allclose(np.array(f(sol.t[k])).ravel(), sol.tau[k])


def test_exact_on_one_branch_stays_on_it_and_never_beats_the_global_optimum(paper_scene):
    """branch='auto' keeps one sign of alpha (no force reversal); per sample its effort is
    >= the unrestricted global optimum's, and it is far smoother."""
    glob = solve_preload(paper_scene, "exact", sample_rate=RATE)
    one = solve_preload(paper_scene, "exact", sample_rate=RATE, branch="auto")
    assert one.all_feasible and one.statistics["branch"] in (1, -1)
    assert np.all(one.statistics["branch"] * one.alpha >= 0)
    assert np.all(np.sum(one.tau**2, axis=1) >= np.sum(glob.tau**2, axis=1) - 1e-9)
    assert one.roughness < 0.01 * glob.roughness


def _enumerated_optimum(tau_p, tau_n, r_p, r_n, f_min, limits, weights, branch):
    """Reference law by enumeration: every candidate (box ends, clipped effort minimiser,
    every root of ||r_j(alpha)|| = f_min) checked against all constraints in numpy; the
    least-effort feasible one, or None. Independent of the interval pushes of the law."""
    lim = np.asarray(limits)
    with np.errstate(divide="ignore", invalid="ignore"):
        ends = np.stack([(-lim - tau_p) / tau_n, (lim - tau_p) / tau_n])
    lo, hi = np.max(np.min(ends, axis=0)), np.min(np.max(ends, axis=0))
    lo, hi = (max(lo, 0.0), hi) if branch > 0 else (lo, min(hi, 0.0)) if branch < 0 else (lo, hi)
    w = np.asarray(weights)
    free = -np.dot(w, tau_p * tau_n) / np.dot(w, tau_n**2)
    a, b = np.sum(r_n**2, axis=0), 2 * np.sum(r_p * r_n, axis=0)
    c = np.sum(r_p**2, axis=0) - f_min**2
    disc = b**2 - 4 * a * c
    ok = (a > 0) & (disc >= 0)
    roots = np.r_[(-b[ok] - np.sqrt(disc[ok])) / (2 * a[ok]), (-b[ok] + np.sqrt(disc[ok])) / (2 * a[ok])]
    best = None
    for x in np.r_[lo, hi, np.clip(free, lo, hi), roots]:
        x = x + 1e-9 * (1 + abs(x)) * np.sign(x - free)  # a hair off the boundary, away from the minimiser
        tau, r = tau_p + x * tau_n, r_p + x * r_n
        if (lo <= x <= hi and np.all(np.linalg.norm(r, axis=0) >= f_min) and np.all(np.abs(tau) <= lim)
                and (best is None or np.dot(w, tau**2) < best[1])):
            best = (x, np.dot(w, tau**2))
    return best


def _random_families(rng, k):
    """k random affine families (tau_p, tau_n unit, r_p, r_n); a few joints without null-space reaction."""
    for _ in range(k):
        tau_n = rng.normal(size=4)
        r_n = rng.normal(scale=8.0, size=(2, 8))
        r_n[:, rng.random(8) < 0.05] = 0.0
        yield rng.normal(scale=2.0, size=4), tau_n / np.linalg.norm(tau_n), rng.normal(scale=15.0, size=(2, 8)), r_n


@pytest.mark.parametrize("branch", [0, 1, -1])
@pytest.mark.parametrize("limit", [5.0, 2.5])
def test_exact_equals_the_enumerated_optimum_on_random_families(paper_scene, branch, limit):
    """On many random families (disjoint feasible intervals, flat joints, infeasible cases)
    the closed form is feasible exactly when some candidate is, with the same effort; when
    it is infeasible alpha stays on the branch and the torques within the limits if the
    branch allows it."""
    scene = _with(paper_scene, weights=(1.0, 2.0, 0.5, 1.5), torque_limit=limit)
    f = exact_preload_function(build(scene), branch=branch)
    w, f_min = scene.actuation.preload.weights, scene.actuation.preload.min_force
    counts = {"feasible": 0, "infeasible": 0}
    for tau_p, tau_n, r_p, r_n in _random_families(np.random.default_rng(11 + branch), 400):
        alpha, tau, feas, margin = (np.array(v).ravel() for v in f(tau_p, tau_n, r_p, r_n))
        ref = _enumerated_optimum(tau_p, tau_n, r_p, r_n, f_min, (limit,) * 4, w, branch)
        assert branch * alpha[0] >= 0
        np.testing.assert_allclose(tau, tau_p + alpha[0] * tau_n, rtol=1e-12, atol=1e-12)
        r = r_p + alpha[0] * r_n
        assert margin[0] == pytest.approx(np.linalg.norm(r, axis=0).min() - f_min, abs=1e-9)
        if ref is None:
            assert feas[0] == 0.0
            counts["infeasible"] += 1
            continue
        counts["feasible"] += 1
        assert feas[0] == 1.0
        assert margin[0] >= -1e-9 and np.all(np.abs(tau) <= limit * (1 + 1e-12))
        cost = np.dot(w, tau**2)
        assert cost <= ref[1] + 1e-9 * (1 + ref[1])
        assert cost >= ref[1] - 1e-6 * (1 + ref[1])  # ref sits 1e-9 (relative) inside the feasible set
    assert min(counts.values()) >= 20, counts


@pytest.mark.filterwarnings("ignore::rrr4.preload.PreloadWarning")
@pytest.mark.parametrize("branch", [1, -1])
def test_exact_on_a_branch_is_the_optimum_of_a_dense_scan_of_that_branch(paper_scene, branch):
    """Along the path with tight limits: effort equal to the least over a dense scan of
    alpha restricted to the branch's sign."""
    scene = _with(paper_scene, weights=(1.0, 2.0, 0.5, 1.5), torque_limit=3.3)
    sol = solve_preload(scene, "exact", sample_rate=50.0, branch=branch)
    f = exact_preload_function(build(scene), branch=branch)
    w, f_min = scene.actuation.preload.weights, scene.actuation.preload.min_force
    checked = 0
    for k in range(0, len(sol.t), 5):
        r_n = _null_reactions(sol, k).T
        tau_p, tau_n, r_p = sol.tau_particular[k], sol.null_space[k], (sol.reactions[k]).T - sol.alpha[k] * r_n
        alpha, tau, feas, _ = (np.array(v).ravel() for v in f(tau_p, tau_n, r_p, r_n))
        scan = _scan_optimum(tau_p, tau_n, r_p, r_n, f_min, scene.torque_limit, w, signed=branch)
        if scan is None:
            assert feas[0] == 0.0
            continue
        _, c_scan, da = scan
        cost = float(np.dot(w, tau**2))
        assert feas[0] == 1.0 and branch * alpha[0] >= 0
        assert cost <= c_scan + 1e-9
        assert c_scan - cost <= (2 * abs(np.dot(w, tau * tau_n)) + 2 * np.dot(w, tau_n**2) * da) * da + 1e-9
        checked += 1
    assert checked >= 5


def test_the_sign_choice_and_mechanism_are_shared_by_problems_that_differ_only_in_clearance(paper_scene):
    """The preload's sign choice (a scan of the path) and the kinematic mechanism are built
    once per preload structure (Problem.preload_key): a scene that differs only in its
    clearances, contact numbers or gains shares them; f_min, gravity and the limits do not."""
    from rrr4.preload import choose_signs, preload_sign
    from rrr4.trajectory import sample_path
    a = build(paper_scene)
    joints = tuple(replace(j, radial_clearance=j.radial_clearance * 1.7) if j.clearance else j
                   for j in paper_scene.graph.joints)
    other = replace(paper_scene, name="other", graph=replace(paper_scene.graph, joints=joints),
                    effects=replace(paper_scene.effects, contact=replace(paper_scene.effects.contact, damping=0.3)),
                    actuation=replace(paper_scene.actuation, kp=2 * paper_scene.actuation.kp))
    b = build(other)
    assert b is not a and b.contact_parameters.tolist() != a.contact_parameters.tolist()
    assert b.structure("preload") is a.structure("preload") and b.mechanism is a.mechanism
    for changed in (_with(paper_scene, min_force=2 * paper_scene.actuation.preload.min_force),
                    replace(paper_scene, effects=replace(paper_scene.effects, gravity=(0.0, -9.81))),
                    replace(paper_scene, graph=replace(paper_scene.graph, actuators=tuple(
                        replace(x, limit=0.5 * x.limit) for x in paper_scene.graph.actuators)))):
        assert build(changed).structure("preload") is not a.structure("preload")
    # the shared sign is the one chosen on the problem's own path and effort family
    s = sample_path(b.path)
    own = choose_signs(b, b.effort_family(s.pose, s.pose_d, s.pose_dd).raw, b.scene.actuation.preload.qp_solver,
                       exact=b.scene.actuation.preload.method == "exact")[0]
    assert preload_sign(b) == preload_sign(a) == int(own)
