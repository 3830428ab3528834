"""Integrators behind one small interface (:mod:`.base`), one module per method.

``METHODS`` maps a scene's ``integrator.method`` to its class.
"""

from .base import FixedStepIntegrator, System
from .rk4 import RK4

METHODS = {RK4.name: RK4}

__all__ = ["FixedStepIntegrator", "System", "RK4", "METHODS"]
