"""argand.scene: scene files, the surface expression parser and the presets.

    parse_surface("x^2*z + y^2")            -> SurfacePolynomial (exact terms)
    load_scene("whitney") / load_scene(path) -> Scene (validated)
    scene_from_dict({...})                   -> Scene

See docs/scenes.md for the format, the grammar and the presets. The MAX_*
constants are the limits every scene and expression is held to (quoted by
the API and docs/reliability.md).
"""

# The names are read from their modules the first time they are asked for
# (PEP 562): importing argand.scene, or argand.scene.expression through it,
# loads neither pydantic nor the models (argand.scene.schema), which `argand
# render` of a preset does without (tests/test_startup.py).
_FROM = {
    **dict.fromkeys(("MAX_COEFFICIENT_BITS", "MAX_DECIMAL_EXPONENT", "MAX_DEGREE", "MAX_LENGTH", "MAX_NESTING",
                     "MAX_NUMBER_LENGTH", "MAX_TERMS", "MAX_WORK", "ExpressionError", "SurfacePolynomial",
                     "parse_surface"), "argand.scene.expression"),
    **dict.fromkeys(("Camera", "Light", "Material", "Scene", "SceneObject", "Transform", "scene_from_dict",
                     "scene_from_text"), "argand.scene.schema"),
    **dict.fromkeys(("SceneError", "load_scene"), "argand.scene.model"),
    "PRESETS": "argand.scene.presets",
}


def __getattr__(name: str):
    module = _FROM.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_FROM))


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
