"""argand.scene: scene files, the surface expression parser and the presets."""

from argand.scene.expression import MAX_DEGREE, ExpressionError, SurfacePolynomial, parse_surface
from argand.scene.model import (
    Camera,
    Light,
    Material,
    Scene,
    SceneError,
    SceneObject,
    Transform,
    load_scene,
    scene_from_dict,
)
from argand.scene.presets import PRESETS

__all__ = [
    "MAX_DEGREE",
    "PRESETS",
    "Camera",
    "ExpressionError",
    "Light",
    "Material",
    "Scene",
    "SceneError",
    "SceneObject",
    "SurfacePolynomial",
    "Transform",
    "load_scene",
    "parse_surface",
    "scene_from_dict",
]
