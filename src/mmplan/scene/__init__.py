"""Obstacles and scenes (docs/conventions.md).

Shapes: :class:`Superellipsoid` (Barr, given by its model parameters), :class:`Sphere`,
:class:`Cylinder` (vertical), :class:`Box` (yawed). Each gives an exact signed distance for
the checker and a :class:`SuperellipsoidModel` (the smooth model all planners use) by
``superellipsoid()``; :func:`obstacle_from_dict` builds one from its scenario form.
"""

from mmplan.scene.box import Box
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.obstacle import Obstacle, obstacle_from_dict, shape_names
from mmplan.scene.scene import Scene
from mmplan.scene.smooth_model import SuperellipsoidModel
from mmplan.scene.sphere import Sphere
from mmplan.scene.superellipsoid import Superellipsoid

__all__ = [
    "Box",
    "Cylinder",
    "Obstacle",
    "Scene",
    "Sphere",
    "Superellipsoid",
    "SuperellipsoidModel",
    "obstacle_from_dict",
    "shape_names",
]
