"""Weighted nonlinear least squares and what it says about its estimates.

- :func:`levenberg_marquardt`: Gauss-Newton with Levenberg-Marquardt damping (Marquardt
  1963, diagonal scaling) in scaled coordinates, bounds by projection (a bound the gradient presses on stays active);
  for a Jacobian that costs many residuals, reused between refreshes by Broyden's update, fun's exact one at the end;
- :func:`covariance`: s^2 (J^T J)^-1 of whitened residuals, s^2 the residual variance
  (chi^2 / (M - p)); standard errors and the correlation matrix; for residuals that are time
  series (``series``), also the sandwich covariance with the residuals' autocorrelation
  (Newey & West 1987), which carries a model error (a systematic, slowly varying misfit)
  into the standard errors, and the larger of the two is used;
- :func:`profile_interval`: where the linearisation is poor, the 95 % interval of one
  parameter from the profile of chi^2 (Venzon & Moolgavkar 1988);
- :func:`identifiability`: the singular values of the scaled sensitivity matrix (columns
  of unit length, Brun, Reichert & Kuensch 2001): its collinearity index 1 / s_min and,
  for each small singular value, the combination of parameters the data cannot separate.
"""

from __future__ import annotations

import numpy as np

__all__ = ["levenberg_marquardt", "lowest_nearby", "covariance", "identifiability", "profile_interval",
           "COLLINEARITY_LIMIT", "Z95", "BANDWIDTH_FRACTION", "NEARBY_STEPS", "NEARBY_QUADRATIC", "NEARBY_GAIN",
           "secant", "SECANT_FLOOR"]

Z95 = 1.959963984540054  # two-sided 95 % quantile of the normal distribution
# the collinearity index above which a combination is not identifiable (Brun et al. 2001: 10-15 is critical)
COLLINEARITY_LIMIT = 20.0
# the Bartlett kernel's bandwidth of the sandwich covariance, as a fraction of the instants: the
# longest correlation of the residuals it can carry (50 ms of a 1 s record)
BANDWIDTH_FRACTION = 0.05
# the gain ratio (actual over predicted reduction) below which a reused Jacobian is asked again (Levenberg-Marquardt
# with reuse); above it the linear model predicts well enough that the secant update carries it
RHO_POOR = 0.25
# the forward-difference step in the scaled coordinates of Levenberg-Marquardt's differenced Jacobian (reuse
# 'differences'): a thousandth of a parameter's scale
DIFFERENCE_STEP = 1e-3
# a fit whose steps all fail is converged where the exact Jacobian's Gauss-Newton step is shorter than this many
# standard errors (see _stationary): an estimate that far off still puts the truth in its 95 % interval 94.3 % of
# the time (the reference plant's 1 s fit stops 0.14 of one short, at a kink of its cost)
STATIONARY_SE = 0.25
# where :func:`lowest_nearby` looks for a lower cost around a converged fit: these many standard errors along each
# principal axis of its covariance where the cost is not quadratic, both ways
NEARBY_STEPS = (0.5, 1.0, 2.0)
# an axis along which chi^2 at one standard error is s^2 above the minimum to this fraction is quadratic: probed there
# only
NEARBY_QUADRATIC = 0.25
# a probe is fitted from only where chi^2 is this many s^2 below the estimate's: a minimum within half of
# that (a point whose chi^2 is within 0.5 of the lowest lies well inside its 1-dof 68 % region) is as good an
# estimate, and a refit costs a whole fit (on the reference plant's 1 s record: 62 s for 0.13 of chi^2)
NEARBY_GAIN = 0.5
# the smallest secant ratio (chi^2's rise at one standard error over its linear model's) :func:`secant` widens by:
# a variance at most 20 times the linear one (4.5 times the standard error). Below it chi^2 is flat to 0.05 s^2 at one
# standard error, and a single probe's quadratic extrapolation to the 95 % crossing (9 linear standard errors out)
# says nothing more: the widening is a lower bound there (reported as 'at_floor'), and such an interval spans
# enough for the verdict to call a positive parameter poorly determined
SECANT_FLOOR = 0.05


