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

from rrr4.identify.least_squares import (
    NEARBY_QUADRATIC,
    SECANT_FLOOR,
    Z95,
    covariance,
    levenberg_marquardt,
    lowest_nearby,
    secant,
)

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
    """Bent by k = 0.5 on w = 0.2 (a's linear standard error 1.2 to 1.4, six times w): chi^2 along
    the axis mostly a rises 0.37 to 0.38 of its linear model's at one standard error, 0.34 at two
    (probed there: not quadratic at one); the secant widens that axis's variance by 1 / 0.34,
    never narrows one, and a's 95 % interval (seed 0: half-width 2.39 linear, 4.08 secant, 4.58
    profile) moves from 0.24 of the profile interval's width inside it to 0.055 (a chi^2 that
    keeps bending beyond two standard errors is still underestimated). Asserted: within 0.1 of
    the width at both ends, and less than half the linear interval's miss."""
    f = Bent(0.5, seed=seed)
    u, r, J, rises = _fitted(f)
    widen, report = secant(rises)
    assert widen is not None and report["widened"] and not report["at_floor"]
    rho = np.array(report["secant"])
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
    assert np.max(off_secant) < 0.1 and np.max(off_secant) < 0.5 * np.max(off_linear), (off_linear, off_secant)
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
    """k = 0 (a's response saturates on w = 0.05, a twenty-fifth of its standard error): chi^2
    along the axis mostly a rises 0.21 of its linear model at one standard error (what b takes
    of G's T part still rises), 0.22 at two: widened by 1 / 0.21. A rise below SECANT_FLOOR
    widens by 1 / SECANT_FLOOR, reported 'at_floor'; a bound that cuts a probe's step to
    nothing gives no rise on that side, a side probed at two standard errors counts too."""
    f = Bent(0.0, w=0.05)
    _, _, _, rises = _fitted(f, (0.0, 0.0))  # the minimum (from 0.3 the fit runs off where a has no effect)
    widen, report = secant(rises)
    k = int(np.argmax(np.abs(rises["axes"][:, 0])))
    assert report["widened"] == [k] and report["variance_factor"][k] == pytest.approx(1 / min(report["rise"][k]))
    assert not np.isnan(rises["far"][k]).any() and np.isnan(rises["far"][1 - k]).all()  # 2 se: on the bent axis only
    made = {"axes": np.eye(3), "rise": np.array([[0.01, 0.3], [np.nan, 0.5], [np.nan, np.nan]]),
            "far": np.array([[np.nan, np.nan], [np.nan, np.nan], [0.9, 0.6]])}
    report = secant(made)[1]
    assert report["widened"] == [0, 1, 2] and report["at_floor"] == [0]
    np.testing.assert_allclose(report["variance_factor"], [1 / SECANT_FLOOR, 2.0, 1 / 0.6])
