"""Classical fixed-step Runge-Kutta of order 4 (Hairer, Norsett & Wanner 1993, I.1, Table 1.2)."""

from __future__ import annotations

from .base import FixedStepIntegrator


class RK4(FixedStepIntegrator):
    name = "rk4"
    order = 4

    def advance(self, ode, t, y, z, u, h):
        k1 = ode(t, y, z, u)
        k2 = ode(t + h / 2, y + h / 2 * k1, z, u)
        k3 = ode(t + h / 2, y + h / 2 * k2, z, u)
        k4 = ode(t + h, y + h * k3, z, u)
        return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
