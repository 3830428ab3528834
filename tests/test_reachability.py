"""The reachability-analysis (TOPP-RA) solver of the time law (rrr4.optimal.reachability)
against references it does not compute itself: the phase-plane closed form of a double
integrator (with a redundant pair of actuators and a contact-like margin), scipy's HiGHS on
the 2-D programs and on the projection, and the convex program (IPOPT) on the reference scene."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog

import rrr4
from rrr4.errors import InfeasibleError, SceneError
from rrr4.optimal import optimal_time_law
from rrr4.optimal.reachability import lp2, point_rows, project_out, recover_alpha, time_optimal_speeds

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "problems" / "paper_circle.yaml"


@pytest.fixture(scope="module")
def paper():
    return rrr4.build(PAPER)


def duration(b, ds):
    sd = np.sqrt(b)
    return float(np.sum(2 * ds / (sd[:-1] + sd[1:])))


def pushed_mass(K, mass, L, f, m_alpha=True):
    """A mass moved along s in [0, 1] [m] by two forces u1 = m a / 2 + alpha, u2 = m a / 2 - alpha
    (alpha their internal force), |u_i| <= L, and the margin row alpha >= f / 2: F (K, 3, 4)."""
    row = np.array([[mass / 2 / L, 0.0, 1.0 / L, 0.0], [mass / 2 / L, 0.0, -1.0 / L, 0.0], [0.0, 0.0, 2.0 / f, 0.0]])
    F = np.broadcast_to(row if m_alpha else row[:2, [0, 1, 3]], (K,) + (row.shape if m_alpha else (2, 3))).copy()
    lo, hi = np.array([-1.0, -1.0, 1.0]), np.array([1.0, 1.0, np.inf])
    return F, (lo, hi) if m_alpha else (lo[:2], hi[:2])


@pytest.mark.parametrize("N", [8, 64, 400])
def test_double_integrator_with_a_redundant_pair_takes_the_phase_plane_time(N):
    """Rest to rest over 1 m with |m a| <= 2 L - f (the projection of the two limits and the
    margin): T = 2 sqrt(1 / A), A = (2 L - f) / m, exact for even N (the switch on a grid
    point); with s_dot <= V as well (V^2 < A): T = 1 / V + V / A, exact where V^2 / (2 A) is
    on the grid; alpha at the switch is exactly f / 2 (the margin at its largest there)."""
    mass, L, f = 2.0, 3.0, 2.0
    A = (2 * L - f) / mass
    F, (lo, hi) = pushed_mass(N + 1, mass, L, f)
    G, h, margin = point_rows(F, lo, hi, np.array([False, False, True]))
    G2, h2 = project_out(G, h)
    b, where = time_optimal_speeds(G2, h2, 1.0 / N, np.full(N + 1, 1e8), 0.0, 0.0)
    assert where == ""
    assert duration(b, 1.0 / N) == pytest.approx(2 / np.sqrt(A), rel=1e-9)
    a = np.diff(b) * N / 2
    assert np.allclose(np.abs(a), A, rtol=1e-9)                      # bang-bang
    V = 1.0                                                          # V^2 / (2 A) = 1/4: N a multiple of 4
    b, _ = time_optimal_speeds(G2, h2, 1.0 / N, np.full(N + 1, V**2), 0.0, 0.0)
    assert duration(b, 1.0 / N) == pytest.approx(1 / V + V / A, rel=1e-9)
    a = np.r_[np.diff(b) * N / 2, 0.0]
    rest = h - G[0] * a - G[1] * b
    alpha = recover_alpha(G[2:], rest, margin, np.zeros((N + 1, 1)))[:, 0]
    u1, u2 = mass * a / 2 + alpha, mass * a / 2 - alpha
    assert max(np.abs(u1).max(), np.abs(u2).max()) <= L * (1 + 1e-12) and alpha.min() >= f / 2 * (1 - 1e-12)
    # the largest margin inside the limits: alpha = L - m |a| / 2
    assert np.allclose(alpha, L - mass * np.abs(a) / 2, rtol=1e-12)


def test_vectorised_seidel_matches_highs_on_random_polygons():
    rng = np.random.default_rng(3)
    K, R = 300, 12
    G = rng.normal(size=(2, R, K))
    G /= np.sqrt((G * G).sum(axis=0))
    h = rng.normal(0.3, 1.0, (R, K))
    box = np.zeros((2, 4, K))
    box[0, 0], box[0, 1], box[1, 2], box[1, 3] = 1, -1, 1, -1
    Gb, hb = np.concatenate([box, G], axis=1), np.concatenate([np.full((4, K), 5.0), h])
    obj = rng.normal(size=(2, K))
    y = lp2(Gb, hb, obj, np.full((2, K), -5.0), np.full((2, K), 5.0))
    infeasible = 0
    for k in range(K):
        ref = linprog(-obj[:, k], A_ub=G[:, :, k].T, b_ub=h[:, k], bounds=[(-5, 5)] * 2, method="highs")
        if ref.status == 2:
            infeasible += 1
            assert np.isnan(y[:, k]).all()
        else:
            assert obj[:, k] @ y[:, k] == pytest.approx(-ref.fun, abs=1e-9)
            assert np.all(G[:, :, k].T @ y[:, k] <= h[:, k] + 1e-9)
    assert 0 < infeasible < K   # both cases met


def test_projection_keeps_exactly_the_points_some_alpha_meets(paper):
    """At random (a, b) of random grid points, the projected rows hold iff an LP (HiGHS) finds
    an alpha meeting every row of the reference scene with the contact condition."""
    from rrr4.optimal.time_law import time_law_functions
    _, F, lo, hi, _ = time_law_functions(paper, 20, sign=1)
    G, h, _ = point_rows(F, lo, hi, np.zeros(len(lo), bool))
    G2, h2 = project_out(G, h)
    rng = np.random.default_rng(5)
    agree = {True: 0, False: 0}
    for _ in range(200):
        k = rng.integers(0, 21)
        a, b = rng.normal(0, 60), rng.uniform(0, 12)
        projected = bool(np.all(G2[0, :, k] * a + G2[1, :, k] * b <= h2[:, k] + 1e-9))
        rest = h[:, k] - G[0, :, k] * a - G[1, :, k] * b
        res = linprog([0.0], A_ub=G[2:, :, k].T, b_ub=rest, bounds=[(None, None)], method="highs")
        margin = np.min(h2[:, k] - G2[0, :, k] * a - G2[1, :, k] * b)
        if abs(margin) > 1e-6:   # away from the boundary: the answers must agree
            assert projected == (res.status == 0)
            agree[projected] += 1
    assert agree[True] > 10 and agree[False] > 10


@pytest.mark.parametrize("contact", [True, False])
def test_pruning_to_the_polygon_edges_changes_nothing(paper, contact):
    """Every point's rows pruned to its polygon's edges give the same speeds as all the rows
    (and far fewer rows: at most 7 of 44 with the contact condition)."""
    from rrr4.optimal.reachability import prune
    from rrr4.optimal.time_law import time_law_functions
    N = 200
    _, F, lo, hi, _ = time_law_functions(paper, N, sign=1, contact=contact)
    G2, h2 = project_out(*point_rows(F, lo, hi, np.zeros(len(lo), bool))[:2])
    X = np.full(N + 1, 1e8)
    b = [time_optimal_speeds(G2, h2, 1.0 / N, X, 0.0, 0.0, prune_rows=p)[0] for p in (True, False)]
    assert np.allclose(b[0], b[1], rtol=1e-12, atol=1e-12 * b[1].max())
    assert prune(G2, h2, X, 1.0 / N)[1].shape[0] <= (7 if contact else G2.shape[1])


@pytest.fixture(scope="module")
def by_grid(paper):
    """Both solvers' durations (sign +1) on N = 100, 200, 400 and 1000 intervals."""
    return {(s, N): optimal_time_law(paper, points=N, sign=1, solver=s) for N in (100, 200, 400, 1000)
            for s in ("reachability", "convex")}