def levenberg_marquardt(fun, u0, lower, upper, max_iter: int = 60, tol: float = 1e-8, rtol: float = 1e-10,
                        reuse: str | None = None, batch=None):
    """Minimise 0.5 |r(u)|^2 with fun(u, jacobian) -> (r (M,), J (M, p) or None without
    `jacobian`) from u0 within [lower, upper]; the Jacobian is asked at every accepted step,
    or with `reuse` ('exact', 'differences': see :func:`_reusing`) carried along the steps and
    refreshed only where it fails; batch(U (k, p)) -> [r (M,) at each row], as fun's (default
    fun one row at a time), gives the residuals of a refresh by differences together. Stops
    when a step moves u by less than tol or lowers the cost by less than rtol of it. Returns
    (u, r, J, iterations, converged): J fun's exact Jacobian at u; iterations the accepted steps."""
    if reuse is not None:
        batch = batch or (lambda U: [fun(v, False)[0] for v in U])
        return _reusing(fun, u0, lower, upper, max_iter, tol, rtol, reuse, batch)
    u = np.clip(np.asarray(u0, float), lower, upper)
    r, J = fun(u, True)
    cost = 0.5 * r @ r
    lam = 1e-3
    for it in range(1, max_iter + 1):
        while True:
            u_new, free = _lm_step(J, r, u, lower, upper, lam)
            if u_new is None:
                lam *= 10
                continue
            r_new, _ = fun(u_new, False)
            cost_new = 0.5 * r_new @ r_new
            if np.isfinite(cost_new) and cost_new <= cost:
                r_new, J_new = fun(u_new, True)
                break
            lam *= 10
            if lam > 1e12:  # no step lowers the cost: converged if the gradient vanishes (to rounding)
                return u, r, J, it, _stationary(J, r, free)
        moved = np.max(np.abs(u_new - u))
        change = cost - cost_new
        u, r, J, cost = u_new, r_new, J_new, cost_new
        lam = max(lam / 10, 1e-12)
        if moved < tol or change <= rtol * max(cost, 1e-300):
            return u, r, J, it, True
    return u, r, J, max_iter, False


def _lm_step(J, r, u, lower, upper, lam):
    """The damped step from u (Marquardt's diagonal scaling, a bound the gradient presses on
    held): (u + step clipped to the bounds, the free coordinates), None if singular."""
    A, g = J.T @ J, J.T @ r
    d = np.diag(A).copy()
    d[d <= 0] = 1.0
    free = ~(((u <= lower) & (g > 0)) | ((u >= upper) & (g < 0)))  # a bound that holds stays active
    step = np.zeros_like(u)
    try:
        step[free] = -np.linalg.solve((A + lam * np.diag(d))[np.ix_(free, free)], g[free])
    except np.linalg.LinAlgError:
        return None, free
    return np.clip(u + step, lower, upper), free


def _stationary(J, r, free) -> bool:
    """Whether u is a minimum no step could move by a meaningful amount: the gradient J^T r in
    the free coordinates vanishes (to rounding), or the Gauss-Newton step it gives is shorter
    than :data:`STATIONARY_SE` of a standard error in the covariance's metric (its predicted
    decrease of chi^2, g^T (J^T J)^-1 g, below STATIONARY_SE^2 s^2: at a kink of the cost, where
    the Jacobian's model fails and no step lowers the cost, the estimate is then as good as
    any point a smooth minimiser would reach)."""
    g, Jf = (J.T @ r)[free], J[:, free]
    if np.linalg.norm(g) <= 1e-6 * max(np.linalg.norm(Jf) * np.linalg.norm(r), 1e-300):
        return True
    s2 = float(r @ r) / max(r.size - int(np.sum(free)), 1)
    return bool(g @ np.linalg.lstsq(Jf.T @ Jf, g, rcond=None)[0] <= STATIONARY_SE ** 2 * s2)


def _differences(batch, u, r, upper, h: float = DIFFERENCE_STEP) -> np.ndarray:
    """The Jacobian of the residuals at u (r there) by forward differences, h in each coordinate
    (backward at an upper bound); batch(U) -> the residuals at each row of U."""
    steps = np.where(u + h <= upper, h, -h)
    rows = batch(u + np.diag(steps))
    return np.column_stack([(rows[i] - r) / steps[i] for i in range(u.size)])


