"""rrr4: planar redundantly actuated mechanisms with revolute joint clearance, in CasADi.

Data flows one way: scene -> problem -> solution -> results. A scene is read and checked
once (:func:`load_scene`); :func:`build` makes the :class:`Problem` every algorithm takes
(the front doors accept either).
"""

from .codegen import codegen
from .errors import InfeasibleError, KinematicsError, MeasurementError, Rrr4Error, SceneError, SimulationError
from .identify import Identification, identify
from .mechanism import Mechanism, Model, check_scene, load_scene
from .optimal import optimal_motion, optimal_time_law
from .preload import PreloadSolution, solve_preload
from .problem import Problem, build
from .scene import Scene
from .simulation import Simulation, simulate
from .studies import sweep

__all__ = ["load_scene", "check_scene", "build", "Problem", "Model", "Scene", "SceneError", "SimulationError",
           "KinematicsError", "Rrr4Error", "Mechanism", "codegen", "simulate", "Simulation", "solve_preload",
           "PreloadSolution", "sweep", "optimal_time_law", "optimal_motion", "InfeasibleError", "identify",
           "Identification", "MeasurementError"]
__version__ = "0.1.0"
