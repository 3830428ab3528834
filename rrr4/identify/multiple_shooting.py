"""Method 'dynamic' with windows: multiple shooting (Bock 1981; Baake et al. 1992 for chaotic
data) for runs too sensitive to their parameters to shoot from t = 0.

The frames of the run (:class:`rrr4.identify.dynamic.DynamicData`) from the first measured
instant on are split into K windows of (nearly) equal length. Window 0 starts at the scene's
initial state, as single shooting does (or, when the measurements start after t = 0, from a
state s_0 that is an unknown too); each later window k starts at its own state s_k, the
mechanism's continuous state there (the stepped coordinates and their rates: with clearance
the tree coordinates, which place the journals in their clearances; not the energy
quadratures, which no output reads), an extra unknown of the fit. The unknowns are
w = [p, s_1, .., s_{K-1}]; they start from the single-shooting run with the parameters' start
values (the nominal ones, or with method 'staged' the seated fit's).

- **Journals keep their place in their clearance** (:func:`clearance_map`): s_k is the start
  state at the nominal clearances; a candidate's clearances scale each journal's eccentricity
  by their ratio to the nominal ones, so that a seated journal keeps its penetration (without
  that, 1 % of the clearance at a fixed state is 1 um against a penetration of about 0.3 um,
  and every window with a contact fails the check below).

- **Runs.** Each window is stepped by the same compiled frame as single shooting, in forward
  mode with the directions [parameters, state entries] (window 0: the parameters only), so
  one run gives the outputs' and the window's end state's exact sensitivities to p and to its
  own start state.
- **Discrete state at a window's start.** The contact flags, onset velocities and running
  maxima are taken from the end of the previous window of the same run (at a continuous
  solution: exactly what single shooting carries there), then the system's discrete update
  runs once at s_k, so that a journal that s_k places in its bearing wall is in contact with
  its onset velocity captured there. They enter the sensitivities as constants (flags are
  piecewise constant; an onset velocity's dependence is left out as in single shooting).
- **Continuity.** The defects d_k = y_end(window k-1) - (window k's start) are residuals with the heavy
  weight 1 / (:data:`DEFECT_SCALE` x the state's scale), a nanometre (nanoradian) against
  the measurements' micrometre, in the Levenberg-Marquardt of the other methods: the same
  bounded solver, and a relaxed start (defects may open while the fit is far off, Bock's
  argument for multiple shooting); at the estimate they are closed to well below the noise
  (reported as ``continuity_defect_max``).
- **Uncertainty.** The states are nuisance unknowns: the parameters' covariance is the
  parameter block of the full stacked problem's, computed as the Schur complement (the
  parameter columns with the state columns projected out; with the defects weighted this
  heavily it is the covariance under exact continuity).
- **Where it cannot work.** The chaos check of single shooting, per window: each window's
  sensitivities to the parameters against central differences of that window's run from its
  start state, +-:data:`~rrr4.identify.dynamic.FD_STEP` of each parameter's scale; a window
  whose disagreement exceeds :data:`~rrr4.identify.dynamic.CHAOS_LIMIT` is refused in one line
  that names it and a shorter window length. A fit that passes it but does not reproduce the
  measurements (a local minimum) is refused by :func:`rrr4.identify.identify` (its reduced
  chi^2 with the noise levels given).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..checks import describe
from ..errors import SceneError, SimulationError
from .dynamic import CHAOS_LIMIT, FD_STEP, DynamicData

__all__ = ["WindowedData", "check_windows", "first_frame", "STATE_SCALE", "DEFECT_SCALE", "MIN_FRAMES"]

STATE_SCALE = 1e-6  # the scale of a window's start coordinates [m or rad]; of their rates: this / frame length [s]
DEFECT_SCALE = 1e-3  # a continuity defect's weight: 1 / (this x the state's scale) (1 nm, 1 nrad against 1 um)
MIN_FRAMES = 2  # frames per window at least


def check_windows(windows, n_frames: int, dt: float) -> int:
    """The number of windows as an int, or a one-line SceneError: a whole number from 1 to the
    run's frames / MIN_FRAMES."""
    top = max(n_frames // MIN_FRAMES, 1)
    if isinstance(windows, bool) or not isinstance(windows, (int, np.integer)) or not 1 <= windows <= top:
        raise SceneError(f"windows: {describe(windows)} is not allowed (a whole number from 1 to {top}: each window "
                         f"holds at least {MIN_FRAMES} of the run's {n_frames} frames of {1e3 * dt:g} ms)")
    return int(windows)


def clearance_map(shooting: DynamicData) -> ca.Function:
    """'clearance_map' (c (n,), ratio (nc,), parameters) -> (coordinates (n,), d/dc, d/dratio):
    the stepped coordinates c with every clearance joint's eccentricity scaled by its clearance's
    ratio to the nominal one (the least change of c that does it, to first order: c + E^+
    ((ratio - 1) e), E = de/dc), so that a journal keeps its place in its clearance (a seated
    journal its penetration) when a candidate clearance changes. Built once per problem."""
    eqs, tree = shooting.eqs, shooting.tree

    def build():
        par, nc = eqs.parametric, len(eqs.clearance_joints)
        n = shooting.system.layout.nq
        c, ratio, P = ca.SX.sym("c", n), ca.SX.sym("ratio", nc), ca.SX.sym("parameters", len(eqs.parameters))
        q = par.tree_state(c, ca.SX.zeros(n), P)[0] if tree else c
        e = ca.vec(par.acceleration(q=q, qd=ca.SX.zeros(q.shape[0]), parameters=P)["eccentricity"])
        E = ca.jacobian(e, c)
        moved = c + E.T @ ca.solve(E @ E.T, ca.vec(ca.repmat(ca.transpose(ratio - 1), 2, 1)) * e)
        return ca.Function("clearance_map", [c, ratio, P], [moved, ca.jacobian(moved, c), ca.jacobian(moved, ratio)])
    return shooting.problem.memo(("identify_clearance_map", tree), build)


def first_frame(shooting: DynamicData) -> int:
    """The frame of the first measured instant (the first window's start)."""
    return int(np.floor(shooting.m.t[0] / shooting.dt + 1e-9))


class WindowedData:
    """The measured run predicted by K windows of single shooting coupled by continuity (see
    the module docstring): the interface of :class:`DynamicData` on the unknowns
    w = [p, s_1, .., s_{K-1}] (``nuisance_start``, ``nuisance_scale``: the states' initial
    values and scales)."""

    def __init__(self, shooting: DynamicData, windows: int, seed=None):
        self.shooting = s = shooting
        first = first_frame(s)
        self.windows = check_windows(windows, s.n_frames - first, s.dt)
        self.bounds = np.round(np.linspace(first, s.n_frames, self.windows + 1)).astype(int)
        self.free_first = first > 0  # a span after t = 0: its first window's start is an unknown too
        self.n_params = len(s.params)
        nq = s.system.layout.nq  # the stepped coordinates; their rates follow, then the quadratures
        self.n_state = 2 * nq
        motion = s.system.layout.in_x("motion")
        scale = np.r_[np.full(nq, STATE_SCALE), np.full(nq, STATE_SCALE / s.dt)]
        n_free = self.windows - 1 + self.free_first
        self.nuisance_scale = np.tile(scale, n_free)
        # the states' first values: the single-shooting run at the window starts with the parameters
        # `seed` (method 'staged': the seated fit's), else the nominal ones
        p0 = np.array([q.nominal for q in s.params] if seed is None else seed, float)
        x, S = s.start(p0, sensitivities=False)
        if self.free_first:
            x, *_ = s.roll(x, S, 0, first)
        self.before = x  # the nominal run's state at the first window's start (its discrete state)
        starts = [x[motion]] if self.free_first else []
        for a, b in zip(self.bounds[:-2], self.bounds[1:-1], strict=True):
            x, *_ = s.roll(x, S, a, b)
            starts.append(x[motion])
        self.nuisance_start = np.concatenate(starts) if starts else np.zeros(0)
        self.chaos, self.chaos_windows, self._cache = None, [], {}
        self.cmap = clearance_map(s)
        for name in ("problem", "m", "params", "angles_measured", "preload", "lag", "dt"):
            setattr(self, name, getattr(s, name))

    def columns(self) -> list[str]:
        return self.shooting.columns()

    def initial_noise(self) -> dict:
        return self.shooting.initial_noise()

    @property
    def runs(self) -> int:
        return self.shooting.runs

    def span(self, k: int) -> tuple[float, float]:
        """Window k's start and end [s]."""
        return self.bounds[k] * self.dt, self.bounds[k + 1] * self.dt

    # ------------------------------------------------------------------ the runs

    def state_columns(self, k: int) -> np.ndarray | None:
        """The columns of window k's start state among the unknowns w (None: the scene's initial state)."""
        j = k - 1 + self.free_first
        return None if j < 0 else self.n_params + j * self.n_state + np.arange(self.n_state)

    def ratios(self, p) -> tuple[np.ndarray, np.ndarray]:
        """Each clearance joint's clearance over its nominal one at the parameter values p (nc,),
        and its derivative (nc, np)."""
        clear = list(self.shooting.eqs.clearance_joints)
        ratio, R = np.ones(len(clear)), np.zeros((len(clear), self.n_params))
        for i, q in enumerate(self.params):
            if q.kind == "clearance":
                for j in q.joints:
                    ratio[clear.index(j)], R[clear.index(j), i] = p[i] / q.nominal, 1.0 / q.nominal
        return ratio, R

    def placed(self, k: int, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Window k's start state (n_state,) from its unknowns (the state with the nominal
        clearances, :func:`clearance_map`) at the parameters w[:np], and its derivatives to the
        parameters (n_state, np) and to the unknowns (n_state, n_state)."""
        p, own, n = w[:self.n_params], self.state_columns(k), self.n_state // 2
        ratio, R = self.ratios(p)
        moved, Jc, Jr = self.cmap(w[own[:n]], ratio, self.shooting.contact_numbers(p))
        d_s = np.eye(self.n_state)
        d_s[:n, :n] = np.array(Jc)
        d_p = np.zeros((self.n_state, self.n_params))
        d_p[:n] = np.array(Jr) @ R
        return np.r_[np.array(moved).ravel(), w[own[n:]]], d_p, d_s

    def _window_start(self, k: int, w: np.ndarray, previous_end: np.ndarray, sensitivities: bool):
        """(x, S) at a free window start: its placed state (:meth:`placed`), the discrete state
        carried from the previous window's end (the first window: the nominal run's) and updated
        there (an implicit method's memory started again), and the sensitivities (nx, np +
        n_state) to the parameters and the window's unknowns (no columns without
        `sensitivities`)."""
        s, system, npar = self.shooting, self.shooting.system, self.n_params
        ny, nz, motion = system.ny, system.nz, system.layout.in_x("motion")
        x = previous_end[:1 + ny + nz].copy()
        start, d_p, d_s = self.placed(k, w)
        x[motion] = start
        x[s.parameter_rows] = s.contact_numbers(w[:npar])
        x[1 + ny:] = np.array(system.discrete(x[0], x[1:1 + ny], x[1 + ny:])).ravel()
        extra = getattr(s.method, "initial_extra", None)
        x = np.r_[x, extra(system, x, s.u[self.bounds[k]])] if extra else x
        S = np.zeros((x.size, npar + self.n_state if sensitivities else 0))
        if sensitivities:
            S[s.parameter_rows, :npar] = s.derivatives(w[:npar])
            S[motion, :npar] = d_p
            S[motion, npar:] = d_s
        return x, S

    def run(self, w, sensitivities: bool = True):
        """(o (n_frames, n_out), dO (n_frames, n_out, n_w) or None, defects (K-1, n_state), their
        Jacobian (K-1, n_state, n_w) or None, the state each window starts from (the previous
        window's end, the nominal run's before the first)) at the unknowns w."""
        w = np.asarray(w, float)
        key = tuple(w.tolist())
        if key in self._cache and (self._cache[key][1] is not None or not sensitivities):
            return self._cache[key]
        s, npar, ns, K = self.shooting, self.n_params, self.n_state, self.windows
        s.runs += 1
        nw = w.size
        o_all, do_all = None, None
        defects, dD, before = np.zeros((K - 1, ns)), np.zeros((K - 1, ns, nw)), []
        x, S = (self.before, None) if self.free_first else s.start(w[:npar], sensitivities)
        for k in range(K):
            a, b = self.bounds[k], self.bounds[k + 1]
            own = self.state_columns(k)
            before.append(x)
            if own is not None:
                x, S = self._window_start(k, w, x, sensitivities)
            x, S, o, do = s.roll(x, S, a, b)
            if o_all is None:
                o_all = np.zeros((s.n_frames, o.shape[1]))
                do_all = np.zeros((s.n_frames, o.shape[1], nw)) if sensitivities else None
            o_all[a:b] = o
            cols = np.arange(npar) if own is None else np.r_[np.arange(npar), own]
            if sensitivities:
                do_all[a:b][:, :, cols] = do
            if k < K - 1:  # continuity: this window's end is where the next one is placed
                nxt = self.state_columns(k + 1)
                start, d_p, d_s = self.placed(k + 1, w)
                defects[k] = x[1:1 + ns] - start
                if sensitivities:
                    dD[k][:, cols] = S[1:1 + ns]
                    dD[k][:, :npar] -= d_p
                    dD[k][:, nxt] -= d_s
        if not (np.all(np.isfinite(o_all)) and np.all(np.isfinite(defects))
                and (do_all is None or np.all(np.isfinite(do_all)))):
            values = dict(zip([q.key for q in self.params], w[:npar].tolist(), strict=True))
            raise SimulationError(f"integrator.step: the windowed run of {self.problem.name!r} is not finite with the "
                                  f"parameters {values}")
        if len(self._cache) > 8:
            self._cache.clear()
        out = (o_all, do_all, defects, dD if sensitivities else None, before)
        self._cache[key] = out
        return out

    def residuals(self, w, sigma: dict, jacobian: bool = True) -> dict:
        """As :meth:`DynamicData.residuals`, with the weighted continuity defects after the
        measurements' residuals (``r``, ``J`` (M + (K-1) n_state, n_w)); ``defect``: the
        defects (K-1, n_state) [m, rad; m/s, rad/s]."""
        o, do, d, dD, _ = self.run(w, jacobian)
        res = self.shooting.residuals_of(*self.shooting.at_measured(o, do), sigma, jacobian)
        weight = 1.0 / (DEFECT_SCALE * self.nuisance_scale[:self.n_state])
        res["r"] = np.r_[res["r"], (d * weight).ravel()]
        if jacobian:
            res["J"] = np.vstack([res["J"], (dD * weight[None, :, None]).reshape(-1, dD.shape[2])])
        res["defect"] = d
        return res

    # ------------------------------------------------------------------ the check

    def check_sensitivities(self, w, sigma: dict, J=None) -> float:
        """The largest relative disagreement over the windows of each window's sensitivities to
        the parameters and central differences of its run from its start state; SimulationError
        naming the first window beyond CHAOS_LIMIT (`J` is not used: each window's own
        sensitivities are compared)."""
        s, npar = self.shooting, self.n_params
        w = np.asarray(w, float)
        o, do, _, _, starts = self.run(w, True)

        def rows(o_k, do_k, a, b):  # the whitened residuals' change with window k's outputs only
            o_full, do_full = o.copy(), np.zeros_like(do[:, :, :npar])
            o_full[a:b] = o_k
            if do_k is not None:
                do_full[a:b] = do_k
            res = s.residuals_of(*s.at_measured(o_full, do_full if do_k is not None else None), sigma,
                                 do_k is not None)
            return res["J"] if do_k is not None else res["r"]

        p = w[:npar]
        scale = max(float(np.linalg.norm(s.residuals_of(*s.at_measured(o, do[:, :, :npar]), sigma)["J"])), 1e-300)
        worst, self.chaos_windows = 0.0, []
        for k in range(self.windows):
            a, b = self.bounds[k], self.bounds[k + 1]
            J_k = rows(o[a:b], do[a:b, :, :npar], a, b)
            cols = []
            for i in range(npar):
                up, down = s.shifted(p, i, FD_STEP), s.shifted(p, i, -FD_STEP)
                r = []
                for v in (up, down):
                    if self.state_columns(k) is None:
                        x = s.start(v, False)[0]
                    else:
                        x = self._window_start(k, np.r_[v, w[npar:]], starts[k], False)[0]
                    r.append(rows(s.roll(x, np.zeros((x.size, 0)), a, b)[2], None, a, b))
                cols.append((r[0] - r[1]) / (up[i] - down[i]))
            J_cd = np.column_stack(cols)
            d = float(np.linalg.norm(J_k - J_cd) / max(np.linalg.norm(J_cd), 1e-6 * scale))
            self.chaos_windows.append(d)
            worst = max(worst, d)
            if not d <= CHAOS_LIMIT:
                self.chaos = worst
                t0, t1 = self.span(k)
                raise SimulationError(self._refusal(k, t0, t1, d))
        self.chaos = worst
        return worst

    def _refusal(self, k: int, t0: float, t1: float, d: float) -> str:
        frames = self.bounds[-1] - self.bounds[0]
        more = min(2 * self.windows, max(frames // MIN_FRAMES, 1))
        hint = (f"use shorter windows (windows={more}, --windows {more}: about "
                f"{1e3 * frames * self.dt / more:.3g} ms each)" if more > self.windows else
                "the windows cannot be shorter; fit a shorter span, or a preloaded run with 'seated'")
        return (f"method 'dynamic': window {k + 1} of {self.windows} ({1e3 * t0:.3g} to {1e3 * t1:.3g} ms) is too "
                f"sensitive to its parameters for shooting (its sensitivities and central differences of runs "
                f"+-{100 * FD_STEP:g} % of a parameter's scale differ by {100 * d:.0f} %, allowed "
                f"{100 * CHAOS_LIMIT:.0f} %): journals that rattle make it chaotic over that window; {hint}")
