"""Planar mechanisms: the immutable body/joint graph :class:`Model` (names -> indices,
joint equations; :mod:`.model`), its kinematics :class:`Mechanism` (any graph; the
closed-form n-RRR as a specialisation; :mod:`.mechanism`), the n-RRR's closed forms
(:mod:`.kinematics`), tree coordinates (:mod:`.tree`) and the checks of a scene against
its model (:mod:`.workspace`)."""

from .mechanism import Mechanism, NRRRMechanism, wrap_angle
from .model import Model, geometry_parameters
from .workspace import check_scene, load_scene

__all__ = ["Model", "Mechanism", "NRRRMechanism", "wrap_angle", "geometry_parameters", "check_scene", "load_scene"]
