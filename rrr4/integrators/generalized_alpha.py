"""Generalised-alpha method (Chung & Hulbert 1993) on the index-1 equations q'' = a(t, q, q').

In the form of Arnold & Bruls (2007) with an acceleration-like variable w (kept between
steps as the method's memory, w_0 = a_0):

    (1 - alpha_m) w_{n+1} + alpha_m w_n = (1 - alpha_f) a_{n+1} + alpha_f a_n,
    q_{n+1} = q_n + h v_n + h^2 ((1/2 - beta) w_n + beta w_{n+1}),
    v_{n+1} = v_n + h ((1 - gamma) w_n + gamma w_{n+1}),

with alpha_m = (2 rho_inf - 1) / (rho_inf + 1), alpha_f = rho_inf / (rho_inf + 1),
gamma = 1/2 - alpha_m + alpha_f, beta = (gamma + 1/2)^2 / 4 (Chung & Hulbert 1993,
eqs. 25-26): second order with spectral radius rho_inf at infinite stiffness. Quadratures
(work, dissipation) use the trapezoidal rule. Newton per step (:mod:`.implicit`), on v_{n+1}:
w_{n+1} = (v_{n+1} - v_n - h (1 - gamma) w_n) / (h gamma).
"""

from __future__ import annotations

from ..errors import Rrr4Error
from .implicit import ImplicitIntegrator


def alpha_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, gamma, beta) of Chung & Hulbert (1993) for spectral radius rho_inf."""
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    gamma = 0.5 - am + af
    return am, af, gamma, 0.25 * (gamma + 0.5) ** 2


class GeneralizedAlpha(ImplicitIntegrator):
    """rho_inf in [0, 1] (the scene's integrator.rho_inf)."""
    name = "generalized-alpha"
    order = 2

    def __init__(self, jit: bool = False, rho_inf: float = 0.0, **newton):
        super().__init__(jit=jit, **newton)
        if not 0 <= rho_inf <= 1:
            raise Rrr4Error(f"integrator.rho_inf: {rho_inf!r} is not allowed (must be in [0, 1])")
        self.rho_inf = float(rho_inf)
        self.parameters = alpha_parameters(self.rho_inf)

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        return cls(jit=jit, rho_inf=settings.rho_inf, **cls.newton_settings(settings))

    def memory_size(self, nq: int) -> int:
        return nq

    def initial_memory(self, f0, nq: int):
        return f0[nq:2 * nq]

    def advance_implicit(self, stage, ode, t, y, z, u, h, memory, nq):
        am, af, g, beta = self.parameters
        q, v, e, w = y[:nq], y[nq:2 * nq], y[2 * nq:], memory
        f0 = ode(t, y, z, u)
        a0 = f0[nq:2 * nq]
        # v-stage: v = r_v + c_v a(q(v), v); q = r_q + c_q v
        base_v = v + h * (1 - g) * w                                # v_{n+1} = base_v + h g w_{n+1}
        c_q = h * beta / g
        r_q = q + h * v + h * h * (0.5 - beta) * w - c_q * base_v
        c_v = h * g * (1 - af) / (1 - am)
        r_v = base_v + h * g * (af * a0 - am * w) / (1 - am)
        y1, f1 = stage(t + h, (r_q, r_v, e + h / 2 * f0[2 * nq:]), (c_q, c_v, h / 2), v + h * a0)
        w1 = (y1[nq:2 * nq] - base_v) / (h * g)
        return y1, w1, [(0.0, f0), (1.0, f1)]
