"""Scene (pydantic model from argand.scene) -> the typed scene the C++
renderer plans a frame from (``_core.SceneSpec``: render.h's structs, bound
with checked fields). Everything here runs once per frame.

The defaults are C++'s: a field the scene leaves out keeps the default
member initialiser of render.h's struct (argand.scene's model reads the same
values from ``_core``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from argand.core import _core


def rotation_matrix(degrees: Any) -> np.ndarray:
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
    forward = rotation_matrix(transform.rotate) * transform.scale
    linear = np.linalg.inv(forward)
    return [float(v) for v in linear.ravel()], [float(v) for v in transform.translate]


def _material(m: Any) -> _core.Material:
    return _core.Material(color=m.color, diffuse=m.diffuse, specular=m.specular, shininess=m.shininess,
                          reflectivity=m.reflectivity, transparency=m.transparency, ior=m.ior)


def _camera(cam: Any) -> _core.CameraSpec:
    return _core.CameraSpec(position=cam.position, look_at=cam.look_at, up=cam.up, fov_degrees=cam.fov)


def _light(light: Any) -> _core.Light:
    directional = light.direction is not None
    return _core.Light(vector=light.direction if directional else light.position, directional=directional,
                       color=light.color, intensity=light.intensity)


def _surface(obj: Any) -> _core.SurfaceSpec:
    poly = obj.polynomial
    linear, translate = object_transform(obj.transform)
    return _core.SurfaceSpec(
        terms=[(i, j, k, float(c)) for (i, j, k), c in sorted(poly.terms.items())],
        degree=poly.degree,
        complex_space=obj.space == "complex",
        clip_radius=obj.clip_radius or 0.0,
        material=_material(obj.material),
        linear=linear,
        translate=translate,
    )


def to_core_scene(scene: Any) -> _core.SceneSpec:
    """The typed scene _core.plan_frame takes, from an argand.scene.Scene (a
    SceneSpec is returned as it is). A scene without lights keeps C++'s
    default lights; without a camera, Scene.default_camera frames it."""
    if isinstance(scene, _core.SceneSpec):
        return scene
    objects = []
    for i, obj in enumerate(scene.objects):
        try:
            objects.append(_surface(obj))
        except ValueError as exc:  # e.g. a transform whose world -> object matrix is not finite
            raise ValueError(f"objects.{i}: {exc}") from None
    out = _core.SceneSpec(objects=objects, background=scene.background, camera=_camera(scene.resolved_camera()))
    if scene.lights:
        out.lights = [_light(light) for light in scene.lights]
    return out
