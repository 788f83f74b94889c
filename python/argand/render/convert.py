"""Scene (pydantic model from argand.scene) -> the plain data the C++
renderer plans a frame from. Everything here runs once per frame."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

DEFAULT_LIGHTS = [
    {"vector": [0.6, 0.4, 1.0], "directional": True, "color": [1.0, 0.97, 0.92], "intensity": 0.9},
    {"vector": [-0.8, 0.3, 0.2], "directional": True, "color": [0.55, 0.65, 1.0], "intensity": 0.35},
]


def _rgb(value: Any) -> list[float]:
    if value is None:
        return [0.85, 0.55, 0.25]
    if isinstance(value, str):
        text = value.lstrip("#")
        return [int(text[i : i + 2], 16) / 255.0 for i in (0, 2, 4)]
    for attr in ("as_tuple", "rgb", "to_list"):
        if hasattr(value, attr):
            got = getattr(value, attr)
            value = got() if callable(got) else got
            break
    if hasattr(value, "r") and hasattr(value, "g") and hasattr(value, "b"):
        return [float(value.r), float(value.g), float(value.b)]
    return [float(v) for v in list(value)[:3]]


def _vec(value: Any, default: list[float]) -> list[float]:
    if value is None:
        return list(default)
    return [float(v) for v in list(value)[:3]]


def rotation_matrix(degrees: list[float]) -> np.ndarray:
    """R = Rz Ry Rx (rotate about x, then y, then z)."""
    rx, ry, rz = (math.radians(a) for a in degrees)
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def object_transform(transform: Any) -> tuple[list[float], list[float]]:
    """World -> object: object = linear @ (world - translate), where the
    object is placed in the world by scale, then rotation, then translation."""
    if transform is None:
        return [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0], [0.0, 0.0, 0.0]
    translate = _vec(getattr(transform, "translate", None), [0, 0, 0])
    scale = float(getattr(transform, "scale", 1.0) or 1.0)
    rotate = _vec(getattr(transform, "rotate", None), [0, 0, 0])
    forward = rotation_matrix(rotate) * scale
    linear = np.linalg.inv(forward)
    return [float(v) for v in linear.ravel()], translate


def _material(m: Any) -> dict:
    get = (lambda k, d: getattr(m, k, d)) if m is not None else (lambda k, d: d)
    return {
        "color": _rgb(get("color", None)),
        "diffuse": float(get("diffuse", 0.8)),
        "specular": float(get("specular", 0.3)),
        "shininess": float(get("shininess", 32.0)),
        "reflectivity": float(get("reflectivity", 0.0)),
        "transparency": float(get("transparency", 0.0)),
        "ior": float(get("ior", 1.5)),
    }


def _camera(scene: Any) -> dict:
    cam = None
    for attr in ("resolved_camera", "default_camera"):
        if getattr(scene, "camera", None) is None and hasattr(scene, attr):
            got = getattr(scene, attr)
            cam = got() if callable(got) else got
            break
    if cam is None:
        cam = scene.camera
    return {
        "position": _vec(cam.position, [10, 8, 6]),
        "look_at": _vec(getattr(cam, "look_at", None), [0, 0, 0]),
        "up": _vec(getattr(cam, "up", None), [0, 0, 1]),
        "fov": float(getattr(cam, "fov", 40.0)),
    }


def _lights(scene: Any) -> list[dict]:
    lights = getattr(scene, "lights", None)
    if not lights:
        return [dict(light) for light in DEFAULT_LIGHTS]
    out = []
    for light in lights:
        direction = getattr(light, "direction", None)
        position = getattr(light, "position", None)
        out.append(
            {
                "vector": _vec(direction if direction is not None else position, [1, 1, 1]),
                "directional": direction is not None,
                "color": _rgb(getattr(light, "color", None) or [1, 1, 1]),
                "intensity": float(getattr(light, "intensity", 1.0)),
            }
        )
    return out


def to_core_scene(scene: Any) -> dict:
    """The dict _core.plan_frame takes. Accepts a Scene or such a dict."""
    if isinstance(scene, dict) and "objects" in scene and scene["objects"] and "terms" in scene["objects"][0]:
        return scene
    from argand.scene import parse_surface

    objects = []
    for obj in scene.objects:
        poly = parse_surface(obj.surface)
        linear, translate = object_transform(getattr(obj, "transform", None))
        objects.append(
            {
                "terms": [(int(i), int(j), int(k), float(c)) for (i, j, k), c in sorted(poly.terms.items())],
                "degree": int(poly.degree),
                "complex": getattr(obj, "space", "complex") == "complex",
                "clip_radius": float(getattr(obj, "clip_radius", None) or 0.0),
                "material": _material(getattr(obj, "material", None)),
                "linear": linear,
                "translate": translate,
            }
        )
    return {
        "objects": objects,
        "lights": _lights(scene),
        "background": _rgb(getattr(scene, "background", None) or [0.08, 0.08, 0.1]),
        "camera": _camera(scene),
    }
