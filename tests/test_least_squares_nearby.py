"""A converged fit moved on to a lower minimum within its standard errors
(rrr4.identify.least_squares.lowest_nearby), held to a reference it does not compute: the
global minimum of a one-dimensional profile on a fine grid (the second coordinate, linear, in
closed form at each point), on a model whose cost is wavy on the scale of its standard error;
a minimum less than NEARBY_GAIN s^2 above the global one, and the minimum of a linear model,
are left alone (the latter after one batch of probes)."""

from __future__ import annotations

import numpy as np

from rrr4.identify.least_squares import NEARBY_GAIN, covariance, levenberg_marquardt, lowest_nearby

T = np.linspace(-1.0, 1.0, 40)
LOWER, UPPER = np.full(2, -5.0), np.full(2, 5.0)


class Wavy:
    """y = a + b t + amp sin(30 a) t^2 with unit noise: with amp 0.03 the cost along a has
    local minima about a standard error apart, of nearly the same depth (amp 0: linear)."""

    def __init__(self, amp: float):
        self.amp = amp
        self.y = self.model(np.zeros(2)) + np.random.default_rng(0).standard_normal(T.size)

    def model(self, u):
        return u[0] + u[1] * T + self.amp * np.sin(30.0 * u[0]) * T ** 2

    def __call__(self, u, jacobian):
        r = self.model(u) - self.y
        return r, (np.column_stack([1 + 30.0 * self.amp * np.cos(30.0 * u[0]) * T ** 2, T]) if jacobian else None)

    def batch(self, U):
        return [self(v, False)[0] for v in U]

    def profile_minimum(self):
        """The global minimum of chi^2 over a on a grid of 1e-4 (b at its closed-form best)."""
        a = np.linspace(-1.0, 1.0, 20001)
        rest = self.y[None, :] - a[:, None] - self.amp * np.sin(30.0 * a)[:, None] * T ** 2
        b = rest @ T / (T @ T)
        chi2 = np.sum((rest - b[:, None] * T) ** 2, axis=1)
        return a[np.argmin(chi2)], float(np.min(chi2))


def _fit(f):
    return lambda v: levenberg_marquardt(f, v, LOWER, UPPER, reuse="differences", batch=f.batch)


def test_a_local_minimum_well_above_the_global_one_is_left_for_it():
    """With amp 0.08 Levenberg-Marquardt from a = -0.3 stops in a local minimum 2.7 of chi^2
    (3.8 s^2) above the global one, about one standard error away; lowest_nearby ends at the
    grid's minimum (to its spacing), with fun's exact Jacobian there."""
    f = Wavy(0.08)
    a_ref, chi2_ref = f.profile_minimum()
    u, r, J, _, ok = _fit(f)(np.array([-0.3, 0.3]))
    se = covariance(J, r, np.ones(2))["standard_error"][0]
    s2 = r @ r / (r.size - 2)
    assert ok and r @ r > chi2_ref + 2 * NEARBY_GAIN * s2 and abs(u[0] - a_ref) < 2 * se, (u, r @ r, chi2_ref, se)
    u, r, J, _, converged, fits, _ = lowest_nearby(_fit(f), f.batch, u, r, J, LOWER, UPPER)
    assert converged and fits >= 1
    assert abs(u[0] - a_ref) < 2e-4 and abs(r @ r - chi2_ref) < 1e-4, (u, a_ref, r @ r, chi2_ref)
    np.testing.assert_array_equal(J, f(u, True)[1])


def test_a_local_minimum_within_the_gain_of_the_global_one_is_kept():
    """With amp 0.03 the fit from a = 0.5 stops 0.09 of chi^2 above the global minimum, 1.2
    standard errors away: as good an estimate (less than NEARBY_GAIN s^2 lower), so no fit is
    run and it comes back as it was."""
    f = Wavy(0.03)
    _, chi2_ref = f.profile_minimum()
    u, r, J, _, ok = _fit(f)(np.array([0.5, 0.3]))
    assert ok and chi2_ref + 0.05 < r @ r < chi2_ref + NEARBY_GAIN * r @ r / (r.size - 2), (r @ r, chi2_ref)
    out = lowest_nearby(_fit(f), f.batch, u, r, J, LOWER, UPPER)
    assert out[3:6] == (0, None, 0)
    np.testing.assert_array_equal(out[0], u)


def test_on_a_quadratic_cost_the_estimate_is_left_alone_after_one_batch_of_probes():
    """A linear model: chi^2 one standard error out along each principal axis, both ways, is
    s^2 above the minimum (quadratic): those four probes in one batch and no more, no fit is run,
    the estimate comes back bit for bit."""
    f = Wavy(0.0)
    sizes = []

    def batch(U):
        sizes.append(len(U))
        return f.batch(U)

    u, r, J, _, ok = _fit(f)(np.array([0.5, 0.3]))
    out = lowest_nearby(_fit(f), batch, u, r, J, LOWER, UPPER)
    assert ok and out[3:6] == (0, None, 0)
    for a, b in zip(out[:3], (u, r, J), strict=True):
        np.testing.assert_array_equal(a, b)
    assert sizes == [2 * 2]
