"""Revolute clearance joints: journal-bearing geometry, normal-force laws, friction laws
and the oil film of a lubricated joint (:mod:`.lubrication`) after Flores & Ambrosio
(2004) and Flores et al. (2006, 2011).

Each law is one small function in a registry (:data:`NORMAL_LAWS`, :data:`FRICTION_LAWS`);
the equation builder (:mod:`rrr4.dynamics.builder`) picks the ones a scene asks for. The
journal seat under a steady load (:mod:`.seat`) is the one model of where a preloaded
journal rests.
"""

from .friction import FRICTION_LAWS, friction_force
from .geometry import ClearanceKinematics, clearance_kinematics, contact_generalized_forces
from .lubrication import LUBRICATION_LAWS, film_force, film_rates, film_weight
from .normal import NORMAL_LAWS, V_MIN, elastic_force, hysteresis_factor, normal_force, stiffness_internal_cylinder
from .seat import SEAT_FORCE, joint_stiffness, seat_gap, seat_gap_function

__all__ = ["ClearanceKinematics", "clearance_kinematics", "contact_generalized_forces", "NORMAL_LAWS",
           "normal_force", "elastic_force", "hysteresis_factor", "stiffness_internal_cylinder", "V_MIN",
           "FRICTION_LAWS", "friction_force",
           "LUBRICATION_LAWS", "film_force", "film_rates", "film_weight", "seat_gap", "seat_gap_function",
           "joint_stiffness", "SEAT_FORCE"]