def _reusing(fun, u0, lower, upper, max_iter: int, tol: float, rtol: float, refresh: str, batch):
    """:func:`levenberg_marquardt` for a Jacobian that costs many residuals (a run with its
    sensitivities). Between refreshes the Jacobian is carried along the accepted steps by
    Broyden's rank-1 secant update (Madsen, Nielsen & Tingleff 2004, section 3.4); it is
    refreshed (`refresh` 'exact': fun's Jacobian; 'differences': forward differences of fun's
    residuals, one per coordinate, all in one call of `batch`) at the start and where the linear
    model fails: a carried Jacobian's step rejected twice (the second more damped: one run, where
    a refresh costs one per coordinate), or its gain ratio rho (actual over predicted reduction
    of the cost) below :data:`RHO_POOR`. The damping follows rho (Nielsen 1999). Converged means what
    it means without reuse, with fun's exact Jacobian: the fit ends at u when the step of u's
    exact Jacobian moves u by less than tol or lowers the cost by less than rtol of it (and
    does lower it); a step that meets that rule with a carried Jacobian is followed by a
    refresh at the new point, one with a refreshed one by fun's exact Jacobian there. The J
    returned is always fun's at the u returned."""
    u = np.clip(np.asarray(u0, float), lower, upper)
    r, J = fun(u, refresh == "exact")
    state = "exact"  # J is fun's at u, 'fresh' its differences at u, or 'carried'
    if refresh != "exact":
        J, state = _differences(batch, u, r, upper), "fresh"
    cost, lam, nu, it, damped = 0.5 * r @ r, 1e-3, 2.0, 0, False
    while it < max_iter:
        u_new, free = _lm_step(J, r, u, lower, upper, lam)
        if u_new is None:
            lam *= 10
            continue
        s = u_new - u
        predicted = cost - 0.5 * np.sum((r + J @ s) ** 2)
        r_new, _ = fun(u_new, False)
        cost_new = 0.5 * r_new @ r_new
        if not (np.isfinite(cost_new) and cost_new <= cost):  # rejected: more damping, else a fresh Jacobian
            if state == "carried" and damped:
                J, state, damped = *_refreshed(fun, batch, u, r, upper, refresh), False
                continue
            damped = state == "carried"  # a carried Jacobian gets one more damped step (a run) before a refresh
            lam, nu = lam * nu, 2 * nu
            if lam > 1e12:  # no step lowers the cost: converged if the exact gradient vanishes (to rounding)
                if state != "exact":
                    J, state, lam, nu = fun(u, True)[1], "exact", 1e-3, 2.0
                    continue
                return u, r, J, it, _stationary(J, r, free)
            continue
        it, damped = it + 1, False
        stop = np.max(np.abs(s)) < tol or cost - cost_new <= rtol * max(cost_new, 1e-300)
        if stop and state == "exact":
            return u, r, J, it, True  # the exact Jacobian's step barely moves: u is the estimate, J is u's
        rho = (cost - cost_new) / predicted if predicted > 0 else 0.0
        lam, nu = max(lam * max(1 / 3, 1 - (2 * rho - 1) ** 3), 1e-12), 2.0
        if stop and state == "fresh":  # the stopping rule met with a refreshed Jacobian: fun's at the new point
            J, state = fun(u_new, True)[1], "exact"
        elif stop or (rho < RHO_POOR and state == "carried"):
            J, state = _refreshed(fun, batch, u_new, r_new, upper, refresh)
        else:
            J, state = J + np.outer(r_new - r - J @ s, s) / (s @ s), "carried"
        u, r, cost = u_new, r_new, cost_new
    if state != "exact":
        J = fun(u, True)[1]
    return u, r, J, max_iter, False


def _refreshed(fun, batch, u, r, upper, refresh: str):
    """(J at u, its state): fun's exact one, or its residuals' forward differences ('fresh')."""
    if refresh == "exact":
        return fun(u, True)[1], "exact"
    return _differences(batch, u, r, upper), "fresh"