def test_both_solvers_converge_to_the_same_law_at_first_order(by_grid):
    """The reachability analysis holds each point with the accelerations of both its segments
    (an alpha per side), the convex program the same with one alpha: their durations agree
    within 1e-5 at every N (measured: -7e-7, 8.3e-6, 4.7e-6, 2.2e-6 relative at N = 100, 200,
    400, 1000; within 0.1 % at N = 1000 is the requirement), while each converges to the
    continuous law at first order (T_N - T_2N halves as N doubles: ratio 0.52 measured)."""
    T = {key: law.duration for key, law in by_grid.items()}
    for N in (100, 200, 400, 1000):
        assert T["reachability", N] == pytest.approx(T["convex", N], rel=1e-5)
    assert abs(T["reachability", 1000] / T["convex", 1000] - 1) < 1e-3
    for s in ("reachability", "convex"):
        ratio = (T[s, 200] - T[s, 400]) / (T[s, 100] - T[s, 200])
        assert 0.4 < ratio < 0.6


def test_collocation_scheme_converges_at_first_order_and_chatters(paper, by_grid):
    """TOPP-RA's collocation scheme (each point with the acceleration after it only) reaches the
    same law at first order (N x relative difference 0.33, 0.42, 0.45 measured at N = 100, 200,
    400) but its s_ddot jumps where the binding constraint changes (its total variation more
    than twice the convex program's), which is why the solver uses the interpolation scheme."""
    from rrr4.optimal.time_law import time_law_functions
    for N in (100, 200, 400):
        _, F, lo, hi, _ = time_law_functions(paper, N, sign=1)
        G2, h2 = project_out(*point_rows(F, lo, hi, np.zeros(len(lo), bool))[:2])
        b, _ = time_optimal_speeds(G2, h2, 1.0 / N, np.full(N + 1, 1e8), 0.0, 0.0, scheme="collocation")
        convex = by_grid["convex", N]
        assert 0.2 < N * (1 - duration(b, 1.0 / N) / convex.duration) < 0.6
    tv = [np.abs(np.diff(v)).sum() for v in (np.diff(b) * N / 2, convex.s_ddot[:-1])]
    assert tv[0] > 2 * tv[1]
    assert np.abs(np.diff(by_grid["reachability", 400].s_ddot[:-1])).sum() < 1.05 * tv[1]


