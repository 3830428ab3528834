"""Planar n-RRR kinematics: closed-form IK, FK, Jacobians and null space in CasADi."""

from .model import Mechanism

__all__ = ["Mechanism"]
