"""rrr4: the planar redundantly actuated 4-RRR with revolute joint clearance, in CasADi.

Data flows one way: scene -> model -> problem -> solution -> results.
"""

from .codegen import codegen
from .errors import KinematicsError, Rrr4Error, SceneError
from .mechanism import Mechanism
from .scene import Scene, load_scene

__all__ = ["load_scene", "Scene", "SceneError", "KinematicsError", "Rrr4Error", "Mechanism", "codegen"]
__version__ = "0.1.0"