def lowest_nearby(fit, batch, u, r, J, lower, upper, rounds: int = 4):
    """A converged fit (u, r, J: fun's residuals and exact Jacobian there) moved on to a lower
    minimum within its own standard errors, where the cost along a poorly determined combination
    is wavy (a response that is not linear on the scale of its standard error: the five-bar's
    B - C difference of a chain) and the fit stopped in a shallow local minimum. Probes chi^2 at
    u +- s_k e_k for each principal axis e_k of (J^T J)^-1 in the free coordinates, s_k its
    standard error (s^2 = chi^2 / (M - p)), and along an axis where chi^2 there is not s^2 above
    u's (to :data:`NEARBY_QUADRATIC`) at u +- a s_k e_k for each a in :data:`NEARBY_STEPS` too:
    batch(U) -> [r at each row], once or twice. Where the lowest probe is below u's chi^2 by
    more than :data:`NEARBY_GAIN` s^2, fit(v) -> (u, r, J, iterations, converged) from it, kept if it
    ends lower, again (at most `rounds` fits; after the last one kept, the returned point is probed
    once more at one standard error). Returns (u, r, J, iterations of the fits, converged: the kept
    fit's, None where none was kept, fits, rises): rises {'axes': (k, n) the unit e_k, 'rise' (k, 2):
    chi^2 at the returned u -+ s_k e_k over its linear model's rise there, 'far' (k, 2): the same at
    the largest of NEARBY_STEPS where probed, nan where not} (see :func:`secant`)."""
    iterations, converged, fits = 0, None, 0
    free = lower < upper
    rises = None
    while True:
        lam, V = np.linalg.eigh(J[:, free].T @ J[:, free])
        s2 = float(r @ r) / max(r.size - u.size, 1)
        unit = np.zeros((int(np.sum(lam > 0)), u.size))
        unit[:, free] = V[:, lam > 0].T
        axes = unit * np.sqrt(s2 / lam[lam > 0])[:, None]
        probes, costs = _probes(batch, u, axes, (1.0,), lower, upper)
        rises = {"axes": unit, "rise": _secant_ratios(J, r, u, probes, costs), "far": np.full((len(unit), 2), np.nan)}
        if fits >= rounds:
            break
        rise = (costs - float(r @ r)).reshape(-1, 2) / s2
        wavy = np.any(np.abs(rise - 1.0) > NEARBY_QUADRATIC, axis=1)
        if wavy.any():
            steps = [a for a in NEARBY_STEPS if a != 1.0]
            more, more_costs = _probes(batch, u, axes[wavy], steps, lower, upper)
            rises["far"][wavy] = _secant_ratios(J, r, u, more, more_costs).reshape(-1, len(steps), 2)[:, -1]
            probes, costs = np.r_[probes, more], np.r_[costs, more_costs]
        if not costs.size or not np.min(costs) < float(r @ r) - NEARBY_GAIN * s2:
            break
        u_new, r_new, J_new, it, ok = fit(probes[int(np.argmin(costs))])
        iterations, fits = iterations + it, fits + 1
        if not float(r_new @ r_new) < float(r @ r):
            break
        u, r, J, converged = u_new, r_new, J_new, ok
    return u, r, J, iterations, converged, fits, rises


