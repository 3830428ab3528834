"""Shared machinery of the implicit fixed-step methods (Bathe, Newmark, generalised-alpha).

The systems of rrr4 are second order: y = [q, v, e] with q' = v, v' = a(t, q, v, z, u) (the
builder's index-1 acceleration, constraint forces included) and quadratures e' = p(t, q, v)
(actuator work, dissipation) that feed nothing back. Every implicit stage of the methods
here has the form

    q = r_q + c_q v,    v = r_v + c_v a(t, q, v),    e = r_e + c_e p(t, q, v),

so Newton runs on the nq velocities only, with the exact Jacobian
I - c_v (A_v + c_q A_q) (A_q = da/dq, A_v = da/dv). Each Newton iteration is one SX
Function (symbolic Jacobian and sparse solve); the iterations sit behind
``Function.if_else`` switches, so the compiled code skips them once the update is below
``newton_tol`` (relative to 1 + max|v|). The state carries two extra counters over the
run: Newton iterations and sub-steps that hit ``max_newton`` without converging.
"""

from __future__ import annotations

from abc import abstractmethod

import casadi as ca
import numpy as np

from ..errors import Rrr4Error
from .base import FixedStepIntegrator, Run, System

__all__ = ["ImplicitIntegrator", "second_order_split"]


