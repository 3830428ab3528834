"""Integrators behind one small interface (:mod:`.base`), one module per method.

``METHODS`` maps a scene's ``integrator.method`` to its class.
"""

from .base import FixedStepIntegrator, System
from .bathe import Bathe
from .generalized_alpha import GeneralizedAlpha
from .newmark import NewmarkTrapezoidal
from .rk4 import RK4

METHODS = {m.name: m for m in (Bathe, NewmarkTrapezoidal, GeneralizedAlpha, RK4)}

__all__ = ["FixedStepIntegrator", "System", "RK4", "Bathe", "NewmarkTrapezoidal", "GeneralizedAlpha", "METHODS"]
