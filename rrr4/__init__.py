"""rrr4: planar redundantly actuated mechanisms with revolute joint clearance, in CasADi.

Data flows one way: scene -> model -> problem -> solution -> results.
"""

from .codegen import codegen
from .errors import KinematicsError, Rrr4Error, SceneError, SimulationError
from .mechanism import Mechanism, Model, check_scene, load_scene
from .preload import PreloadSolution, solve_preload
from .scene import Scene
from .simulation import Simulation, simulate
from .sweeps import sweep

__all__ = ["load_scene", "check_scene", "Model", "Scene", "SceneError", "SimulationError", "KinematicsError",
           "Rrr4Error", "Mechanism", "codegen", "simulate", "Simulation", "solve_preload", "PreloadSolution", "sweep"]
__version__ = "0.1.0"
