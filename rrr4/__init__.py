"""rrr4: the planar redundantly actuated 4-RRR with revolute joint clearance, in CasADi.

Data flows one way: scene -> model -> problem -> solution -> results.
"""

from .codegen import codegen
from .errors import KinematicsError, Rrr4Error, SceneError
from .mechanism import Mechanism
from .preload import PreloadSolution, solve_preload
from .scene import Scene, load_scene
from .simulation import Simulation, simulate

__all__ = ["load_scene", "Scene", "SceneError", "KinematicsError", "Rrr4Error", "Mechanism", "codegen",
           "simulate", "Simulation", "solve_preload", "PreloadSolution"]
__version__ = "0.1.0"
