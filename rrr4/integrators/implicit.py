"""Shared machinery of the implicit fixed-step methods (Bathe, Newmark, generalised-alpha).

The systems of rrr4 are second order: y = [q, v, e] with q' = v, v' = a(t, q, v, z, u) (the
builder's index-1 acceleration, constraint forces included) and quadratures e' = p(t, q, v)
(actuator work, dissipation) that feed nothing back. Every implicit stage of the methods
here has the form

    q = r_q + c_q v,    v = r_v + c_v a(t, q, v),    e = r_e + c_e p(t, q, v),

so Newton runs on the nq velocities only, with the iteration matrix
G = I - c_v (A_v + c_q A_q) (A_q = da/dq, A_v = da/dv). G is sparse (on the 4-RRR with 8
clearance joints, 40 % of 19 x 19 in tree coordinates, 31 % of 27 x 27 in reference-point
ones); it is factorised by a sparse Householder QR whose pattern is fixed when the
step is built (``casadi.qr_sparse``), so a factorisation and a solve are straight-line code.

Two Newton variants (``integrator.newton``, :data:`NEWTON`):

- ``simplified`` (default): the factors of G are part of the integrator's state and are
  reused across iterations and steps. They are renewed at the start of a stage when the
  stage's (c_q, c_v) differ from those they were built with (a step-size change, e.g. the
  refined sub-steps of a contact event), after a step in which a contact opened or closed,
  and after a stage that converged slowly (contraction rate above :data:`SLOW`). A stage
  whose simplified iterations diverge or do not converge within :data:`SIMPLIFIED` falls
  back to full Newton from its predictor, and the factors are renewed at the next step.
  Convergence: the update is below ``newton_tol`` (relative to 1 + max|v|), or the
  estimated remaining error theta / (1 - theta) |dv| is (theta: contraction rate).
- ``full``: a new Jacobian and factorisation at every iteration (quadratic convergence,
  the most work per step).

Each iteration is one Function behind a ``Function.if_else`` switch, so the compiled code
skips the iterations a converged stage does not need. The state carries counters over the
run: Newton iterations, stages that hit ``max_newton`` without converging, and Jacobian
evaluations (each Jacobian is factorised once, so it also counts factorisations).
"""

from __future__ import annotations

import copy
from abc import abstractmethod

import casadi as ca
import numpy as np

from ..errors import Rrr4Error
from ..scene.vocabulary import NEWTON
from .base import FixedStepIntegrator, Run, System, frame_inputs
from .error_control import ADAPTIVE, adaptive_frame, initial_adaptive

__all__ = ["ImplicitIntegrator", "second_order_split", "NEWTON"]

SIMPLIFIED = 6  # simplified iterations of a stage before it falls back to full Newton
SLOW = 0.1  # contraction rate above which the factors are renewed for the next step
ETA_MIN = 0.01  # floor of the carried error estimate: one update is accepted only if 100 x below tolerance
COUNTERS = ("newton_iterations", "newton_failures", "jacobians")


