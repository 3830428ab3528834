"""scipy ``solve_ivp`` (RK45: Dormand & Prince 1980; Radau IIA order 5: Hairer & Wanner 1996)
on the same equations: the baseline a user would otherwise write, with the right-hand side
(and, for Radau, its Jacobian) called from Python at every stage.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from .adaptive import AdaptiveIntegrator
from .base import System


class ScipyIVP(AdaptiveIntegrator):
    scipy_method = ""

    def prepare(self, system: System, h0: float) -> None:
        self._ode = system.ode
        t, y, z, u = ca.SX.sym("t"), ca.SX.sym("y", system.ny), ca.SX.sym("z", system.nz), ca.SX.sym("u", system.nu)
        self._jac = ca.Function("ode_jacobian", [t, y, z, u], [ca.jacobian(system.ode(t, y, z, u), y)])
        self._h0 = h0

    def integrate_frame(self, t_a, t_b, y, z, u):
        def rhs(t, yy):
            return np.array(self._ode(t, yy, z, u)).ravel()

        kw = {"jac": lambda t, yy: np.array(self._jac(t, yy, z, u))} if self.scipy_method == "Radau" else {}
        sol = solve_ivp(rhs, (t_a, t_b), y, method=self.scipy_method, rtol=self.rtol, atol=self.atol,
                        first_step=min(self._h0, t_b - t_a), **kw)
        if not sol.success:
            return np.full_like(np.asarray(y, float), np.nan), {}
        return sol.y[:, -1], {"steps": sol.t.size - 1, "rhs_evaluations": sol.nfev, "jacobians": sol.njev}


class RK45(ScipyIVP):
    name, scipy_method, order = "rk45", "RK45", 5
    ladder = (1e-3, 1e-4, 1e-5, 1e-7)


class Radau(ScipyIVP):
    name, scipy_method, order = "radau", "Radau", 5
    ladder = (1e-3, 1e-5, 1e-7)
