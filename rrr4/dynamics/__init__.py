"""Rigid-body dynamics in reference-point coordinates (Zhang & Zhang 2017, eq. 3-5)."""

from .mass import actuator_matrix, gravity_forces, mass_matrix

__all__ = ["mass_matrix", "gravity_forces", "actuator_matrix"]
