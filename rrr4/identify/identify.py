"""The front door: :func:`identify` turns measurements of a mechanism into the parameters
of its scene (clearances, friction, contact stiffness, link lengths and base positions),
with their uncertainty, their correlations, an identifiability verdict and the identified
scene (DESIGN section 11)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..checks import unknown_value
from ..errors import MeasurementError, SceneError, SimulationError
from ..problem import Problem
from ..scene import Scene
from ..scene.vocabulary import IDENTIFICATION_DEFAULT, IDENTIFICATION_METHODS
from .dynamic import DynamicData
from .least_squares import (
    Z95,
    covariance,
    identifiability,
    levenberg_marquardt,
    lowest_nearby,
    profile_interval,
    secant,
)
from .measurements import Measurements, driven_scene, measurements_from_simulation, read_measurements
from .multiple_shooting import WindowedData, check_windows, first_frame
from .parameters import Parameter, identified_scene, resolve_parameters
from .seated import SeatedData, check_friction_explained, check_seated, noise_from_residuals

__all__ = ["identify", "Identification", "METHODS"]

METHODS = IDENTIFICATION_METHODS
DEFAULT_METHOD = IDENTIFICATION_DEFAULT
FIT_LIMIT = 10.0  # the reduced chi^2 with every noise level given beyond which a dynamic fit is refused
POOR = 0.5  # a standard error above half a parameter's scale (a factor 1.6 in a stiffness): barely determined
# a positive parameter (clearance, friction, stiffness) whose 95 % interval spans more than this factor is
# poorly determined, unless it is fitted linearly and the interval's half-width is below SPAN_FLOOR of its scale (a
# friction of 0.001 +- 0.001 is determined: it is nearly 0)
SPAN_FACTOR, SPAN_FLOOR = 2.0, 0.1
# the linearised (Wald) interval is replaced by the profile likelihood's where the standard error in the fitted
# coordinate exceeds this, or where chi^2 at the Wald interval's ends misses its quadratic prediction by more than
# QUADRATIC_TOL
PROFILE_FRACTION, QUADRATIC_TOL = 0.25, 0.25
INSEPARABLE = 0.995  # a correlation beyond which a parameter is not profiled (the verdict names its combination)
POSITIVE = ("clearance", "friction", "stiffness")


@dataclass(frozen=True)
class Identification:
    """The result of :func:`identify`. p parameters (``parameters``: keys, nominal values,
    bounds), M fitted residuals over N instants.

    estimate, standard_error (p,) in the parameters' units; interval (p, 2): 95 % intervals,
    found in the coordinate each parameter is fitted in (log for a stiffness: asymmetric), from
    the profile likelihood where the linearisation is poor (``fit['intervals']``), widened by
    a model error the residuals' autocorrelation shows (``fit['model_error_inflation']``, method
    'seated') and, method 'dynamic', along the principal axes where chi^2 rises more slowly than
    its linear model (the secant, ``fit['secant']``); covariance, correlation (p, p); at_bound:
    keys whose estimate sits on a bound (their interval means little); noise {column: std} and
    noise_estimated {column: True if estimated from the residuals}; fit: reduced chi^2, RMS
    residual per column, iterations, convergence, wall time; verdict: the identifiability
    verdict (:func:`_verdict`); t (N,), measured,
    prediction, residual: {column: (N,)}; explained: {column: (N,)} what the model explains
    (the pose's offset from the path, the friction efforts off the preload direction; the
    measured counterpart is explained + residual); scene: the nominal scene; identified: the scene
    with the estimates (None without the nominal scene's YAML; a parameter the verdict finds
    not determined, ``verdict['poorly_determined']``, keeps its nominal value there);
    identified_yaml: its data."""
    method: str
    parameters: tuple[Parameter, ...]
    estimate: np.ndarray
    standard_error: np.ndarray
    interval: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    at_bound: tuple[str, ...]
    noise: dict
    noise_estimated: dict
    fit: dict
    verdict: dict
    t: np.ndarray
    measured: dict
    prediction: dict
    residual: dict
    explained: dict
    scene: Scene
    identified: Scene | None = None
    identified_yaml: dict | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)

    @property
    def keys(self) -> list[str]:
        return [p.key for p in self.parameters]

    def value(self, key: str) -> float:
        """The estimate of the parameter `key`."""
        if key not in self.keys:
            raise unknown_value("key", "parameter", key, self.keys)
        return float(self.estimate[self.keys.index(key)])

    def summary(self) -> dict:
        """A JSON-ready summary (what ``identification.json`` holds)."""
        rows = [{"key": p.key, "nominal": p.nominal, "lower": p.lower, "upper": p.upper, "estimate": float(e),
                 "standard_error": float(s), "interval_95": [float(a), float(b)], "at_bound": p.key in self.at_bound,
                 "in_identified_scene": p.nominal if p.key in self.verdict["poorly_determined"] else float(e)}
                for p, e, s, (a, b) in zip(self.parameters, self.estimate, self.standard_error, self.interval,
                                           strict=True)]
        corr = np.where(np.isfinite(self.correlation), self.correlation, None).tolist()
        return {"scene": self.scene.name, "method": self.method, "parameters": rows, "correlation": corr,
                "noise": {c: {"std": s, "estimated": self.noise_estimated[c]} for c, s in self.noise.items()},
                "fit": self.fit, "verdict": self.verdict, "warnings": list(self.warnings)}

    def table(self) -> str:
        """The estimates as a plain-text table, then the verdict."""
        lines = [f"{'parameter':44s} {'nominal':>11s} {'estimate':>11s} {'std error':>10s}  95 % interval"]
        for p, e, s, (a, b) in zip(self.parameters, self.estimate, self.standard_error, self.interval, strict=True):
            mark = "  (at a bound)" if p.key in self.at_bound else ""
            if p.key in self.verdict["poorly_determined"]:
                mark += "  (the identified scene keeps the nominal value)"
            lines.append(f"{p.key:44s} {p.nominal:11.5g} {e:11.5g} {s:10.3g}  [{a:.5g}, {b:.5g}]{mark}")
        f = self.fit
        rms = ", ".join(f"{c} {v:.3g}" for c, v in f["rms_residual"].items())
        lines.append(f"{f['samples']} instants, reduced chi^2 {f['reduced_chi2']:.3g}, RMS residuals: {rms}; "
                     f"{f['iterations']} iterations in {f['wall_time_s']:.2f} s")
        lines += [f"stage {k + 1}, {st['said']}" for k, st in enumerate(self.fit.get("stages", []))]
        if n := len(self.fit.get("secant", {}).get("widened", [])):
            lines.append(f"intervals widened along {n} ax{'is' if n == 1 else 'es'} where chi^2 rises more slowly than "
                         "its linear model (secant)")
        lines.append(verdict_text(self.verdict))
        return "\n".join(lines)


def verdict_text(v: dict) -> str:
    """The verdict in words (one line per combination the data cannot separate, one per
    parameter the identified scene keeps at its nominal value, with the reason)."""
    index = f"collinearity index {v['collinearity_index']:.3g}, limit {v['collinearity_limit']:g}"
    if v["identifiable"]:
        out = [f"verdict: identifiable (every parameter determined, every 95 % interval within a factor "
               f"{SPAN_FACTOR:g}; {index})"]
        for c in v["not_identifiable"]:
            combo = " ".join(f"{w:+.2g} {k}" for k, w in c["combination"].items())
            out.append(f"  collinear but determined by these data: {combo} (singular value {c['singular_value']:.2g})")
        return "\n".join(out)
    out = [f"verdict: NOT identifiable from these data ({index}); the identified scene keeps the nominal value "
           "of what they do not determine"]
    reasons = v.get("reasons", {})
    for k in v.get("poorly_determined", []):
        out.append(f"  {k}: not determined ({reasons.get(k, 'standard error above half its scale')}); the "
                   "identified scene keeps its nominal value")
    for c in v["not_identifiable"]:
        combo = " ".join(f"{w:+.2g} {k}" for k, w in c["combination"].items())
        out.append(f"  cannot separate: {combo} (singular value {c['singular_value']:.2g}); to excite it: "
                   f"{c['excite']}")
    return "\n".join(out)


def _excite(params: dict[str, Parameter]):
    def hint(keys: list[str]) -> str:
        ps = [params[k] for k in keys]
        kinds = {p.kind for p in ps}
        joints = [j for p in ps if p.kind == "clearance" for j in p.joints]
        out = []
        chains = {j[1:] for j in joints}
        if len(joints) > 1 and any(f"B{c}" in joints and f"C{c}" in joints for c in chains):
            out.append("loads that differ at the two ends of a following link (accelerate it harder, or a load "
                       "across it)")
        if "clearance" in kinds and "stiffness" in kinds:
            out.append("a load whose magnitude changes (vary the preload f_min along the run)")
        if "friction" in kinds:
            out.append("a reversal of the slip or load direction (a path that reverses) and the efforts tau_* "
                       "among the measurements")
        if kinds & {"driving", "following", "base"}:
            out.append("poses spread over the workspace and rotations of the task body")
        return "; ".join(out) or "a path that moves these parameters' effects apart"
    return hint


def _continuity(data: WindowedData, defects: np.ndarray) -> dict:
    """What a windowed fit adds to `fit`: its windows and the largest continuity defects left
    (coordinates [m or rad], rates [m/s or rad/s])."""
    half = data.n_state // 2
    return {"windows": data.windows, "window_starts_s": [data.span(k)[0] for k in range(data.windows)],
            "continuity_defect_max": [float(np.max(np.abs(defects[:, :half]))),
                                      float(np.max(np.abs(defects[:, half:])))],
            "sensitivity_disagreement_windows": list(data.chaos_windows)}


def _measurements(problem: Problem, measurements, arm, noise) -> Measurements:
    if isinstance(measurements, Measurements):
        m = measurements
    elif isinstance(measurements, (str, os.PathLike)):
        m = read_measurements(measurements, problem, arm=arm)
    elif hasattr(measurements, "tau") and hasattr(measurements, "q"):
        m = measurements_from_simulation(measurements)
    else:
        raise MeasurementError(f"measurements: {type(measurements).__name__} is not allowed (a CSV file's path, "
                               "rrr4.identify.Measurements or a Simulation)")
    if noise:
        m = Measurements(m.t, m.columns, {**m.noise, **noise}, m.source)
    return m


def _fit(fun, u, lower, upper, sigma: dict, given: dict, first: dict, residuals, npar: int, reuse: str | None = None,
         batch=None):
    """Levenberg-Marquardt from u, re-estimating the noise levels not `given` from the
    residuals (at most four rounds, until they settle within 1 %): (u, sigma, iterations,
    converged). fun(u, jacobian, sigma): the weighted residuals and their Jacobian at the noise
    levels sigma; residuals(u, sigma): the raw residuals by column; reuse: how a Jacobian that
    costs many residuals is reused (see :func:`levenberg_marquardt`), and then a shallow local
    minimum left for a lower one within the standard errors (:func:`lowest_nearby`); batch(U,
    sigma): the weighted residuals at each row of U together (None: fun's one at a time).
    rises: lowest_nearby's probes of chi^2 at the last fit's estimate (see :func:`secant`), None
    without `reuse`."""
    iterations, converged, rises = 0, True, [None]

    def fit(u, s):
        b = batch and (lambda U: batch(U, s))
        lm = lambda v: levenberg_marquardt(lambda w, jacobian: fun(w, jacobian, s), v, lower, upper,  # noqa: E731
                                           reuse=reuse, batch=b)
        u, r, J, it, ok = lm(u)
        if reuse:
            u, _, _, more, kept, _, rises[0] = lowest_nearby(lm, b or (lambda U: [fun(v, False, s)[0] for v in U]),
                                                             u, r, J, lower, upper)
            it, ok = it + more, ok if kept is None else kept
        return u, it, ok

    for _ in range(4):
        u, it, ok = fit(u, sigma)
        iterations, converged = iterations + it, ok
        if len(given) == len(sigma):
            break
        new = noise_from_residuals(residuals(u, sigma), npar)
        new = {**{c: max(v, 1e-6 * first[c]) for c, v in new.items()}, **given}  # a floor for exact data
        change = max(abs(new[c] / sigma[c] - 1) for c in sigma)
        sigma = new
        if change < 0.01:
            u, it, ok = fit(u, sigma)
            iterations, converged = iterations + it, ok
            break
    return u, sigma, iterations, converged, rises[0]


def _verdict(J, params, relative_se, interval=None) -> dict:
    """The identifiability verdict of the scaled sensitivities J. 'poorly_determined': the
    parameters these data do not determine, which the identified scene keeps at their nominal
    values, and 'reasons' {key: why}: no dependence, a standard error in the fitted coordinate
    above POOR, or (clearance, friction, stiffness, with `interval` (p, 2)) a 95 % interval
    spanning more than SPAN_FACTOR; a member of a combination the singular values flag
    (collinearity index above its limit) is named as such, but judged by its interval: with
    enough data a collinear pair is determined all the same. 'identifiable': every parameter
    determined."""
    keys = [q.key for q in params]
    verdict = identifiability(J, keys, _excite(dict(zip(keys, params, strict=True))))
    inseparable = {k for c in verdict["not_identifiable"] for k in c["combination"]}
    reasons = {}
    for i, (q, s_u) in enumerate(zip(params, relative_se, strict=True)):
        lo, hi = (np.nan, np.nan) if interval is None else interval[i]
        wide = q.kind in POSITIVE and not (lo > 0 and hi <= SPAN_FACTOR * lo) and (
            q.log or hi - lo > 2 * SPAN_FLOOR * q.scale)
        if q.key in verdict["not_seen"]:
            reasons[q.key] = "these data do not depend on it"
        elif not s_u <= POOR or wide:
            span = f"a factor {hi / lo:.3g}" if lo > 0 else "down to 0"
            why = (f"standard error {s_u:.2g} of its scale, above {POOR:g}" if not s_u <= POOR else
                   f"its 95 % interval [{lo:.3g}, {hi:.3g}] spans {span}, more than {SPAN_FACTOR:g}")
            # a combination the singular values flag is named; its members are kept only where their
            # intervals say so (with enough data a collinear pair is determined all the same)
            reasons[q.key] = f"in a combination these data cannot separate: {why}" if q.key in inseparable else why
    poor = [k for k in keys if k in reasons]
    return {**verdict, "poorly_determined": poor, "reasons": reasons,
            "identifiable": not poor and not verdict["not_seen"]}


def _intervals(params, u, lower, upper, se_u, inflation, cov_u, s2, fun, profile: bool):
    """95 % intervals (p, 2) in the parameters' units, found in the coordinate each is fitted
    in (a log-fitted stiffness gets an asymmetric interval), and how each was found ('wald' or
    'profile'). se_u (p,), cov_u (p, p): standard errors and covariance in the fitted
    coordinates, inflation (p,): their model-error factors (:func:`covariance`); fun(u,
    jacobian) -> (whitened residuals, Jacobian) at the final noise levels. With `profile`,
    a parameter whose se_u exceeds PROFILE_FRACTION or whose chi^2 at the linearised
    interval's ends misses the quadratic prediction by more than QUADRATIC_TOL gets the
    profile-likelihood interval (threshold Z95^2 s^2 inflation^2: the model error widens it
    as it widens the standard error)."""
    npar = len(params)
    cost = lambda v: float(np.sum(fun(v, False)[0] ** 2))  # noqa: E731

    def refit(v, i):
        lo, hi = lower.copy(), upper.copy()
        lo[i] = hi[i] = v[i]
        return levenberg_marquardt(fun, v, lo, hi, max_iter=30)[0]

    c0 = cost(u) if profile else 0.0
    out, how = np.empty((npar, 2)), []
    for i, q in enumerate(params):
        a, b, kind = u[i] - Z95 * se_u[i], u[i] + Z95 * se_u[i], "wald"
        threshold = Z95 ** 2 * s2 * inflation[i] ** 2
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.abs(cov_u[i] / np.sqrt(cov_u[i, i] * np.diag(cov_u)))
        corr[i] = 0.0
        # a member of a combination the data cannot separate is not determined, whatever its profile
        if profile and np.isfinite(se_u[i]) and se_u[i] > 0 and not np.nanmax(corr, initial=0.0) > INSEPARABLE:
            direction = np.zeros(u.size)  # the others' conditional move along u_i (the plain covariance's)
            direction[:npar] = cov_u[:, i] / cov_u[i, i] * inflation[i] / inflation
            ends = [np.clip(u + direction * (e - u[i]), lower, upper) for e in (a, b)]
            quadratic = all(abs((cost(v) - c0) / threshold - 1.0) <= QUADRATIC_TOL for v in ends)
            if se_u[i] > PROFILE_FRACTION or not quadratic:
                a, b = profile_interval(cost, u, i, lower, upper, se_u[i], threshold, refit)
                kind = "profile"
        a, b = max(a, lower[i]), min(b, upper[i])
        out[i] = [q.value(a), q.value(b)]
        how.append(kind)
    return out, how


def identify(scene, measurements, parameters=None, method: str = DEFAULT_METHOD, noise: dict | None = None,
             arm: str | None = None, effort_lag="controller", windows: int = 1) -> Identification:
    """Identify `parameters` of `scene` (the nominal model: a Scene, a scene file or a
    Problem) from `measurements` (a CSV file, :class:`Measurements` or a Simulation).

    parameters: dotted scene keys (:data:`rrr4.identify.parameters.PATTERNS`; default
    clearance, friction coefficient, contact stiffness), or a mapping key -> None |
    [lower, upper] | {nominal, lower, upper}. method: 'staged' (the default: 'seated' first
    where the journals are seated by a preload, then 'dynamic' over the whole record from
    its estimates, see :func:`staged`), 'seated' (journals seated under preload;
    quasi-static) or 'dynamic' (shooting through the compiled stepping from the scene's
    initial state, from the nominal values; refuses a run too chaotic to shoot).
    noise: {column: standard deviation} (the rest is estimated from the residuals). arm:
    the arm prefix of a study's timeseries.csv with several arms. windows: with 'dynamic',
    the number of windows of multiple shooting (1: single shooting from the scene's initial
    state; K > 1: K windows whose start states are extra unknowns coupled by continuity, see
    :mod:`rrr4.identify.multiple_shooting`).
    effort_lag: the time constant [s] with which the measured friction efforts follow the
    seat model ('controller': the feedback's kd / kp; 0: none).
    Raises SceneError / MeasurementError (one line) for bad input; with 'dynamic'
    SimulationError (one line) for a run or a window too sensitive to its parameters to shoot,
    or a fit that does not reproduce the measurements."""
    problem = Problem.from_scene(scene)
    if method not in METHODS:
        raise unknown_value("method", "identification method", method, METHODS)
    if method == "seated" and not (isinstance(windows, int) and not isinstance(windows, bool) and windows == 1):
        raise SceneError(f"windows: {windows!r} is not allowed with method {method!r} (windows of multiple shooting "
                         "belong to methods 'dynamic' and 'staged')")
    if method == "seated":
        check_seated(problem)
    wall = time.perf_counter()
    m = _measurements(problem, measurements, arm, noise)
    nominal = scene if isinstance(scene, Scene) else problem.scene  # the one given is the one varied
    if nominal.data is not None:
        nominal.with_values({})  # data a change in memory made stale: one line now, not after the fit
    params = resolve_parameters(problem, parameters, nominal.data)
    if method == "staged":
        return staged(problem, nominal, m, params, effort_lag, windows, wall)
    return _one_method(problem, nominal, m, params, method, effort_lag, windows, wall)


def staged(problem: Problem, nominal: Scene, m: Measurements, params: list[Parameter], effort_lag, windows: int,
           wall: float) -> Identification:
    """Method 'staged' (DESIGN section 11): 'seated' first where it applies (quick: a chain's
    clearance sum, friction), then 'dynamic' over the whole record from its estimates (those
    it determines; the rest from their nominal values), which sees what the seat model
    cannot (a chain's two clearances apart, the link lengths with them). The result is the
    dynamic fit's, with ``fit['stages']``: what each stage found and why it moved on."""
    stages, seed = [], None
    why = _no_seats(problem)
    if why is None:
        try:
            first = _one_method(problem, nominal, m, params, "seated", effort_lag, 1, time.perf_counter())
        except (SceneError, MeasurementError) as e:
            why = str(e)
    if why is None:
        kept = set(first.verdict["poorly_determined"]) | set(first.at_bound)
        seed = [q.nominal if q.key in kept else float(v) for q, v in zip(params, first.estimate, strict=True)]
        used = [q.key for q in params if q.key not in kept]
        stages.append({"method": "seated", "wall_time_s": first.fit["wall_time_s"],
                       "identifiable": first.verdict["identifiable"],
                       "collinearity_index": first.verdict["collinearity_index"],
                       "estimate": dict(zip(first.keys, first.estimate.tolist(), strict=True)), "seeded": used,
                       "said": (f"seated ({first.fit['wall_time_s']:.1f} s): "
                                + (f"{', '.join(_short(k) for k in used)} determined"
                                   if used else "nothing determined")
                                + (f", {len(kept)} poorly determined or at a bound (nominal kept)" if kept else "")
                                + f", collinearity index {first.verdict['collinearity_index']:.3g}; moving on: the "
                                "dynamics over the whole record separate what the seat model sees only together "
                                "(a chain's two clearances, the link lengths with them), starting from these")})
    else:
        stages.append({"method": "seated", "skipped": why, "said": f"seated skipped: {why}"})
    second = _one_method(problem, nominal, m, params, "dynamic", effort_lag, windows, time.perf_counter(), seed)
    stages.append({"method": "dynamic", "wall_time_s": second.fit["wall_time_s"],
                   "identifiable": second.verdict["identifiable"],
                   "collinearity_index": second.verdict["collinearity_index"],
                   "said": (f"dynamic over {m.t[0]:g} to {m.t[-1]:g} s ({second.fit['wall_time_s']:.1f} s, "
                            f"{second.fit['simulations']} simulations, {second.fit['iterations']} iterations): "
                            f"reduced chi^2 {second.fit['reduced_chi2']:.3g}, collinearity index "
                            f"{second.verdict['collinearity_index']:.3g}")})
    fit = {**second.fit, "stages": stages, "wall_time_s": time.perf_counter() - wall}
    return replace(second, method="staged", fit=fit)


def _short(key: str) -> str:
    """A parameter's key without the common prefixes (for one line)."""
    return key.replace("joints.per_joint.", "").replace(".radial_clearance", " clearance").replace(
        "effects.", "").replace("mechanism.", "")


def _no_seats(problem: Problem) -> str | None:
    """Why method 'seated' does not apply to `problem` (None: it does)."""
    if driven_scene(problem):
        return (f"scene {problem.name!r} is driven by its drivers (no task body held against a preload: nothing "
                "seats its journals where the seat model puts them); straight to 'dynamic'")
    if not problem.has_preload:
        return f"scene {problem.name!r} does not preload (its journals are not seated)"
    return None


def _method_data(problem: Problem, nominal: Scene, m: Measurements, params: list[Parameter], method: str, effort_lag,
                 windows: int, seed):
    """The data object of `method` (seated; dynamic, in windows where `windows` > 1)."""
    if method == "seated":
        return SeatedData(problem, m, params, effort_lag)
    data = DynamicData(problem, m, params, nominal)
    if check_windows(windows, data.n_frames - first_frame(data), data.dt) > 1:
        if driven_scene(problem):
            raise SceneError(f"windows: {windows} is not allowed with a driven scene (scene {problem.name!r}: "
                             "multiple shooting does not reproduce its run yet, two windows over a noise-free "
                             "revolution end in a wrong local minimum; fit it with windows=1)")
        return WindowedData(data, windows, seed)
    return data


def _one_method(problem: Problem, nominal: Scene, m: Measurements, params: list[Parameter], method: str, effort_lag,
                windows: int, wall: float, seed=None) -> Identification:
    """One method's fit (see :func:`identify`); seed: the parameters' start values (default
    their nominal ones); a seeded 'dynamic' fit skips the sensitivity check at its start (the
    one at the estimate stays)."""
    data = _method_data(problem, nominal, m, params, method, effort_lag, windows, seed)
    npar = len(params)
    # a windowed fit's start states: nuisance unknowns, unbounded, in the scaled coordinates (s - start) / scale
    start, scale_s = (data.nuisance_start, data.nuisance_scale) if isinstance(data, WindowedData) else \
        (np.zeros(0), np.zeros(0))
    lower = np.r_[[q.coordinate(q.lower) for q in params], np.full(start.size, -np.inf)]
    upper = np.r_[[q.coordinate(q.upper) for q in params], np.full(start.size, np.inf)]
    given = {c: float(s) for c, s in m.noise.items() if c in data.columns()}
    first = data.initial_noise()
    sigma = {**first, **given}

    def values(u):
        return np.r_[[q.value(v) for q, v in zip(params, u[:npar], strict=True)], start + scale_s * u[npar:]]

    def derivative(u):
        return np.r_[[q.derivative(v) for q, v in zip(params, u[:npar], strict=True)], scale_s]

    def fun(u, jacobian, sigma):
        res = data.residuals(values(u), sigma, jacobian=jacobian)
        if not jacobian:
            return res["r"], None
        return res["r"], res["J"] * derivative(u)

    u = np.zeros(npar + start.size)
    if seed is not None:
        u[:npar] = np.clip([q.coordinate(v) for q, v in zip(params, seed, strict=True)], lower[:npar], upper[:npar])
    chaos_nominal = None
    if method == "dynamic" and seed is None:  # a run too chaotic to shoot is refused before fitting, again at the end
        chaos_nominal = data.check_sensitivities(values(u), sigma, data.residuals(values(u), sigma)["J"])
    # single shooting's Jacobian is a run with sensitivities (about 40 without): reused, refreshed by differences
    reuse = "differences" if method == "dynamic" and not start.size else None
    u, sigma, iterations, converged, rises = _fit(
        fun, u, lower, upper, sigma, given, first, lambda u, sigma: data.residuals(values(u), sigma, jacobian=False),
        npar, reuse, reuse and (lambda U, s: data.residuals_batch([*map(values, U)], s)))
    w = values(u)
    res = data.residuals(w, sigma)
    if method == "dynamic":
        data.check_sensitivities(w, sigma, res["J"])
    p, scale = w[:npar], derivative(u)[:npar]  # delta method in log coordinates
    r, J = res["r"], res["J"] * derivative(u)
    if start.size:  # the start states are nuisance unknowns: the parameters' columns with theirs projected out
        J = J[:, :npar] - J[:, npar:] @ np.linalg.lstsq(J[:, npar:], J[:, :npar], rcond=None)[0]
    widen, widening = secant(rises)  # where chi^2 rises more slowly than its linear model: wider
    dof, series = sum(float(np.sum(v)) for v in res["expected"].values()), len(m) if method == "seated" else None
    try:
        cov = covariance(J, r, scale, dof, series, widen)
        linear = cov if widen is None else covariance(J, r, scale, dof, series)
    except np.linalg.LinAlgError as e:  # e.g. residuals of measurements in the wrong units overflow
        raise MeasurementError(f"{m.source or 'measurements'}: the fit's covariance cannot be computed ({e}); are "
                               "the columns in SI units (m, rad, N m)?") from None
    if method == "dynamic" and len(given) == len(sigma) and not cov["reduced_chi2"] <= FIT_LIMIT:
        raise SimulationError(f"method 'dynamic': the fit does not reproduce the measurements (reduced chi^2 "
                              f"{cov['reduced_chi2']:.3g} with the noise levels given, allowed {FIT_LIMIT:g}): the "
                              "shooting ended in a local minimum (journals that rattle: the run it starts from is "
                              "too far from the measured one) or the noise levels given are too small; no estimate is "
                              "returned")
    friction = [q.key for q in params if q.kind == "friction"]
    explained = check_friction_explained(data, res, friction[0]) if method == "seated" and friction else None
    se = cov["standard_error"]
    interval, how = _intervals(params, u, lower, upper, se / scale, cov["inflation"],
                               cov["covariance"] / np.outer(scale, scale), cov["reduced_chi2"],
                               lambda v, jacobian: fun(v, jacobian, sigma), method == "seated")
    verdict = _verdict(J, params, se / scale, interval)
    poor = verdict["poorly_determined"]
    at_bound = tuple(q.key for q, v in zip(params, p, strict=True)
                     if min(v - q.lower, q.upper - v) <= 1e-9 * (q.upper - q.lower))
    # a barely determined parameter keeps its nominal value in the identified scene
    written = [q.nominal if q.key in poor else v for q, v in zip(params, p, strict=True)]
    try:
        identified = identified_scene(nominal, params, written)
    except SceneError as e:
        raise SceneError(f"identified scene: {e} (an estimate left the scene's allowed range; bound it with "
                         "parameters=)") from None
    yaml_data = None if identified is None else identified.data
    fit = {"samples": len(m), "residuals": int(r.size), "reduced_chi2": cov["reduced_chi2"], "chi2": cov["chi2"],
           "rms_residual": {c: float(np.sqrt(np.mean(v ** 2))) for c, v in res["raw"].items()},
           "iterations": iterations, "converged": bool(converged), "wall_time_s": time.perf_counter() - wall,
           "angles": "measured" if data.angles_measured else "prescribed by the drivers" if driven_scene(problem) else
           "controller references", "preload": data.preload,
           **({"friction_explained_ratio": explained[0], "friction_sliding_fraction": explained[1]}
              if explained is not None else {}),
           "effort_lag_s": data.lag, **({"simulations": data.runs, "sensitivity_disagreement": data.chaos,
                                         "sensitivity_disagreement_nominal": chaos_nominal}
                                        if method == "dynamic" else {}),
           **(_continuity(data, res["defect"]) if start.size else {}),
           "columns": data.columns(), "intervals": dict(zip([q.key for q in params], how, strict=True)),
           "model_error_inflation": [float(v) for v in cov["inflation"]],
           **({"secant": {**widening, "standard_error_linear": linear["standard_error"].tolist()}} if rises else {})}
    return Identification(
        method, tuple(params), p, se, interval, cov["covariance"],
        cov["correlation"], at_bound, sigma, {c: c not in given for c in sigma}, fit, verdict, m.t,
        {c: m.columns[c] for c in data.columns()}, res["prediction"], res["raw"], res["explained"], problem.scene,
        identified,
        yaml_data)
