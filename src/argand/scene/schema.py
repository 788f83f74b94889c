"""The scene's pydantic models and the parsing of scene text (YAML or
JSON) into them; argand.scene.model (and argand.scene) hands these names
out, importing this module the first time one is read there. The checks
that do not need pydantic (bounds, colours, samples, the framing,
SceneError) are argand.scene.model's."""

from __future__ import annotations

import difflib
import json
import types
import typing
from functools import cached_property
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from argand.core import _core
from argand.core._core import MAX_OBJECTS, MAX_SAMPLES
from argand.scene.expression import ExpressionError, SurfacePolynomial, parse_surface
from argand.scene.model import (
    _CAMERA,
    _LIGHT,
    _MATERIAL,
    _SCENE,
    RGB,
    SceneError,
    _color_of,
    _enclose,
    _vector,
    _yaml_loader,
    bounds,
    check_samples,
    framing_position,
    surface_extent,
)

DEFAULT_FOV: float = _CAMERA.fov_degrees

#: Colours: "#rrggbb" or [r, g, b], stored as three floats, each component
#: within the bounds of the typed scene's field (FIELD_LIMITS).
MaterialColor = Annotated[RGB, BeforeValidator(_color_of("Material.color"))]
LightColor = Annotated[RGB, BeforeValidator(_color_of("Light.color"))]
BackgroundColor = Annotated[RGB, BeforeValidator(_color_of("SceneSpec.background"))]


#: A point or direction: [x, y, z], three finite numbers.
Vector = Annotated[tuple[float, float, float], BeforeValidator(_vector)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)



class Material(_Strict):
    """Phong shading plus mirror reflection and refraction (real objects)."""

    color: MaterialColor = _MATERIAL.color
    diffuse: float = Field(_MATERIAL.diffuse, **bounds("Material.diffuse"))
    specular: float = Field(_MATERIAL.specular, **bounds("Material.specular"))
    shininess: float = Field(_MATERIAL.shininess, **bounds("Material.shininess"))
    reflectivity: float = Field(_MATERIAL.reflectivity, **bounds("Material.reflectivity"))
    transparency: float = Field(_MATERIAL.transparency, **bounds("Material.transparency"))
    ior: float = Field(_MATERIAL.ior, **bounds("Material.ior"))

    @model_validator(mode="after")
    def _energy(self) -> Material:
        if self.reflectivity + self.transparency > 1:
            raise ValueError(
                f"reflectivity + transparency must not exceed 1 (got {self.reflectivity} + {self.transparency})"
            )
        return self


class Transform(_Strict):
    """Places the object in the world: scale, then rotate (degrees about x,
    then y, then z), then translate."""

    translate: Vector = (0.0, 0.0, 0.0)
    scale: float = Field(1.0, gt=0)
    rotate: Vector = (0.0, 0.0, 0.0)


class SceneObject(_Strict):
    """One surface F(x, y, z) = 0, in object space."""

    surface: str
    space: Literal["complex", "real"] = "complex"
    #: C++'s SurfaceSpec.clip_radius takes 0 for no clip sphere; a scene says
    #: that with null, so here the radius is above that lower bound.
    clip_radius: float | None = Field(None, gt=_core.FIELD_LIMITS["SurfaceSpec.clip_radius"][0])
    material: Material = Material()
    transform: Transform | None = None

    @field_validator("surface")
    @classmethod
    def _parse(cls, text: str) -> str:
        try:
            parse_surface(text)
        except ExpressionError as exc:
            raise ValueError(str(exc)) from None
        return text

    @cached_property
    def polynomial(self) -> SurfacePolynomial:
        """The parsed, expanded surface."""
        return parse_surface(self.surface)

    @cached_property
    def extent(self) -> float:
        """Radius about the object's origin of what it shows: clip_radius, or
        for an unclipped surface :func:`surface_extent`."""
        return self.clip_radius if self.clip_radius is not None else surface_extent(self.polynomial)

    def bounding_sphere(self) -> tuple[Vector, float]:
        """(centre, radius) in the world of what this object shows: the
        sphere of radius :attr:`extent`, placed by the transform."""
        radius = self.extent
        if self.transform is None:
            return (0.0, 0.0, 0.0), radius
        return self.transform.translate, radius * self.transform.scale


class Camera(_Strict):
    """A pinhole camera; ``fov`` is the vertical field of view in degrees."""

    position: Vector
    look_at: Vector = _CAMERA.look_at
    up: Vector = _CAMERA.up
    fov: float = Field(_CAMERA.fov_degrees, **bounds("CameraSpec.fov_degrees"))

    @model_validator(mode="after")
    def _not_degenerate(self) -> Camera:
        view = np.subtract(self.look_at, self.position)
        if not np.any(view):
            raise ValueError("camera position and look_at must differ")
        if not np.any(np.cross(view, self.up)):
            raise ValueError("camera up must not be zero or parallel to the view direction (look_at - position)")
        return self


class Light(_Strict):
    """A light at infinity (``direction``, pointing towards the light) or a
    point light (``position``): exactly one of the two."""

    direction: Vector | None = None
    position: Vector | None = None
    color: LightColor = _LIGHT.color
    intensity: float = Field(_LIGHT.intensity, **bounds("Light.intensity"))

    @model_validator(mode="after")
    def _one_of(self) -> Light:
        if (self.direction is None) == (self.position is None):
            raise ValueError("a light has either a direction or a position (exactly one of them)")
        if self.direction is not None and not any(self.direction):
            raise ValueError("a light's direction must not be [0, 0, 0]")
        return self