def second_order_split(system: System) -> int:
    """nq such that y = [q (nq), v (nq), e] with q' = v and y' independent of e; raises Rrr4Error if none."""
    ny = system.ny
    t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", ny), ca.SX.sym("z", system.nz), ca.SX.sym("u", system.nu)
    f = system.ode(t, y, z, u)
    for nq in range(ny // 2, 0, -1):
        if all(ca.is_equal(f[i], y[nq + i]) for i in range(nq)) and not ca.depends_on(f, y[2 * nq:]):
            return nq
    raise Rrr4Error("implicit integrators need a second-order system y = [q, v, quadratures] with q' = v")


class ImplicitIntegrator(FixedStepIntegrator):
    """Base of the implicit methods: subclasses implement :meth:`advance_implicit` with :meth:`stage`.

    newton_tol: relative velocity-update tolerance; max_newton: iterations per stage.
    A method may keep `memory_size` extra state entries between steps (e.g. the
    acceleration-like variable of generalised-alpha), initialised by :meth:`initial_memory`.
    """

    def __init__(self, jit: bool = False, newton_tol: float = 1e-10, max_newton: int = 8, refine: int = 1):
        super().__init__(jit=jit, refine=refine)
        if not (np.isfinite(newton_tol) and newton_tol > 0):
            raise Rrr4Error(f"integrator.newton_tol: {newton_tol!r} is not allowed (must be > 0)")
        if int(max_newton) < 1:
            raise Rrr4Error(f"integrator.max_newton: {max_newton!r} is not allowed (must be >= 1)")
        self.newton_tol, self.max_newton = float(newton_tol), int(max_newton)

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        return cls(jit=jit, newton_tol=settings.newton_tol, max_newton=settings.max_newton, refine=settings.refine)

    # ---- what a method implements
    def memory_size(self, nq: int) -> int:
        return 0

    def initial_memory(self, f0, nq: int):
        """Memory at t0 from f0 = y'(t0) (symbolic or numeric)."""
        return f0[:0]

    @abstractmethod
    def advance_implicit(self, stage, ode, t, y, z, u, h, memory, nq):
        """(y_next, memory_next) of one step; `stage(t, r, c, v_guess)` solves one implicit stage
        (r = (r_q, r_v, r_e), c = (c_q, c_v, c_e)) and returns (Y, f(Y))."""

    def advance(self, ode, t, y, z, u, h):  # the memory-free interface of FixedStepIntegrator
        raise NotImplementedError("implicit methods step through step_function")

    # ---- machinery
    def _newton_functions(self, system: System, nq: int) -> tuple[ca.Function, ca.Function]:
        """'newton_update': v, pars -> v_next, converged; and the same behind an if_else skip."""
        v, tt = ca.SX.sym("v", nq), ca.SX.sym("t")
        rq, rv, cq, cv = ca.SX.sym("r_q", nq), ca.SX.sym("r_v", nq), ca.SX.sym("c_q"), ca.SX.sym("c_v")
        z, u = ca.SX.sym("z", system.nz), ca.SX.sym("u", system.nu)
        q = rq + cq * v
        ne = system.ny - 2 * nq
        a = system.ode(tt, ca.vertcat(q, v, ca.SX.zeros(ne)), z, u)[nq:2 * nq]
        res = v - rv - cv * a
        jac = ca.jacobian(res, v)
        dv = -ca.solve(jac, res)
        v1 = v + dv
        done = ca.norm_inf(dv) <= self.newton_tol * (1 + ca.norm_inf(v1))
        pars = ca.vertcat(tt, rq, rv, cq, cv, z, u)
        upd = ca.Function("newton_update", [v, pars], ca.cse([v1, done]), ["v", "pars"], ["v_next", "converged"])
        v_in, p_in = ca.MX.sym("v", nq), ca.MX.sym("pars", pars.shape[0])
        skip = ca.Function("newton_skip", [v_in, p_in], [v_in, ca.MX(1)], ["v", "pars"], ["v_next", "converged"])
        return upd, ca.Function.if_else("newton_iteration", skip, upd)

    def step_function(self, system: System, h: float) -> ca.Function:
        """MX Function 'step': x = [t, y, z, memory, newton_iterations, newton_failures], u -> x_next."""
        nq = second_order_split(system)
        ny, nz, nm = system.ny, system.nz, self.memory_size(nq)
        _, iteration = self._newton_functions(system, nq)
        x, u = ca.MX.sym("x", 1 + ny + nz + nm + 2), ca.MX.sym("u", system.nu)
        t, y, z = x[0], x[1:1 + ny], x[1 + ny:1 + ny + nz]
        mem, iters, fails = x[1 + ny + nz:1 + ny + nz + nm], x[-2], x[-1]
        count = {"iters": iters, "fails": fails}

        def stage(ts, r, c, v_guess):
            (r_q, r_v, r_e), (c_q, c_v, c_e) = r, c
            pars = ca.vertcat(ts, r_q, r_v, c_q, c_v, z, u)
            vk, done = v_guess, ca.MX(0)
            for _ in range(self.max_newton):
                count["iters"] = count["iters"] + (1 - done)
                vk, conv = iteration(done, vk, pars)
                done = ca.fmax(done, conv)
            count["fails"] = count["fails"] + (1 - done)
            qk = r_q + c_q * vk
            fk = system.ode(ts, ca.vertcat(qk, vk, ca.MX.zeros(ny - 2 * nq)), z, u)
            return ca.vertcat(qk, vk, r_e + c_e * fk[2 * nq:]), fk

        y1, mem1 = self.advance_implicit(stage, system.ode, t, y, z, u, h, mem, nq)
        z1 = system.discrete(t + h, y1, z)
        x1 = ca.vertcat(t + h, y1, z1, mem1, count["iters"], count["fails"])
        return ca.Function("step", [x, u], [x1], ["x", "u"], ["x_next"])

    def run(self, system: System, x0, u_frames, h: float, steps_per_frame: int, chunk: int = 50,
            progress: bool = False) -> Run:
        """As :meth:`FixedStepIntegrator.run`, with the Newton counters in the statistics."""
        nq = second_order_split(system)
        ny, nz = system.ny, system.nz
        x0 = np.asarray(x0, float)
        u0 = np.atleast_2d(np.asarray(u_frames, float))[0]
        y0 = x0[1:1 + ny]
        f0 = np.array(system.ode(x0[0], y0, x0[1 + ny:1 + ny + nz], system.held(y0, u0))).ravel()
        mem0 = np.asarray(self.initial_memory(f0, nq), float).ravel()
        X = super().run(system, np.r_[x0, mem0, 0.0, 0.0], u_frames, h, steps_per_frame, chunk, progress).states
        n_steps = steps_per_frame * X.shape[0]
        return Run(X[:, :x0.size], {"newton_iterations": int(round(X[-1, -2])),
                                    "newton_failures": int(round(X[-1, -1])),
                                    "newton_iterations_per_step": float(X[-1, -2]) / max(n_steps, 1)})