def second_order_split(system: System) -> int:
    """nq such that y = [q (nq), v (nq), e] with q' = v and y' independent of e; raises Rrr4Error if none."""
    ny = system.ny
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", ny), ca.SX.sym("z", system.nz), ca.SX.sym("u", system.nu)
    f = system.ode(t, y, z, u)
    for nq in range(ny // 2, 0, -1):
        if all(ca.is_equal(f[i], y[nq + i]) for i in range(nq)) and not ca.depends_on(f, y[2 * nq:]):
            return nq
    raise Rrr4Error("implicit integrators need a second-order system y = [q, v, quadratures] with q' = v")


def _norm(dv):
    """max |dv|, and +inf if dv holds a NaN or an inf (norm_inf alone is 0 for NaN: C's fmax
    drops NaN, so a NaN update would pass for a converged one). |sum| < inf is false for NaN
    and inf; the obvious sum - sum == 0 is not, as CasADi simplifies x - x to 0."""
    return ca.if_else(ca.fabs(ca.sum1(dv)) < np.inf, ca.norm_inf(dv), np.inf)


def _skippable(name: str, f: ca.Function, skipped) -> ca.Function:
    """``Function.if_else`` of f and a cheap stand-in: switch(skip, *f's inputs); skipped(*inputs) -> outputs."""
    ins = [ca.MX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    skip = ca.Function(f"{name}_skip", ins, list(skipped(*ins)), f.name_in(), f.name_out())
    return ca.Function.if_else(name, skip, f)


class _Newton:
    """A stage's Newton solvers for one system (see the module docstring), built once.

    pars = [t, r_q, r_v, c_q, c_v, z, u]; p: the quadratures' rates at the last iterate.

    - factor_switch(keep, v, factors, pars) -> factors: the QR factors of G at v (size
      n_factors), or the given ones when keep;
    - simplified(v_guess, factors, eta, pars) -> v, p, converged, slow, eta, iterations;
    - full_switch(skip, v_guess, p, pars) -> v, p, converged, iterations (a new Jacobian and
      factorisation per iteration; skipped entirely when skip).

    Iterations past the first sit behind ``Function.if_else`` switches nested so that a
    converged stage costs one switch, not one per unrolled iteration."""

    def __init__(self, system: System, nq: int, tol: float, max_newton: int):
        ne = system.ny - 2 * nq
        v, tt, w = ca.SX.sym("v", nq), ca.SX.sym("t"), ca.SX.sym("p", ne)
        rq, rv, cq, cv = ca.SX.sym("r_q", nq), ca.SX.sym("r_v", nq), ca.SX.sym("c_q"), ca.SX.sym("c_v")
        z, u = ca.SX.sym("z", system.nz), ca.SX.sym("u", system.nu)
        pars = ca.vertcat(tt, rq, rv, cq, cv, z, u)
        f = system.ode(tt, ca.vertcat(rq + cq * v, v, ca.SX.zeros(ne)), z, u)
        a, p = f[nq:2 * nq], f[2 * nq:]  # p: the quadratures' rates at the iterate (no extra RHS)
        res = v - rv - cv * a
        jac = ca.jacobian(res, v)
        V, R, beta, prinv, pc = ca.qr_sparse(jac)
        self.n_pars = pars.shape[0]

        dv = -ca.solve(jac, res)
        v1 = v + dv
        full = ca.Function("newton_full", [v, w, pars], ca.cse([v1, p, _norm(dv) <= tol * (1 + ca.norm_inf(v1))]),
                           ["v", "p", "pars"], ["v_next", "p_next", "converged"])

        factors = ca.vertcat(*V.nonzeros(), *R.nonzeros(), beta)
        self.n_factors = factors.shape[0]
        f_in = ca.SX.sym("factors", self.n_factors)
        nv, nr = V.nnz(), R.nnz()
        Vs = ca.SX(V.sparsity(), f_in[:nv])
        Rs = ca.SX(R.sparsity(), f_in[nv:nv + nr])
        dv = -ca.qr_solve(res, Vs, Rs, f_in[nv + nr:], prinv, pc)
        v1 = v + dv
        one = ca.Function("newton_simplified", [v, w, f_in, pars],
                          ca.cse([v1, p, _norm(dv), 1 + ca.norm_inf(v1)]),
                          ["v", "p", "factors", "pars"], ["v_next", "p_next", "step", "scale"])
        self.factor = ca.Function("newton_factor", [v, f_in, pars], ca.cse([factors]), ["v", "factors", "pars"],
                                  ["factors_next"])
        self.factor_switch = _skippable("newton_factor_switch", self.factor, lambda v, f, _: (f,))
        self.update = one
        self.simplified = self._simplified(one, nq, ne, tol)
        self.full_switch = self._full(full, nq, ne, max_newton)

        # a stage's rate: from its own equation when Newton converged, else the RHS at the iterate
        ts, ys, zs, us = (ca.MX.sym(k, n) for k, n in (("t", 1), ("y", system.ny), ("z", system.nz), ("u", system.nu)))
        vs, rvs, cvs, ps = ca.MX.sym("v", nq), ca.MX.sym("r_v", nq), ca.MX.sym("c_v"), ca.MX.sym("p", ne)
        ins = [ts, ys, zs, us, vs, rvs, cvs, ps]
        self.rate = ca.Function.if_else(
            "stage_rate", ca.Function("rate_converged", ins, [ca.vertcat(vs, (vs - rvs) / cvs, ps)]),
            ca.Function("rate_evaluated", ins, [system.ode(ts, ys, zs, us)]))

    def _simplified(self, one: ca.Function, nq: int, ne: int, tol: float) -> ca.Function:
        """Simplified iterations with fixed factors. Stops when the update, or the estimated
        remaining error eta |dv| (eta = theta / (1 - theta), carried from the last stage and
        floored at ETA_MIN), is below tol (1 + |v|); gives up (converged = 0) when an update
        grows (theta >= 1, or NaN) or after SIMPLIFIED iterations; slow: theta > SLOW."""
        v, w, fac, pars = (ca.MX.sym(k, n) for k, n in (("v", nq), ("p", ne), ("factors", self.n_factors),
                                                       ("pars", self.n_pars)))
        eta, prev = ca.MX.sym("eta"), ca.MX.sym("prev")
        names_in = ["v", "p", "factors", "pars", "eta", "prev"]
        names_out = ["v_next", "p_next", "eta_next", "prev_next", "converged", "bad", "slow", "iterations"]

        def later(i, inner):
            """Iterations i.. (i >= 1): one update, then the rest behind a switch."""
            v1, p1, step, scale = one(v, w, fac, pars)
            theta = step / prev
            ok = theta < 1
            eta1 = ca.if_else(ok, ca.fmax(theta / (1 - theta), ETA_MIN), eta)
            conv = ok * ca.logic_or(step <= tol * scale, eta1 * step <= tol * scale)
            bad, slow = ca.logic_not(ok), theta > SLOW
            outs = [v1, p1, eta1, step, conv, bad, slow, ca.MX(1)]
            if inner is not None:
                r = inner(ca.logic_or(conv, bad), v1, p1, fac, pars, eta1, step)
                outs = [*r[:4], ca.fmax(conv, r[4]), ca.fmax(bad, r[5]), ca.fmax(slow, r[6]), 1 + r[7]]
            f = ca.Function(f"newton_simplified_{i}", [v, w, fac, pars, eta, prev], outs, names_in, names_out)
            return _skippable(f"newton_simplified_{i}_switch", f,
                              lambda v, w, f_, p_, e, s: (v, w, e, s, ca.MX(0), ca.MX(0), ca.MX(0), ca.MX(0)))

        inner = None
        for i in range(SIMPLIFIED - 1, 0, -1):
            inner = later(i, inner)
        # the first update: always taken; converged on its own size or on eta carried over
        v1, p1, step, scale = one(v, ca.MX.zeros(ne), fac, pars)
        conv = ca.logic_or(step <= tol * scale, eta * step <= tol * scale)
        r = inner(conv, v1, p1, fac, pars, eta, step)
        converged = ca.fmax(conv, r[4] * (1 - r[5]))
        return ca.Function("newton_simplified_stage", [v, fac, eta, pars],
                           [r[0], r[1], converged, r[6], r[2], 1 + r[7]],
                           ["v", "factors", "eta", "pars"], ["v_next", "p_next", "converged", "slow", "eta_next",
                                                             "iterations"])

    @staticmethod
    def _full(full: ca.Function, nq: int, ne: int, max_newton: int) -> ca.Function:
        """Up to max_newton full Newton iterations (each skipped once converged), as one switch."""
        v, w, pars = ca.MX.sym("v", nq), ca.MX.sym("p", ne), ca.MX.sym("pars", full.size1_in(2))
        step = _skippable("newton_full_switch", full, lambda v, w, _: (v, w, ca.MX(1)))
        vk, pk, done, iters = v, w, ca.MX(0), ca.MX(0)
        for _ in range(max_newton):
            iters += 1 - done
            vk, pk, conv = step(done, vk, pk, pars)
            done = ca.fmax(done, conv)
        solve = ca.Function("newton_full_stage", [v, w, pars], [vk, pk, done, iters], ["v", "p", "pars"],
                            ["v_next", "p_next", "converged", "iterations"])
        return _skippable("newton_full_stage_switch", solve, lambda v, w, _: (v, w, ca.MX(1), ca.MX(0)))


class ImplicitIntegrator(FixedStepIntegrator):
    """Base of the implicit methods: subclasses implement :meth:`advance_implicit` with :meth:`stage`.

    newton: 'simplified' or 'full' (see the module docstring); newton_tol: relative
    velocity-update tolerance; max_newton: full Newton iterations per stage. A method may
    keep `memory_size` extra state entries between steps (e.g. the acceleration-like
    variable of generalised-alpha), initialised by :meth:`initial_memory`, and says how many
    distinct stage matrices (c_q, c_v) one step uses (`matrices`).
    """

    def __init__(self, jit: bool = False, newton: str = "simplified", newton_tol: float = 1e-10,
                 max_newton: int = 8, refine: int = 1, tolerance: float | None = None):
        super().__init__(jit=jit, refine=refine)
        if tolerance is not None and not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance)
                                          and tolerance > 0):
            raise Rrr4Error(f"integrator.tolerance: {tolerance!r} is not allowed (a local position error per "
                            "step > 0 [m], or none for fixed steps)")
        self.tolerance = None if tolerance is None else float(tolerance)
        if newton not in NEWTON:
            raise Rrr4Error(f"integrator.newton: {newton!r} is not allowed (choose from {', '.join(NEWTON)})")
        if not (np.isfinite(newton_tol) and newton_tol > 0):
            raise Rrr4Error(f"integrator.newton_tol: {newton_tol!r} is not allowed (must be > 0)")
        if int(max_newton) < 1:
            raise Rrr4Error(f"integrator.max_newton: {max_newton!r} is not allowed (must be >= 1)")
        self.newton, self.newton_tol, self.max_newton = newton, float(newton_tol), int(max_newton)

    @staticmethod
    def newton_settings(settings) -> dict:
        """The Newton keywords of a scene's IntegratorSettings."""
        return {"newton": settings.newton, "newton_tol": settings.newton_tol, "max_newton": settings.max_newton,
                "refine": settings.refine, "tolerance": settings.tolerance}

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        return cls(jit=jit, **cls.newton_settings(settings))

    # the stages' derivative (Function.forward): through the Newton iterations (False), or the
    # implicit function's (True): the iterations and their bookkeeping (counters, simplified
    # Newton's factors) held constant (no_grad), then one more update at the converged stage with
    # G factorised there, held constant too, whose derivative is the implicit function's,
    # dv = -G^-1 (dres/dpars) dpars: exact where the stage converged, for full and simplified
    # Newton alike (whose reused factors have no exact derivative of their own); no second
    # derivatives of the acceleration, one solve. The quadratures' rates p are taken before that
    # update (their derivative misses dp/dv dv: nothing reads them back, and no output does)
    implicit_derivative = False

    # ---- what a method implements
    matrices = 1  # distinct (c_q, c_v) among the stages of one step

    def memory_size(self, nq: int) -> int:
        return 0

    def initial_memory(self, f0, nq: int):
        """Memory at t0 from f0 = y'(t0) (symbolic or numeric)."""
        return f0[:0]

    @abstractmethod
    def advance_implicit(self, stage, ode, t, y, z, u, h, memory, nq):
        """(y_next, memory_next, rates) of one step: rates [(s, f(y(t + s h))), ...] from s = 0 to
        s = 1 at the step's start, its stages and its end (for the error estimate);
        `stage(t, r, c, v_guess)` solves one implicit stage (r = (r_q, r_v, r_e), c = (c_q, c_v,
        c_e)) and returns (Y, f(Y))."""

    def advance(self, ode, t, y, z, u, h):  # the memory-free interface of FixedStepIntegrator
        raise NotImplementedError("implicit methods step through step_function")

    # ---- machinery
    def _layout(self, system: System, nq: int) -> tuple[int, int, int]:
        """(size of the method's memory, factors per matrix slot, extra state entries after
        [t, y, z]): memory, the counters, a renew flag, then per slot (c_q, c_v, eta, factors)."""
        nm = self.memory_size(nq)
        nf = _newton(system, nq, self.newton_tol, self.max_newton).n_factors if self.newton == "simplified" else 0
        slots = self.matrices * (3 + nf) if nf else 0
        return nm, nf, nm + len(COUNTERS) + 1 + slots

    def step_function(self, system: System, h: float) -> ca.Function:
        """MX Function 'step': x = [t, y, z, memory, counters, renew, matrix slots], u -> x_next."""
        return self.estimated_step_function(system, h, error=False)

    def error_constant(self) -> float:
        """C of the local position error C h^3 q''' of one step, measured on q'' = t from the
        exact state at t = 0 with h = 1 (exact: q(1) = 1/6); 1/12 for the trapezoidal rule."""
        if "_error_constant" not in vars(self):
            t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", 2), ca.SX.sym("z", 0), ca.SX.sym("u", 0)
            test = System(ca.Function("ode", [t, y, z, u], [ca.vertcat(y[1], t)]),
                          ca.Function("discrete", [t, y, z], [z]))
            method = copy.copy(self)
            method.newton, method.tolerance = "full", None
            x0 = np.r_[0.0, 0.0, 0.0, method.initial_extra(test, np.zeros(3), np.zeros(0))]
            x1 = np.array(method.step_function(test, 1.0)(x0, np.zeros(0))).ravel()
            self._error_constant = abs(float(x1[1]) - 1.0 / 6.0)
        return self._error_constant

    def estimated_step_function(self, system: System, h: float | None, error: bool = True) -> ca.Function:
        """MX Function 'estimated_step': x, u (, h) -> x_next, error (h an input when None, as
        error control needs, else fixed in the graph); with error=False, 'step': x, u -> x_next
        (one Function, not a wrapper, whose output would be one more copy of the state per
        step). One step and, with a tolerance, the
        estimate of its local position error C h^2 max |a(t + h) - a(t)| over the coordinates
        [m or rad] (C: :meth:`error_constant`; Zienkiewicz & Xie 1991 for the trapezoidal rule).
        A method with inner stages (Bathe) takes the steepest of the differences between
        consecutive stages over their fraction of the step, so that a contact force that rises
        and falls inside the step is seen. +inf if the step is not finite."""
        nq = second_order_split(system)
        ny, nz = system.ny, system.nz
        nm, nf, extra = self._layout(system, nq)
        newton = _newton(system, nq, self.newton_tol, self.max_newton)
        x, u = ca.MX.sym("x", 1 + ny + nz + extra), ca.MX.sym("u", system.nu)
        h_in = [ca.MX.sym("h")] if h is None else []
        h = h_in[0] if h_in else h

        def per_h(c) -> float:
            """c / h as a number (the stage coefficients are multiples of h)."""
            return float(ca.Function("per_h", h_in, [c / h])(1.0)) if h_in else float(c) / h
        t, y, z = x[0], x[1:1 + ny], x[1 + ny:1 + ny + nz]
        o = 1 + ny + nz
        mem = x[o:o + nm]
        o += nm
        count = dict(zip(COUNTERS, ca.vertsplit(x[o:o + len(COUNTERS)]), strict=True))
        renew = x[o + len(COUNTERS)]
        o += len(COUNTERS) + 1
        slots = [x[o + k * (3 + nf):o + (k + 1) * (3 + nf)] for k in range(self.matrices)] if nf else []
        used: list[tuple[float, float]] = []
        flags = {"renew_next": ca.MX(0)}

        ne = ny - 2 * nq

        def full_newton(pars, v_guess, p_guess, skip):
            vk, pk, done, iters = newton.full_switch(skip, v_guess, p_guess, pars)
            count["newton_iterations"] += iters
            count["jacobians"] += iters
            count["newton_failures"] += 1 - done
            return vk, pk, done

        def simplified_newton(pars, v_guess, c_q, c_v):
            sig = (per_h(c_q), per_h(c_v))
            key = next((c for c in used if np.allclose(c, sig, rtol=1e-9, atol=0)), sig)
            if key not in used:
                used.append(key)
            k = used.index(key)
            if k >= len(slots):
                raise AssertionError(f"{type(self).__name__}.matrices is too small")
            tag, eta, factors = slots[k][:2], slots[k][2], slots[k][3:]
            key_h = ca.vertcat(key[0] * h, key[1] * h)  # one expression per slot: equal stages compare equal
            stale = ca.fmax(renew, ca.norm_inf(tag - key_h) > 0)
            factors = newton.factor_switch(1 - stale, v_guess, factors, pars)
            count["jacobians"] += stale
            vk, pk, done, slow, eta, iters = newton.simplified(v_guess, factors, ca.if_else(stale, 1.0, eta), pars)
            count["newton_iterations"] += iters
            # not converged: full Newton from the predictor, and new factors at the next step
            fallback = 1 - done
            flags["renew_next"] = ca.fmax(flags["renew_next"], ca.fmax(slow, fallback))
            v_full, p_full, converged = full_newton(pars, v_guess, pk, done)
            slots[k] = ca.vertcat(key_h, eta, factors)
            return ca.if_else(fallback, v_full, vk), ca.if_else(fallback, p_full, pk), converged

        def stage(ts, r, c, v_guess):
            """(Y, f(Y)): the stage's state and its rate. Converged, a = (v - r_v) / c_v from the
            stage's own equation and the quadrature rates of the last iterate (no further RHS);
            not converged, the RHS at Y."""
            (r_q, r_v, r_e), (c_q, c_v, c_e) = r, c
            pars = ca.vertcat(ts, r_q, r_v, c_q, c_v, z, u)
            if nf:
                vk, pk, converged = simplified_newton(pars, v_guess, c_q, c_v)
            else:
                vk, pk, converged = full_newton(pars, v_guess, ca.MX.zeros(ne), ca.MX(0))
            if self.implicit_derivative:  # one more update, with G factorised at the solution held constant
                vk, pk, converged = ca.no_grad(vk), ca.no_grad(pk), ca.no_grad(converged)
                factors = ca.no_grad(newton.factor(vk, ca.MX.zeros(newton.n_factors), ca.no_grad(pars)))
                vk, pk = newton.update(vk, ca.MX.zeros(ne), factors, pars)[:2]
            qk = r_q + c_q * vk
            yk = ca.vertcat(qk, vk, r_e + c_e * pk)
            return yk, newton.rate(converged, ts, yk, z, u, vk, r_v, c_v, pk)

        y1, mem1, rates = self.advance_implicit(stage, system.ode, t, y, z, u, h, mem, nq)
        z1 = system.update(t + h, y1, z, u)
        ne = system.events
        contact_changed = ca.norm_inf(z1[:ne] - z[:ne]) > 0 if ne else ca.MX(0)
        renew1 = ca.fmax(flags["renew_next"], contact_changed)
        kept = [*count.values(), renew1, *slots]  # the iterations' bookkeeping: no derivative through it
        x1 = ca.vertcat(t + h, y1, z1, mem1, *(map(ca.no_grad, kept) if self.implicit_derivative else kept))
        if not error:
            return ca.Function("step", [x, u, *h_in], [x1], ["x", "u", *(["h"] if h_in else [])], ["x_next"])
        estimate = ca.MX(0)
        if self.tolerance is not None:  # the steepest change of the acceleration between rate points
            slopes = [_norm(fb[nq:2 * nq] - fa[nq:2 * nq]) / (sb - sa)
                      for (sa, fa), (sb, fb) in zip(rates[:-1], rates[1:], strict=True)]
            estimate = ca.if_else(_norm(y1) < np.inf,
                                  self.error_constant() * h * h * ca.mmax(ca.vertcat(*slopes)), np.inf)
        return ca.Function("estimated_step", [x, u, *h_in], [x1, estimate], ["x", "u", *(["h"] if h_in else [])],
                           ["x_next", "error"])

    def frame_function(self, system: System, h: float, steps_per_frame: int) -> ca.Function:
        """As :meth:`FixedStepIntegrator.frame_function`, or with a tolerance the adaptive frame of
        :mod:`.error_control` (h: the largest step)."""
        if self.tolerance is None:
            return super().frame_function(system, h, steps_per_frame)
        nq = second_order_split(system)
        counters = 1 + system.ny + system.nz + self.memory_size(nq)
        return adaptive_frame(self, system, h, steps_per_frame, counters, len(COUNTERS),
                              counters + COUNTERS.index("newton_failures"))

    def derivative_frame_function(self, system: System, h: float, steps_per_frame: int) -> ca.Function:
        """As :meth:`FixedStepIntegrator.derivative_frame_function`, the stages differentiated as
        implicit functions (:attr:`implicit_derivative`: not through the Newton iterations, which
        the frame evaluates once)."""
        if self.tolerance is not None:
            raise Rrr4Error(f"integrator.tolerance: {self.tolerance!r} is not allowed in a frame differentiated as "
                            "implicit functions (fixed steps only)")
        method = copy.copy(self)
        method.implicit_derivative = True
        return FixedStepIntegrator.derivative_frame_function(method, system, h, steps_per_frame)

    def initial_extra(self, system: System, x0, u0) -> np.ndarray:
        """The entries after [t, y, z] at the start of a run: memory, zero counters, renew on."""
        nq = second_order_split(system)
        ny, nz = system.ny, system.nz
        y0 = x0[1:1 + ny]
        z0 = x0[1 + ny:1 + ny + nz]
        f0 = np.array(system.ode(x0[0], y0, z0, system.held(y0, z0, u0))).ravel()
        mem0 = np.asarray(self.initial_memory(f0, nq), float).ravel()
        _, _, extra = self._layout(system, nq)
        out = np.zeros(extra)
        out[:mem0.size] = mem0
        out[mem0.size + len(COUNTERS)] = 1.0  # renew at the first stage
        return out if self.tolerance is None else np.r_[out, initial_adaptive()]

    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int | None = None,
            progress: bool = False, every: int = 1, sink=None) -> Run:
        """As :meth:`FixedStepIntegrator.run`, with the Newton counters in the statistics."""
        x0 = np.asarray(x0, float)
        u_frames = frame_inputs(u_frames)
        u0 = u_frames[:1][0]
        nq = second_order_split(system)
        nm = self.memory_size(nq)
        states, last, stepping = self.roll(system, np.r_[x0, self.initial_extra(system, x0, u0)], u_frames, h,
                                           steps_per_frame, chunk, progress, every=every, sink=sink)
        counts = dict(zip(COUNTERS, (int(round(c)) for c in last[x0.size + nm:x0.size + nm + len(COUNTERS)]),
                          strict=True))
        n_steps = steps_per_frame * u_frames.shape[0]
        stats = {"newton": self.newton, **counts, "stepping": stepping}
        if self.tolerance is not None:
            a = dict(zip(ADAPTIVE, last[-len(ADAPTIVE):], strict=True))
            n_steps = int(a["accepted_steps"])
            stats.update({"tolerance": self.tolerance, "steps": n_steps, "rejected_steps": int(a["rejected_steps"]),
                          "steps_above_tolerance": int(a["steps_above_tolerance"]),
                          "smallest_step": h / 2 ** a["deepest_level"]})
            if a["failed"]:
                stats["failure"] = {"t": float(last[0]), "step": h / 2 ** a["level"]}
        stats.update({f"{k}_per_step": counts[k] / max(n_steps, 1) for k in ("newton_iterations", "jacobians")})
        return Run(states, stats)


def _newton(system: System, nq: int, tol: float, max_newton: int) -> _Newton:
    """The Newton solvers of a system (built once per system and settings, kept on the system)."""
    key = ("newton", nq, tol, max_newton)
    if key not in system.frames:
        system.frames[key] = _Newton(system, nq, tol, max_newton)
    return system.frames[key]
