"""Integrators behind one small interface (:mod:`.base`), one module per method.

``METHODS`` maps a scene's ``integrator.method`` to its class.
"""

from ..scene.vocabulary import INTEGRATORS, registry
from .adaptive import AdaptiveIntegrator
from .base import BACKGROUND, FixedStepIntegrator, FrameInputs, Integrator, Run, System
from .bathe import Bathe
from .casadi_plugins import Cvodes, Erk, Idas, Rosenbrock
from .generalized_alpha import GeneralizedAlpha
from .newmark import NewmarkTrapezoidal
from .rk4 import RK4
from .ros2 import Ros2
from .scipy_ivp import RK45, Radau

# the registry, by the scene's vocabulary
METHODS = registry(INTEGRATORS, {m.name: m for m in (Bathe, NewmarkTrapezoidal, GeneralizedAlpha, Ros2, RK4, Erk,
                                                     Rosenbrock, Cvodes, Idas, RK45, Radau)})

__all__ = ["BACKGROUND", "Integrator", "FixedStepIntegrator", "FrameInputs", "System", "Run", "RK4", "Bathe",
           "NewmarkTrapezoidal",
           "GeneralizedAlpha", "Ros2", "AdaptiveIntegrator", "Cvodes", "Idas", "Erk", "Rosenbrock", "RK45", "Radau",
           "METHODS"]
