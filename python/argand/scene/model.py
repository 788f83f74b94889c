"""Scene files (YAML or JSON), validated with pydantic. A scene says only
what it needs: ``objects: [{surface: "x^2*z + y^2"}]`` is complete."""

from __future__ import annotations

import json
import math
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from argand.scene.expression import ExpressionError, SurfacePolynomial, parse_surface

Vector = tuple[float, float, float]


def _color(value: Any) -> tuple[float, float, float]:
    if isinstance(value, str):
        text = value.strip().lstrip("#")
        if len(text) != 6 or any(ch not in "0123456789abcdefABCDEF" for ch in text):
            raise ValueError(f"colour {value!r} must be '#rrggbb' or [r, g, b] with values in 0..1")
        return tuple(int(text[i : i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]
    if isinstance(value, (list, tuple)) and len(value) == 3:
        try:
            rgb = tuple(float(v) for v in value)
        except (TypeError, ValueError):
            raise ValueError(f"colour {value!r} must hold three numbers") from None
        if not all(0.0 <= v <= 1.0 for v in rgb):
            raise ValueError(f"colour components must be in 0..1, got {list(value)}")
        return rgb  # type: ignore[return-value]
    raise ValueError(f"colour {value!r} must be '#rrggbb' or [r, g, b] with values in 0..1")


Color = Annotated[tuple[float, float, float], BeforeValidator(_color)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Material(_Strict):
    color: Color = (0.85, 0.55, 0.25)
    diffuse: float = Field(0.8, ge=0, le=1)
    specular: float = Field(0.3, ge=0, le=1)
    shininess: float = Field(32.0, gt=0, le=10000)
    reflectivity: float = Field(0.0, ge=0, le=1)
    transparency: float = Field(0.0, ge=0, le=1)
    ior: float = Field(1.5, ge=1, le=4)

    @model_validator(mode="after")
    def _energy(self) -> "Material":
        if self.reflectivity + self.transparency > 1:
            raise ValueError("reflectivity + transparency must not exceed 1")
        return self


class Transform(_Strict):
    """Places the object: scale, then rotate (degrees about x, y, z), then translate."""

    translate: Vector = (0.0, 0.0, 0.0)
    scale: float = Field(1.0, gt=0)
    rotate: Vector = (0.0, 0.0, 0.0)


class SceneObject(_Strict):
    surface: str
    space: Literal["complex", "real"] = "complex"
    clip_radius: float | None = Field(None, gt=0)
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
        return parse_surface(self.surface)


class Camera(_Strict):
    position: Vector
    look_at: Vector = (0.0, 0.0, 0.0)
    up: Vector = (0.0, 0.0, 1.0)
    fov: float = Field(40.0, gt=1, lt=179)

    @model_validator(mode="after")
    def _not_degenerate(self) -> "Camera":
        view = [a - b for a, b in zip(self.look_at, self.position)]
        if math.hypot(*view) == 0:
            raise ValueError("camera position and look_at must differ")
        cross = (
            view[1] * self.up[2] - view[2] * self.up[1],
            view[2] * self.up[0] - view[0] * self.up[2],
            view[0] * self.up[1] - view[1] * self.up[0],
        )
        if math.hypot(*cross) == 0:
            raise ValueError("camera up must not be parallel to the view direction")
        return self


class Light(_Strict):
    direction: Vector | None = None  # towards the light (a light at infinity)
    position: Vector | None = None  # a point light
    color: Color = (1.0, 1.0, 1.0)
    intensity: float = Field(1.0, ge=0)

    @model_validator(mode="after")
    def _one_of(self) -> "Light":
        if (self.direction is None) == (self.position is None):
            raise ValueError("a light has either a direction or a position")
        return self


#: Radius framed when no object has a clipping sphere.
DEFAULT_EXTENT = 3.0


class Scene(_Strict):
    objects: list[SceneObject] = Field(min_length=1)
    camera: Camera | None = None
    lights: list[Light] | None = None
    background: Color = (0.08, 0.08, 0.1)

    def extent(self) -> float:
        """Radius of a sphere about the origin that holds what is shown."""
        radii = []
        for obj in self.objects:
            r = obj.clip_radius if obj.clip_radius is not None else _natural_extent(obj.polynomial)
            if obj.transform is not None:
                r = r * obj.transform.scale + math.hypot(*obj.transform.translate)
            radii.append(r)
        return max(radii)

    def resolved_camera(self) -> Camera:
        """The scene's camera, or one that frames the scene from a 3/4 view."""
        if self.camera is not None:
            return self.camera
        fov = 40.0
        distance = self.extent() / math.sin(math.radians(fov / 2)) * 1.05
        direction = (0.62, 0.52, 0.59)  # a pleasant 3/4 view, z up
        norm = math.hypot(*direction)
        return Camera(position=tuple(distance * d / norm for d in direction), fov=fov)  # type: ignore[arg-type]

    def to_dict(self) -> dict:
        return self.model_dump(mode="json", exclude_none=True)


def _natural_extent(poly: SurfacePolynomial) -> float:
    """For x^n + y^n + z^n - c style surfaces, about c^(1/n) * 3^(1/n);
    otherwise DEFAULT_EXTENT."""
    const = float(poly.terms.get((0, 0, 0), 0))
    n = poly.degree
    pure = all(sum(1 for e in m if e) <= 1 for m in poly.terms if m != (0, 0, 0))
    if const < 0 and pure:
        return 1.15 * (-const) ** (1.0 / n) * 3 ** (0.5 / n) * 1.2
    return DEFAULT_EXTENT


def _readable(exc: ValidationError) -> str:
    lines = []
    for e in exc.errors():
        where = ".".join(str(p) for p in e["loc"]) or "scene"
        msg = e["msg"].removeprefix("Value error, ")
        lines.append(f"{where}: {msg}")
    return "invalid scene:\n  " + "\n  ".join(lines)


class SceneError(ValueError):
    """A scene that cannot be used, with every problem listed."""


def scene_from_dict(data: Any) -> Scene:
    if not isinstance(data, dict):
        raise SceneError("a scene must be a mapping with an 'objects' list, e.g. {objects: [{surface: 'x^2 + y^2 - z'}]}")
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise SceneError(_readable(exc)) from None


def load_scene(name_or_path: str | Path) -> Scene:
    """A preset name, or a .yaml / .yml / .json scene file."""
    from argand.scene.presets import PRESETS, preset_path

    text = str(name_or_path)
    if text in PRESETS:
        path = preset_path(text)
    else:
        path = Path(text)
        if not path.exists():
            raise SceneError(f"no preset or file named {text!r}; presets: {', '.join(PRESETS)}")
    raw = path.read_text()
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(raw)
        except json.JSONDecodeError as exc:
            raise SceneError(f"{path}: JSON error at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    else:
        import yaml

        try:
            data = yaml.safe_load(raw)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
            raise SceneError(f"{path}: YAML error{where}: {getattr(exc, 'problem', exc)}") from None
    try:
        return scene_from_dict(data)
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None
