"""Classical fixed-step Runge-Kutta of order 4 (Hairer, Norsett & Wanner 1993, I.1, Table 1.2)."""

from __future__ import annotations

from .base import FixedStepIntegrator


class RK4(FixedStepIntegrator):
    name = "rk4"
    order = 4
    ladder = (1e-4, 1e-3 / 12, 6.25e-5, 5e-5, 4e-5, 2.5e-5, 1e-5, 5e-6, 2e-6, 1e-6)  # explicit: small steps

    def advance(self, ode, t, y, z, u, h):
        k1 = ode(t, y, z, u)
        k2 = ode(t + h / 2, y + h / 2 * k1, z, u)
        k3 = ode(t + h / 2, y + h / 2 * k2, z, u)
        k4 = ode(t + h, y + h * k3, z, u)
        return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
