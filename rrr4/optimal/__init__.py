"""Optimal control that keeps every clearance joint in contact (DESIGN.md §10): the effort
family along a path as a function of its speed (:mod:`.family`) and time-optimal path
following with the null-space efforts as decision variables (:mod:`.time_law`), and
point-to-point motions with the path free (:mod:`.point_to_point`).
"""

from .family import PathFamily, path_family
from .point_to_point import MOTION_OBJECTIVES, OptimalMotion, optimal_motion
from .time_law import OBJECTIVES, OptimalTimeLaw, optimal_time_law

__all__ = ["PathFamily", "path_family", "OptimalTimeLaw", "optimal_time_law", "OBJECTIVES", "OptimalMotion",
           "optimal_motion", "MOTION_OBJECTIVES"]
