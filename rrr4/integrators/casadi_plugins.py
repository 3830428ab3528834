"""CasADi's own integrator plugins: 'cvodes' (BDF, SUNDIALS; Hindmarsh et al. 2005), 'idas'
(the same equations as a DAE solver), 'erk' (embedded explicit Runge-Kutta with step
control) and 'rosenbrock' (linearly implicit, adaptive), all with rtol/atol.

The integrator Function is built once per run (``casadi.integrator``) on the system's
ODE with p = [t_a, z, u] and time measured from the frame start; each frame is one call.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..functions import QUIET
from .adaptive import AdaptiveIntegrator
from .base import System


class CasadiPlugin(AdaptiveIntegrator):
    plugin = ""

    def prepare(self, system: System, h0: float) -> None:
        ny, nz, nu = system.ny, system.nz, system.nu
        y, tau = ca.SX.sym("y", ny), ca.SX.sym("t")
        p = ca.SX.sym("p", 1 + nz + nu)
        f = system.ode(p[0] + tau, y, p[1:1 + nz], p[1 + nz:])
        opts = {"reltol": self.rtol, "abstol": self.atol, **QUIET}
        if self.plugin in ("cvodes", "idas"):  # SUNDIALS' own messages: a failed frame is reported as NaN
            opts.update({"max_num_steps": 10**7, "max_step_size": 0.0, "disable_internal_warnings": True})
        self._dt = None
        self._dae, self._opts, self._nz = {"x": y, "p": p, "t": tau, "ode": f}, opts, nz
        self._fun = None

    def _function(self, dt: float) -> ca.Function:
        if self._fun is None or abs(dt - self._dt) > 1e-15 * max(dt, 1.0):
            self._fun = ca.integrator(f"frame_{self.plugin}", self.plugin, self._dae, 0.0, dt, self._opts)
            self._dt = dt
        return self._fun

    def integrate_frame(self, t_a, t_b, y, z, u):
        fun = self._function(t_b - t_a)
        try:
            yb = np.array(fun(x0=y, p=np.r_[t_a, z, u])["xf"]).ravel()
        except RuntimeError:  # the solver gave up (e.g. step size underflow): report non-finite
            return np.full_like(np.asarray(y, float), np.nan), {}
        s = fun.stats()
        return yb, {"steps": s.get("n_steps", s.get("nsteps", 0)), "rejected_steps": s.get("n_reject", 0),
                    "rhs_evaluations": s.get("n_rhs", s.get("nfevals", 0)), "jacobians": s.get("n_jac", 0)}


class Cvodes(CasadiPlugin):
    name = plugin = "cvodes"
    ladder = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-9)


class Idas(CasadiPlugin):
    name = plugin = "idas"


class Erk(CasadiPlugin):
    name = plugin = "erk"


class Rosenbrock(CasadiPlugin):
    name = plugin = "rosenbrock"
    ladder = (1e-3, 1e-5, 1e-7)
