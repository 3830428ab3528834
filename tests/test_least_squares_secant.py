"""The secant correction of the covariance (rrr4.identify.least_squares.secant) from
lowest_nearby's probes, held to a reference it does not compute: the profile-likelihood 95 %
interval (the Delta chi^2 = Z95^2 s^2 crossing) of a two-parameter model on a fine grid, the
second parameter linear and profiled out in closed form at each point. The model's response
bends over on a quarter of its standard error to half its slope (the five-bar's B - C
difference bends over on ~1 um, its standard error ~2 um): chi^2 along it rises more slowly
than the linearised covariance says, and the secant interval is much closer to the profile's
than the linear one. A linear model is left as it is, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from rrr4.identify.least_squares import (NEARBY_QUADRATIC, SECANT_FLOOR, Z95, covariance, levenberg_marquardt,
                                         lowest_nearby, secant)

T = np.linspace(-1.0, 1.0, 60)
G = np.cos(2.0 * T) + 0.5 * T  # a's response shape, correlated with b's (T)
LOWER, UPPER = np.full(2, -50.0), np.full(2, 50.0)


class Bent:
    """y = b T + c f(a) G with unit noise, f(a) = k a + (1 - k) w tanh(a / w): slope 1 at a = 0,
    k beyond w (k 1: linear). The noise is made orthogonal to T and G: the estimate is the truth
    (a = b = 0, where the response bends), chi^2 there about M - 2."""

    def __init__(self, k: float, w: float = 0.2, c: float = 0.15, seed: int = 0):
        self.k, self.w, self.c = k, w, c
        noise = np.random.default_rng(seed).standard_normal(T.size)
        q = np.linalg.qr(np.column_stack([T, G]))[0]
        self.y = self.model(np.zeros(2)) + noise - q @ (q.T @ noise)

    def f(self, a):
        return self.k * a + (1.0 - self.k) * self.w * np.tanh(a / self.w)

    def model(self, u):
        return u[1] * T + self.c * self.f(u[0]) * G

    def __call__(self, u, jacobian):
        r = self.model(u) - self.y
        if not jacobian:
            return r, None
        fa = self.k + (1.0 - self.k) * (1.0 - np.tanh(u[0] / self.w) ** 2)
        return r, np.column_stack([self.c * fa * G, T])

    def batch(self, U):
        return [self(v, False)[0] for v in U]

    def profile(self, a_hat, chi2_hat, threshold):
        """The 95 % interval of a: where min over b of chi^2 (closed form) minus chi2_hat crosses
        `threshold`, on a grid of 2e-4 each side of a_hat."""
        a = np.arange(-10.0, 10.0, 2e-4)
        rest = self.y[None, :] - self.c * self.f(a)[:, None] * G
        b = rest @ T / (T @ T)
        rise = np.sum((rest - b[:, None] * T) ** 2, axis=1) - chi2_hat
        low, high = a[(a < a_hat) & (rise <= threshold)], a[(a > a_hat) & (rise <= threshold)]
        return low.min(), high.max()


def _fitted(f, start=(0.3, 0.1)):
    fit = lambda v: levenberg_marquardt(f, v, LOWER, UPPER, reuse="differences", batch=f.batch)  # noqa: E731
    u, r, J, _, _ = fit(np.array(start))
    u, r, J, _, _, fits, rises = lowest_nearby(fit, f.batch, u, r, J, LOWER, UPPER)
    return u, r, J, rises


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_secant_interval_is_much_closer_to_the_profile_than_the_linear_one(seed):
    """Bent by k = 0.5 on w = 0.2 (a's linear standard error 1.2 to 1.5, six times w): chi^2 at one
    standard error along the axis mostly a is 0.37 to 0.38 of its linear model's s^2; the secant
    widens that axis's variance by 1 / rho, never narrows one, and a's 95 % interval moves from
    the linear one (its ends 0.24 of the profile interval's width inside it) to 0.08 of the width
    inside it (a chi^2 that keeps bending beyond one standard error is still underestimated).
    Asserted: within 0.12 of the width, and less than half the linear interval's miss."""
    f = Bent(0.5, seed=seed)
    u, r, J, rises = _fitted(f)
    widen, report = secant(rises)
    assert widen is not None and report["widened"] and not report["at_floor"]
    rho = np.min(report["rise"], axis=1)
    assert np.all(rho[report["widened"]] < 1.0 - NEARBY_QUADRATIC)
    lin, sec = covariance(J, r, np.ones(2)), covariance(J, r, np.ones(2), widen=widen)
    s2 = lin["reduced_chi2"]
    lo, hi = f.profile(u[0], float(r @ r), Z95 ** 2 * s2)
    width = hi - lo
    linear = u[0] + np.array([-1.0, 1.0]) * Z95 * lin["standard_error"][0]
    widened = u[0] + np.array([-1.0, 1.0]) * Z95 * sec["standard_error"][0]
    off_linear = np.abs(linear - [lo, hi]) / width
    off_secant = np.abs(widened - [lo, hi]) / width
    assert np.all(sec["standard_error"] >= lin["standard_error"] * (1 - 1e-12))
    assert np.max(off_secant) < 0.12 and np.max(off_secant) < 0.5 * np.max(off_linear), (off_linear, off_secant)
    # the widened axis's variance is its linear one over rho (the congruence keeps the principal axes)
    e = np.array(rises["axes"])
    for k in report["widened"]:
        assert e[k] @ sec["covariance"] @ e[k] == pytest.approx(e[k] @ lin["covariance"] @ e[k] / rho[k], rel=1e-9)


def test_on_a_linear_model_nothing_changes():
    """k = 1: chi^2 quadratic, every rise 1 to rounding: no axis widened, no T, and the covariance
    is that of the plain linearisation bit for bit."""
    f = Bent(1.0)
    u, r, J, rises = _fitted(f)
    widen, report = secant(rises)
    np.testing.assert_allclose(report["rise"], 1.0, atol=1e-9)
    assert widen is None and report["widened"] == [] and report["variance_factor"] == [1.0, 1.0]
    for key in ("covariance", "standard_error", "correlation"):
        np.testing.assert_array_equal(covariance(J, r, np.ones(2), widen=widen)[key], covariance(J, r, np.ones(2))[key])


def test_a_flat_axis_is_widened_by_the_floor_and_said_to_be():
    """k = 0 (a saturates: chi^2 along a levels off 0.25 s^2 in) on w = 0.05: the rise at one
    standard error is below SECANT_FLOOR, so the variance is widened by 1 / SECANT_FLOOR and the
    axis reported at the floor; a bound that cuts a probe's step to nothing gives no rise there."""
    f = Bent(0.0, w=0.05)
    u, r, J, rises = _fitted(f, (0.0, 0.0))  # the minimum (from 0.3 the fit runs off where a has no effect)
    widen, report = secant(rises)
    k = int(np.argmax(np.abs(np.array(rises["axes"])[:, 0])))
    assert k in report["at_floor"] and report["variance_factor"][k] == pytest.approx(1.0 / SECANT_FLOOR)
    one_sided = secant({"axes": np.eye(2), "rise": np.array([[np.nan, 0.5], [np.nan, np.nan]])})[1]
    assert one_sided["widened"] == [0] and one_sided["variance_factor"] == [2.0, 1.0]
