"""argand.scene: scene files, the surface expression parser and the presets.

    parse_surface("x^2*z + y^2")            -> SurfacePolynomial (exact terms)
    load_scene("whitney") / load_scene(path) -> Scene (validated)
    scene_from_dict({...})                   -> Scene

See docs/scenes.md for the format, the grammar and the presets. The MAX_*
constants are the limits every scene and expression is held to (quoted by
the API and docs/reliability.md).
"""

from argand.scene.expression import (
    MAX_COEFFICIENT_BITS,
    MAX_DECIMAL_EXPONENT,
    MAX_DEGREE,
    MAX_LENGTH,
    MAX_NESTING,
    MAX_NUMBER_LENGTH,
    MAX_TERMS,
    MAX_WORK,
    ExpressionError,
    SurfacePolynomial,
    parse_surface,
)
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
    scene_from_text,
)
from argand.scene.presets import PRESETS

__all__ = [
    "MAX_COEFFICIENT_BITS",
    "MAX_DECIMAL_EXPONENT",
    "MAX_DEGREE",
    "MAX_LENGTH",
    "MAX_NESTING",
    "MAX_NUMBER_LENGTH",
    "MAX_TERMS",
    "MAX_WORK",
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
    "scene_from_text",
]
