"""Two-step Bathe method in the generalised rho_inf form (Bathe & Baig 2005; Noh & Bathe 2019).

Each step h has two implicit sub-steps, solved by Newton (:mod:`.implicit`):

1. trapezoidal rule over gamma h:  y_g = y_n + gamma h / 2 (f_n + f_g);
2. y_{n+1} = y_n + h (q0 f_n + q1 f_g + q2 f_{n+1}),

with (Noh & Bathe 2019, eq. 9) q1 = (rho_inf + 1) / (2 gamma (rho_inf - 1) + 4),
q0 = (gamma - 1) q1 + 1/2, q2 = -gamma q1 + 1/2. rho_inf = 0, gamma = 1/2 gives
q0 = q1 = q2 = 1/3, the original Bathe & Baig (2005) scheme (the 3-point backward Euler
second sub-step); rho_inf = 1 is the trapezoidal rule applied twice. Second order; the
spectral radius at infinite stiffness is rho_inf, so contact-stiffness modes the step
does not resolve are damped instead of ringing.
"""

from __future__ import annotations

from ..errors import Rrr4Error
from .implicit import ImplicitIntegrator


def bathe_weights(gamma: float, rho_inf: float) -> tuple[float, float, float]:
    """(q0, q1, q2) of the second sub-step (Noh & Bathe 2019, eq. 9)."""
    q1 = (rho_inf + 1) / (2 * gamma * (rho_inf - 1) + 4)
    return (gamma - 1) * q1 + 0.5, q1, 0.5 - gamma * q1


class Bathe(ImplicitIntegrator):
    """gamma in (0, 1): sub-step fraction; rho_inf in [0, 1]: spectral radius at h -> infinity."""
    name = "bathe"
    order = 2

    def __init__(self, jit: bool = False, gamma: float = 0.5, rho_inf: float = 0.0, **newton):
        super().__init__(jit=jit, **newton)
        if not 0 < gamma < 1:
            raise Rrr4Error(f"integrator.gamma: {gamma!r} is not allowed (must be in (0, 1))")
        if not 0 <= rho_inf <= 1:
            raise Rrr4Error(f"integrator.rho_inf: {rho_inf!r} is not allowed (must be in [0, 1])")
        self.gamma, self.rho_inf = float(gamma), float(rho_inf)
        self.weights = bathe_weights(self.gamma, self.rho_inf)
        if self.weights[2] <= 1e-6:
            raise Rrr4Error(f"integrator.gamma: {gamma!r} with rho_inf {rho_inf!r} makes the second sub-step "
                            "explicit (q2 = 0); use a smaller gamma")
        # both sub-steps share one iteration matrix when gamma h / 2 = q2 h (gamma = 2 - sqrt 2 at rho_inf = 0)
        self.matrices = 1 if abs(self.gamma / 2 - self.weights[2]) < 1e-12 else 2

    @classmethod
    def from_settings(cls, settings, jit: bool = False):
        return cls(jit=jit, gamma=settings.gamma, rho_inf=settings.rho_inf, **cls.newton_settings(settings))

    def advance_implicit(self, stage, ode, t, y, z, u, h, memory, nq):
        q0, q1, q2 = self.weights
        f0 = ode(t, y, z, u)
        c = self.gamma * h / 2
        r = y + c * f0
        yg, fg = stage(t + self.gamma * h, (r[:nq], r[nq:2 * nq], r[2 * nq:]), (c, c, c),
                       y[nq:2 * nq] + 2 * c * f0[nq:2 * nq])
        c = q2 * h
        r = y + h * (q0 * f0 + q1 * fg)
        y1, f1 = stage(t + h, (r[:nq], r[nq:2 * nq], r[2 * nq:]), (c, c, c),
                      yg[nq:2 * nq] + (1 - self.gamma) * h * fg[nq:2 * nq])
        return y1, memory, [(0.0, f0), (self.gamma, fg), (1.0, f1)]