class Scene(_Strict):
    #: At most MAX_OBJECTS (the renderer's limit, defined in C++).
    objects: list[SceneObject] = Field(min_length=1, max_length=MAX_OBJECTS)
    camera: Camera | None = None
    #: None (or empty): the renderer's default lights (render.h's default_lights()).
    lights: list[Light] | None = None
    background: BackgroundColor = _SCENE.background
    #: Samples per pixel, a square from 1 to MAX_SAMPLES (C++'s limit):
    #: the pixel's colour is their mean, its status the worst of theirs.
    samples: int = Field(1, ge=1, le=MAX_SAMPLES, strict=True)

    @field_validator("samples")
    @classmethod
    def _square(cls, samples: int) -> int:
        return check_samples(samples)

    def bounding_sphere(self) -> tuple[Vector, float]:
        """(centre, radius) of a sphere holding every object's bounding sphere."""
        spheres = [obj.bounding_sphere() for obj in self.objects]
        return _enclose(spheres)

    def default_camera(self) -> Camera:
        """A camera that frames :meth:`bounding_sphere` from a 3/4 view
        (DEFAULT_VIEW), z up, fov DEFAULT_FOV."""
        centre, radius = self.bounding_sphere()
        position = framing_position(centre, radius)
        return Camera(position=position, look_at=centre, up=(0.0, 0.0, 1.0), fov=DEFAULT_FOV)  # type: ignore[arg-type]

    def resolved_camera(self) -> Camera:
        """The scene's camera, or :meth:`default_camera` when it has none."""
        return self.camera if self.camera is not None else self.default_camera()

    def to_dict(self) -> dict:
        """Plain JSON-ready data (every default filled in, None left out);
        scene_from_dict(scene.to_dict()) == scene."""
        return self.model_dump(mode="json", exclude_none=True)



def _model_at(location: tuple) -> type[BaseModel] | None:
    """The model class holding the field at `location` (a pydantic loc)."""
    model: type[BaseModel] | None = Scene
    for step in location[:-1]:
        if model is None:
            return None
        if isinstance(step, int):
            continue
        info = model.model_fields.get(step)
        model = _model_in(info.annotation) if info is not None else None
    return model


def _model_in(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if typing.get_origin(annotation) in (list, typing.Union, types.UnionType, Annotated):
        for arg in typing.get_args(annotation):
            found = _model_in(arg)
            if found is not None:
                return found
    return None


def _describe(error: dict) -> tuple[str, str]:
    location = error["loc"]
    where = ".".join(str(p) for p in location) or "scene"
    kind = error["type"]
    if kind == "extra_forbidden":
        model = _model_at(location)
        name = str(location[-1])
        allowed = list(model.model_fields) if model is not None else []
        message = f"unknown field {name!r}"
        close = difflib.get_close_matches(name, allowed, n=1)
        material_field = difflib.get_close_matches(name, list(Material.model_fields), n=1)
        if close:
            message += f" (did you mean {close[0]!r}?)"
        elif model is SceneObject and material_field:
            message += f" (did you mean material: {{{material_field[0]}: ...}}?)"
        if allowed:
            message += f"; allowed: {', '.join(allowed)}"
        return where, message
    message = error["msg"].removeprefix("Value error, ")
    if kind == "missing":
        return where, "required field missing"
    given = error.get("input")
    if kind != "value_error" and not isinstance(given, (dict, list)) and given is not None:
        shown = repr(given)
        message += f" (got {shown if len(shown) <= 60 else shown[:57] + '...'})"
    return where, message


def _readable(exc: ValidationError, prefix: str = "") -> SceneError:
    problems = [_describe(e) for e in exc.errors()]
    lines = []
    for where, message in problems:
        first, *rest = message.splitlines()
        lines.append(f"  {where}: {first}")
        lines.extend(f"    {line}" for line in rest)
    return SceneError(f"{prefix}invalid scene:\n" + "\n".join(lines), problems)


def scene_from_dict(data: Any) -> Scene:
    """Validates plain data (as read from YAML or JSON) into a Scene; raises
    SceneError listing every problem."""
    if not isinstance(data, dict):
        raise SceneError(
            "a scene must be a mapping with an 'objects' list, e.g. {objects: [{surface: 'x^2 + y^2 - z'}]}, "
            f"not {type(data).__name__}"
        )
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise _readable(exc) from None


def scene_from_text(text: str, kind: Literal["yaml", "json"] = "yaml", source: str = "scene") -> Scene:
    """Parses YAML or JSON text into a Scene; raises SceneError naming
    `source` and the line of a syntax error."""
    # Both parsers recurse once per nesting level (RecursionError on a deep
    # text) and refuse integers of more than 4,300 digits with a plain
    # ValueError: those are mistakes in the text like any other.
    if kind == "json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise SceneError(f"{source}: JSON error at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
        except RecursionError:
            raise SceneError(f"{source}: JSON error: nested too deeply") from None
        except ValueError as exc:
            raise SceneError(f"{source}: JSON error: {exc}") from None
    else:
        import yaml

        try:
            data = yaml.load(text, Loader=_yaml_loader())  # noqa: S506 (a SafeLoader)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
            problem = getattr(exc, "problem", None) or str(exc)
            raise SceneError(f"{source}: YAML error{where}: {problem}") from None
        except RecursionError:
            raise SceneError(f"{source}: YAML error: nested too deeply") from None
        except ValueError as exc:
            raise SceneError(f"{source}: YAML error: {exc}") from None
    try:
        return scene_from_dict(data)
    except SceneError as exc:
        raise SceneError(f"{source}: {exc}", exc.problems) from None


