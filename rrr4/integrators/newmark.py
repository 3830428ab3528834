"""Newmark's trapezoidal rule (constant average acceleration, beta = 1/4, gamma = 1/2; Newmark 1959).

For q'' = a(t, q, q') it is the trapezoidal rule on y = [q, v]:
q_{n+1} = q_n + h/2 (v_n + v_{n+1}), v_{n+1} = v_n + h/2 (a_n + a_{n+1}), which expands to
Newmark's q_{n+1} = q_n + h v_n + h^2/4 (a_n + a_{n+1}). Second order, unconditionally
stable, no numerical damping (spectral radius 1 at infinite stiffness). Newton per step
(:mod:`.implicit`).
"""

from __future__ import annotations

from .implicit import ImplicitIntegrator


class NewmarkTrapezoidal(ImplicitIntegrator):
    name = "newmark"
    order = 2

    def advance_implicit(self, stage, ode, t, y, z, u, h, memory, nq):
        f0 = ode(t, y, z, u)
        c = h / 2
        r = y + c * f0
        y1, f1 = stage(t + h, (r[:nq], r[nq:2 * nq], r[2 * nq:]), (c, c, c), y[nq:2 * nq] + h * f0[nq:2 * nq])
        return y1, memory, [(0.0, f0), (1.0, f1)]
