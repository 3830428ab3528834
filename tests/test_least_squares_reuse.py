"""Levenberg-Marquardt with the Jacobian reused (rrr4.identify.least_squares, reuse 'exact' and
'differences': Broyden's update between refreshes, fun's exact Jacobian at the estimate), held to
references it does not compute: a minimum known in closed form (noise-free data, Rosenbrock's
valley) and MINPACK's Levenberg-Marquardt (scipy.optimize.least_squares) on noisy data, with and
without an active bound."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from rrr4.identify.least_squares import covariance, levenberg_marquardt

T = np.linspace(0.0, 4.0, 60)
TRUTH = np.array([2.0, 1.3, 0.5])
SIGMA = 0.01


class Decay:
    """y = a exp(-b t) + c, whitened by SIGMA; counts its evaluations with and without Jacobian."""

    def __init__(self, y):
        self.y, self.calls = y, {True: 0, False: 0}

    def residuals(self, u):
        a, b, c = u
        return (a * np.exp(-b * T) + c - self.y) / SIGMA

    def jacobian(self, u):
        a, b, _ = u
        e = np.exp(-b * T)
        return np.column_stack([e, -a * T * e, np.ones_like(T)]) / SIGMA

    def __call__(self, u, jacobian):
        self.calls[bool(jacobian)] += 1
        return self.residuals(u), (self.jacobian(u) if jacobian else None)


def _noisy(seed=0):
    y = TRUTH[0] * np.exp(-TRUTH[1] * T) + TRUTH[2]
    return y + SIGMA * np.random.default_rng(seed).standard_normal(T.size)


LOWER, UPPER = np.full(3, -10.0), np.full(3, 10.0)
START = np.array([1.0, 0.5, 0.0])


@pytest.mark.parametrize("reuse", ["exact", "differences"])
def test_reuse_reaches_a_known_minimum_with_fewer_jacobians_and_returns_the_exact_one(reuse):
    """Noise-free data: the minimum is the truth (cost 0). Plain LM and LM with reuse reach it;
    with reuse the Jacobian is asked fewer times, and the one returned is the exact (analytic)
    Jacobian at the estimate returned, not a carried one."""
    y = TRUTH[0] * np.exp(-TRUTH[1] * T) + TRUTH[2]
    plain, reused = Decay(y), Decay(y)
    u0, *_, ok0 = levenberg_marquardt(plain, START, LOWER, UPPER)
    u, r, J, _, ok = levenberg_marquardt(reused, START, LOWER, UPPER, reuse=reuse)
    assert ok0 and ok
    np.testing.assert_allclose(u0, TRUTH, atol=1e-7)
    np.testing.assert_allclose(u, TRUTH, atol=1e-7)
    np.testing.assert_array_equal(J, reused.jacobian(u))
    np.testing.assert_array_equal(r, reused.residuals(u))
    assert reused.calls[True] < plain.calls[True], (reused.calls, plain.calls)


@pytest.mark.parametrize("reuse", [None, "exact", "differences"])
@pytest.mark.parametrize("bounded", [False, True])
def test_reuse_agrees_with_minpack_on_noisy_data(reuse, bounded):
    """Noisy data (nonzero residual at the minimum), with and without the upper bound of c below
    its estimate (then active): the estimate within 1e-3 standard errors of scipy's (MINPACK
    'lm' unbounded, 'trf' bounded, both to tight tolerances), the standard errors from the J
    returned within 1e-6 of those from the analytic Jacobian at it."""
    f = Decay(_noisy())
    upper = UPPER.copy()
    if bounded:
        upper[2] = 0.49
    ref = least_squares(f.residuals, START, jac=f.jacobian, method="trf" if bounded else "lm",
                        bounds=(LOWER, upper) if bounded else (-np.inf, np.inf), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    u, r, J, _, ok = levenberg_marquardt(f, START, LOWER, upper, reuse=reuse)
    assert ok
    se = covariance(f.jacobian(ref.x), f.residuals(ref.x), np.ones(3))["standard_error"]
    assert np.all(np.abs(u - ref.x) < 1e-3 * se), ((u - ref.x) / se, reuse)
    if bounded:
        assert u[2] == upper[2]
    np.testing.assert_allclose(covariance(J, r, np.ones(3))["standard_error"],
                               covariance(f.jacobian(u), r, np.ones(3))["standard_error"], rtol=1e-6)


@pytest.mark.parametrize("reuse", ["exact", "differences"])
def test_reuse_follows_rosenbrocks_valley_to_its_minimum(reuse):
    """r = (10 (u2 - u1^2), 1 - u1): the curved valley where the linear model fails along the
    way (refreshes), minimum (1, 1) with cost 0."""
    calls = {True: 0, False: 0}

    def fun(u, jacobian):
        calls[bool(jacobian)] += 1
        r = np.array([10.0 * (u[1] - u[0] ** 2), 1.0 - u[0]])
        return r, (np.array([[-20.0 * u[0], 10.0], [-1.0, 0.0]]) if jacobian else None)

    u, r, J, _, ok = levenberg_marquardt(fun, [-1.2, 1.0], np.full(2, -5.0), np.full(2, 5.0), max_iter=200,
                                         reuse=reuse)
    assert ok and calls[True] >= 1
    np.testing.assert_allclose(u, [1.0, 1.0], atol=1e-6)
    np.testing.assert_array_equal(J, fun(u, True)[1])


@pytest.mark.parametrize("bounded", [False, True])
def test_a_batch_of_residuals_gives_the_fit_of_single_calls(bounded):
    """Refreshes by differences through `batch` (all points of a refresh in one call, as
    DynamicData.residuals_batch rolls runs together): the same fit, bit for bit, as fun's
    residuals one at a time, and every residual of a refresh asked through the batch (one call
    of p points per refresh, none of them through fun)."""
    upper = UPPER.copy()
    if bounded:
        upper[2] = 0.49  # active at the estimate: the differences there step backwards
    single, batched = Decay(_noisy()), Decay(_noisy())
    sizes = []

    def batch(U):
        sizes.append(len(U))
        return [batched.residuals(v) for v in U]

    u0, r0, J0, it0, ok0 = levenberg_marquardt(single, START, LOWER, upper, reuse="differences")
    u, r, J, it, ok = levenberg_marquardt(batched, START, LOWER, upper, reuse="differences", batch=batch)
    assert ok0 and ok and it == it0
    for a, b in ((u, u0), (r, r0), (J, J0)):
        np.testing.assert_array_equal(a, b)
    assert sizes and set(sizes) == {3}
    assert batched.calls[False] + 3 * len(sizes) == single.calls[False]


@pytest.mark.parametrize("reuse", [None, "differences"])
def test_a_minimum_at_a_kink_is_converged_where_the_remaining_step_is_a_quarter_of_a_standard_error(reuse):
    """chi^2 = sum (u - y_i)^2 + (1 + e |u - ybar|)^2: a V-shaped minimum at u = ybar, where every
    step raises the cost and the gradient is e, not zero; started there, the fit stays there.
    With e = 0.01 the exact Jacobian's Gauss-Newton step is 1e-3 of a standard error (0.25 of
    one is the limit): converged; with e = 5 it is 0.45 of one: the same minimum, reported not
    converged (the linear model behind the intervals fails there)."""
    y = np.random.default_rng(3).standard_normal(100)
    for e, expected in ((0.01, True), (5.0, False)):
        def fun(u, jacobian, e=e):
            d = u[0] - y.mean()
            r = np.r_[u[0] - y, 1.0 + e * abs(d)]
            return r, (np.r_[np.ones(y.size), e * (1.0 if d >= 0 else -1.0)][:, None] if jacobian else None)

        u, r, J, it, converged = levenberg_marquardt(fun, np.array([y.mean()]), np.array([-5.0]), np.array([5.0]),
                                                     reuse=reuse)
        assert converged is expected and abs(u[0] - y.mean()) < 1e-3, (e, u, it, converged)