def _secant_ratios(J, r, u, probes, costs):
    """(k, 2): each probe's rise of chi^2 over the rise its linear model predicts for the same step
    (|J d|^2, d the probe's step from u, clipped to the bounds: 1 for a quadratic cost, nan for
    a step a bound cut to nothing)."""
    d = probes - u
    predicted = np.sum((d @ J.T) ** 2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(predicted > 0, (costs - float(r @ r)) / predicted, np.nan)
    return ratio.reshape(-1, 2)


def secant(rises: dict | None, floor: float = SECANT_FLOOR) -> tuple[np.ndarray | None, dict]:
    """The secant correction of the linearised covariance from :func:`lowest_nearby`'s probes:
    along each principal axis e_k, rho_k the smallest rise of chi^2 (in units of its linear
    model's for the same step) at -+ one standard error, and at -+ two where lowest_nearby probed
    there (an axis not quadratic at one): the chord nearest the 95 % crossing (1.96 standard
    errors). Where rho_k < 1 - :data:`NEARBY_QUADRATIC` (chi^2 flatter than its linear model) the
    axis's variance is divided by max(rho_k, `floor`), never narrowed:
    Sigma' = T Sigma T with T = I + sum_k (sqrt(w_k) - 1) e_k e_k^T, w_k = 1 / max(rho_k, floor)
    (T = V W^1/2 V^T: it commutes with J^T J, so the axes stay the principal axes and only their
    variances change). Returns (T, or None where no axis is widened; the report: 'rise', 'rise_far'
    (k, 2), 'secant' (k,) rho_k, 'widened' the axes' indices, 'variance_factor' (k,) w_k, 'at_floor'
    the axes whose rho_k is below the floor: chi^2 along them flat within `floor` of its linear
    model, their widening a lower bound)."""
    if rises is None or not len(rises["rise"]):
        return None, {}
    both = np.c_[rises["rise"], rises["far"]]
    rho = np.min(np.where(np.isnan(both), np.inf, both), axis=1)
    rho[np.isinf(rho) & (rho > 0)] = 1.0  # no step on either side (bounds) or no finite run: no information
    widened = rho < 1.0 - NEARBY_QUADRATIC
    w = np.where(widened, 1.0 / np.maximum(rho, floor), 1.0)
    def listed(a):  # for JSON: a side not probed (or a run not finite) is None
        return np.where(np.isfinite(a), a, None).tolist()

    report = {"rise": listed(rises["rise"]), "rise_far": listed(rises["far"]),
              "secant": rho.tolist(), "axes": rises["axes"].tolist(), "widened": np.flatnonzero(widened).tolist(),
              "variance_factor": w.tolist(), "at_floor": np.flatnonzero(widened & (rho < floor)).tolist(),
              "floor": floor}
    if not widened.any():
        return None, report
    E = rises["axes"]
    return np.eye(E.shape[1]) + (E.T * (np.sqrt(w) - 1.0)) @ E, report


def _probes(batch, u, axes, steps, lower, upper):
    """(U, chi^2 at each row): u -+ a times each axis (rows of `axes`) for a in steps, within the
    bounds, in one call of batch (a residual not finite: chi^2 inf)."""
    U = np.array([np.clip(u + sign * a * axis, lower, upper) for axis in axes for a in steps for sign in (-1.0, 1.0)])
    if not len(U):
        return np.zeros((0, u.size)), np.zeros(0)
    return U, np.array([float(q @ q) if np.all(np.isfinite(q)) else np.inf for q in batch(U)])


def covariance(J: np.ndarray, r: np.ndarray, scale: np.ndarray, dof: float | None = None,
               series: int | None = None, widen: np.ndarray | None = None) -> dict:
    """Covariance, standard errors and correlation of the parameters p (dp/du = scale)
    from the whitened residuals r (M,) and their Jacobian J (M, p) in u: s^2 (J^T J)^-1
    with s^2 = chi^2 / (dof - p) (dof: the residuals' degrees of freedom, default M). A
    singular J^T J gives infinite standard errors.

    series: N, when r is blocks of N residuals each a time series on the same N instants
    (one block per measured column): then also the sandwich (J^T J)^-1 S (J^T J)^-1 with S
    the Bartlett-weighted autocovariances of the instants' scores sum_c J_c r_c up to
    lag :data:`BANDWIDTH_FRACTION` N, scaled by M / (dof - p) (Newey & West 1987), and each
    parameter's variance is the larger of the two: white noise leaves them equal (to the
    sandwich's scatter, ~13 % on the standard error at 1000 instants); a model error, residuals
    that are smooth in time, widens the sandwich. 'inflation' (p,): the standard errors over
    those of s^2 (J^T J)^-1 (1 without `series`).

    widen (p, p): T of :func:`secant` (in u): both covariances rescaled congruently, T C T, before
    they are compared: the sandwich's inflation is then that of the model error over the widened
    linear covariance, and the secant widening and the model error's multiply."""
    M, npar = J.shape
    chi2 = float(r @ r)
    s2 = chi2 / max((M if dof is None else dof) - npar, 1)
    A = J.T @ J
    try:
        inv = np.linalg.inv(A)
        if not np.all(np.isfinite(inv)) or np.linalg.cond(A) > 1e15:
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(A)
        inv[np.diag_indices(npar)] = np.inf
    widen = widen if widen is not None and np.all(np.isfinite(inv)) else None
    cov = s2 * inv if widen is None else widen @ (s2 * inv) @ widen.T
    inflation = np.ones(npar)
    if series and M % series == 0 and np.all(np.isfinite(np.diag(inv))):
        scores = (J * r[:, None]).reshape(M // series, series, npar).sum(axis=0)
        meat = scores.T @ scores
        for lag in range(1, int(np.ceil(BANDWIDTH_FRACTION * series)) + 1):
            g = scores[lag:].T @ scores[:-lag]
            meat += (1.0 - lag / (BANDWIDTH_FRACTION * series + 1.0)) * (g + g.T)
        sandwich = inv @ meat @ inv * M / max((M if dof is None else dof) - npar, 1)
        sandwich = sandwich if widen is None else widen @ sandwich @ widen.T
        inflation = np.sqrt(np.maximum(np.diag(sandwich) / np.diag(cov), 1.0))
        cov = cov * np.outer(inflation, inflation)  # the correlations stay those of s^2 T (J^T J)^-1 T
    cov = cov * np.outer(scale, scale)
    se = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr[~np.isfinite(corr)] = np.nan
    np.fill_diagonal(corr, 1.0)
    return {"covariance": cov, "standard_error": se, "correlation": corr, "chi2": chi2, "reduced_chi2": s2,
            "residuals": M, "inflation": inflation}


def profile_interval(cost, u: np.ndarray, i: int, lower: np.ndarray, upper: np.ndarray, se: float,
                     threshold: float, refit, steps: int = 24) -> tuple[float, float]:
    """The 95 % interval of coordinate i in u-space from the profile of cost(u) (chi^2): the
    values t of u[i] at which min over the others of cost, minus cost(u), reaches `threshold`
    (Z95^2 times the residual variance: the likelihood-ratio test's 95 % quantile), on each
    side of u[i], or the bound where it does not. refit(u_start, i) -> u: the others refitted
    with u[i] held (warm-started from the nearest point inside). se: the linearised standard
    error of u[i]: the first step out is min(se, a quarter of the range). Bracketing by
    doubling, then regula falsi (Illinois) on sqrt(rise) (linear in t where chi^2 is
    quadratic) to 1e-3 se; `steps` profile points per side at most."""
    c0 = cost(u)
    tol = 1e-3 * min(se, 1.0)
    out = []

    def rise_at(t, start):
        trial = start.copy()
        trial[i] = t
        trial = refit(trial, i)
        return np.sqrt(max(cost(trial) - c0, 0.0)) - np.sqrt(threshold), trial

    for sign in (-1.0, 1.0):
        bound = lower[i] if sign < 0 else upper[i]
        inner, f_in, start = u[i], -np.sqrt(threshold), u.copy()
        outer, f_out = None, None
        d, used = min(se, 0.25 * (upper[i] - lower[i])), 0
        while used < steps:  # bracket: double the step until the rise passes the threshold or the bound
            t = u[i] + sign * d
            t = bound if (t - bound) * sign >= 0 else t
            f, trial = rise_at(t, start)
            used += 1
            if f >= 0:
                outer, f_out = t, f
                break
            inner, f_in, start = t, f, trial
            if t == bound:
                break
            d *= 2.0
        if outer is None:
            out.append(bound)  # the data do not bound it on this side
            continue
        side = 0
        while used < steps and abs(outer - inner) > tol:
            t = inner + (outer - inner) * (-f_in) / (f_out - f_in)
            f, trial = rise_at(t, start)
            used += 1
            if f < 0:
                inner, f_in, start = t, f, trial
                f_out, side = (f_out / 2, 0) if side == -1 else (f_out, -1)
            else:
                outer, f_out = t, f
                f_in, side = (f_in / 2, 0) if side == 1 else (f_in, 1)
        out.append(0.5 * (inner + outer))
    return out[0], out[1]


def identifiability(J: np.ndarray, keys: list[str], hint=None) -> dict:
    """The verdict from the singular values of the sensitivity matrix J (M, p) with columns
    scaled to unit length: collinearity index gamma = 1 / s_min; for every singular value
    below 1 / COLLINEARITY_LIMIT the combination (right singular vector, entries above 0.2)
    the data cannot separate; `hint(keys) -> str` says what motion would excite it."""
    norms = np.linalg.norm(J, axis=0)
    blind = [k for k, v in zip(keys, norms, strict=True) if not v > 0]
    Jn = J / np.where(norms > 0, norms, 1.0)
    _, s, vt = np.linalg.svd(Jn, full_matrices=False)
    gamma = float(1.0 / s[-1]) if s[-1] > 0 else float("inf")
    combos = []
    for k in range(len(s)):
        if s[k] * COLLINEARITY_LIMIT >= 1.0:
            continue
        v = vt[k] / np.max(np.abs(vt[k]))
        members = {key: float(round(c, 3)) for key, c in zip(keys, v, strict=True) if abs(c) > 0.2}
        combos.append({"singular_value": float(s[k]), "combination": members,
                       "excite": hint(list(members)) if hint else ""})
    return {"identifiable": not combos and not blind, "collinearity_index": gamma,
            "collinearity_limit": COLLINEARITY_LIMIT, "singular_values": [float(v) for v in s],
            "not_identifiable": combos, "not_seen": blind}