def test_every_constraint_holds_at_every_grid_point(by_grid, paper):
    """The reachability law (as reported: each point with the acceleration of the segment
    after it, the last with the last segment's, and that side's alpha) within the limits and
    the contact condition at every point, its efforts the independent inverse dynamics of its
    motion."""
    law = by_grid["reachability", 1000]
    assert law.statistics["solver"] == "reachability" and law.statistics["success"]
    limits = np.asarray(law.torque_limit)
    assert np.all(np.abs(law.efforts) <= limits * (1 + 1e-9))
    assert law.axial.min() >= law.f_min * (1 - 1e-9)
    fam = paper.effort_family(law.pose, law.pose_d, law.pose_dd)
    tau = fam.tau_p + np.einsum("knm,km->kn", fam.tau_n, law.alpha)
    assert np.abs(tau - law.efforts).max() <= 1e-9 * np.abs(law.efforts).max()
    r = fam.r_p + np.einsum("kjcm,km->kjc", fam.r_n, law.alpha)
    assert np.allclose(r, law.reactions, atol=1e-9 * np.abs(r).max())
    assert sum(bool(b) for b in law.binding) > 0.9 * len(law.s)


@pytest.mark.parametrize("kwargs", [{"contact": False}, {"contact": False, "null_space": False}])
def test_limits_only_laws_agree_with_the_convex_program(paper, kwargs):
    laws = [optimal_time_law(paper, points=200, solver=s, **kwargs) for s in ("reachability", "convex")]
    assert laws[0].duration == pytest.approx(laws[1].duration, rel=1e-5)
    assert np.all(np.abs(laws[0].efforts) <= np.asarray(laws[0].torque_limit) * (1 + 1e-9))


@pytest.mark.parametrize("kwargs", [{"end_speeds": (1.0, 0.5)}, {"max_speed": 2.0}, {"max_task_speed": 0.2}])
def test_end_speeds_and_speed_bounds_agree_with_the_convex_program(paper, kwargs):
    laws = [optimal_time_law(paper, points=200, sign=1, solver=s, **kwargs) for s in ("reachability", "convex")]
    assert laws[0].duration == pytest.approx(laws[1].duration, rel=1e-4)
    ends = kwargs.get("end_speeds", (0.0, 0.0))
    assert laws[0].s_dot[[0, -1]] == pytest.approx(ends, abs=1e-12)
    assert laws[0].s_dot.max() <= kwargs.get("max_speed", np.inf) * (1 + 1e-12)
    speed = np.linalg.norm(laws[0].pose_d[:, :2], axis=1)
    assert speed.max() <= kwargs.get("max_task_speed", np.inf) * (1 + 1e-9)


def test_a_start_too_fast_to_stop_ends_in_one_line(paper):
    with pytest.raises(InfeasibleError, match=r"no law from s_dot 20 to 0 1/s keeps every constraint .sign .1.: "
                                              r"s_dot at s = 0 is too fast to reach the end") as e:
        optimal_time_law(paper, points=100, sign=1, end_speeds=(20.0, 0.0))
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("kwargs, words", [
    ({"solver": "fast"}, "solver: unknown value 'fast'"),
    ({"solver": "reachability", "objective": "time+effort"}, "solver: 'reachability' is not allowed here .it needs "
                                                             "the objective is 'time'"),
    ({"solver": "reachability", "max_task_acceleration": 5.0}, "needs no max_task_acceleration"),
])
def test_bad_solver_choices_end_in_one_line(paper, kwargs, words):
    with pytest.raises(SceneError, match=words) as e:
        optimal_time_law(paper, points=20, **kwargs)
    assert "\n" not in str(e.value)


def test_the_default_solver_is_the_reachability_for_time_and_the_convex_program_else(paper):
    assert optimal_time_law(paper, points=50).statistics["solver"] == "reachability"
    assert optimal_time_law(paper, points=50, max_task_acceleration=50.0).statistics["solver"] == "ipopt"
