"""Planar mechanisms: the body/joint graph model, its kinematics (any graph; closed-form
n-RRR IK as a specialisation) and the checks of a scene against its model."""

from .graph import Model
from .model import Mechanism, NRRRMechanism
from .workspace import check_scene, load_scene

__all__ = ["Model", "Mechanism", "NRRRMechanism", "check_scene", "load_scene"]
