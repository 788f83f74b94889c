"""Scene files (YAML or JSON), validated with pydantic.

A scene says only what it needs: ``objects: [{surface: "x^2*z + y^2"}]`` is
complete; every other field has a default, and a missing camera frames the
scene (:meth:`Scene.default_camera`). Unknown fields are refused, and every
problem is reported with where it is (``objects.0.clip_radius: ...``).
"""

from __future__ import annotations

import difflib
import json
import math
import types
import typing
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from argand.core import _core
from argand.core._core import MAX_OBJECTS, MAX_SAMPLES
from argand.scene.expression import ExpressionError, SurfacePolynomial, parse_surface

RGB = tuple[float, float, float]

#: Scene file endings load_scene reads.
SCENE_SUFFIXES = (".yaml", ".yml", ".json")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def range_text(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    """Bounds as C++'s field checks write them: "in [0.0, 1.0]", ">= 0.0"."""
    if math.isinf(hi):
        return f"{'>' if lo_open else '>='} {float(lo)!r}"
    return f"in {'(' if lo_open else '['}{float(lo)!r}, {float(hi)!r}{')' if hi_open else ']'}"


def bounds(field: str) -> dict[str, float]:
    """The bounds of the typed scene's number field ``Struct.field`` (C++'s
    FIELD_LIMITS, which its setters check) as pydantic's ge/gt/le/lt: every
    limit of a scene field that reaches C++ is written once, there."""
    lo, hi, lo_open, hi_open = _core.FIELD_LIMITS[field]
    out = {}
    if math.isfinite(lo):
        out["gt" if lo_open else "ge"] = lo
    if math.isfinite(hi):
        out["lt" if hi_open else "le"] = hi
    return out


def _within(value: float, lo: float, hi: float, lo_open: bool, hi_open: bool) -> bool:
    return (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)


def _color_of(field: str) -> Any:
    """The validator of a colour of the typed scene's field ``field``:
    '#rrggbb' or [r, g, b], each component within FIELD_LIMITS[field]."""
    limits = _core.FIELD_LIMITS[field]
    each = range_text(*limits)
    allowed = f"a colour is '#rrggbb' or [r, g, b] with each component {each}"

    def color(value: Any) -> RGB:
        if isinstance(value, str):
            hex_digits = value[1:]
            if not value.startswith("#") or len(hex_digits) != 6 or any(ch not in "0123456789abcdefABCDEF" for ch in hex_digits):
                raise ValueError(f"{allowed}, not {value!r}")
            rgb = tuple(int(hex_digits[i : i + 2], 16) / 255.0 for i in (0, 2, 4))
        elif isinstance(value, (list, tuple)):
            if len(value) != 3 or not all(_is_number(v) for v in value):
                raise ValueError(f"{allowed}, not {list(value)!r}")
            rgb = tuple(float(v) for v in value)
        else:
            raise ValueError(f"{allowed}, not {value!r}")
        if not all(math.isfinite(v) and _within(v, *limits) for v in rgb):
            raise ValueError(f"colour components must be {each}, got {value if isinstance(value, str) else list(value)!r}")
        return rgb  # type: ignore[return-value]

    return color


#: Colours: "#rrggbb" or [r, g, b], stored as three floats, each component
#: within the bounds of the typed scene's field (FIELD_LIMITS).
MaterialColor = Annotated[RGB, BeforeValidator(_color_of("Material.color"))]
LightColor = Annotated[RGB, BeforeValidator(_color_of("Light.color"))]
BackgroundColor = Annotated[RGB, BeforeValidator(_color_of("SceneSpec.background"))]


def _vector(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) == 3 and all(_is_number(v) for v in value):
        return tuple(value)
    shown = list(value) if isinstance(value, (list, tuple)) else value
    raise ValueError(f"expected three numbers [x, y, z], not {shown!r}")


#: A point or direction: [x, y, z], three finite numbers.
Vector = Annotated[tuple[float, float, float], BeforeValidator(_vector)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


# The defaults are C++'s (render.h's default member initialisers, exported
# by _core): one definition, which tests/scene/test_model.py checks.
_MATERIAL = _core.Material()
_CAMERA = _core.CameraSpec()
_LIGHT = _core.Light()
_SCENE = _core.SceneSpec()


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


#: Camera defaults when a scene has none (the fov is C++'s CameraSpec default).
DEFAULT_FOV: float = _CAMERA.fov_degrees
#: The default view: from azimuth 35 degrees, elevation 30 degrees (z up).
DEFAULT_VIEW = (
    math.cos(math.radians(30)) * math.cos(math.radians(35)),
    math.cos(math.radians(30)) * math.sin(math.radians(35)),
    math.sin(math.radians(30)),
)
#: Room left around the framed sphere (1 = touching the frame's top and bottom).
FRAMING_MARGIN = 1.1


def check_samples(samples: Any) -> int:
    """samples per pixel: a square from 1 to MAX_SAMPLES (1, 4, 9, ..., 64);
    raises ValueError saying so."""
    allowed = ", ".join(str(k * k) for k in range(1, math.isqrt(MAX_SAMPLES) + 1))
    if not isinstance(samples, int) or isinstance(samples, bool) or _core.sample_side(samples) == 0:
        raise ValueError(f"samples per pixel must be one of {allowed} (a square up to {MAX_SAMPLES}), got {samples!r}")
    return samples


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
        distance = FRAMING_MARGIN * radius / math.sin(math.radians(DEFAULT_FOV / 2))
        position = tuple(c + distance * d for c, d in zip(centre, DEFAULT_VIEW))
        return Camera(position=position, look_at=centre, up=(0.0, 0.0, 1.0), fov=DEFAULT_FOV)  # type: ignore[arg-type]

    def resolved_camera(self) -> Camera:
        """The scene's camera, or :meth:`default_camera` when it has none."""
        return self.camera if self.camera is not None else self.default_camera()

    def to_dict(self) -> dict:
        """Plain JSON-ready data (every default filled in, None left out);
        scene_from_dict(scene.to_dict()) == scene."""
        return self.model_dump(mode="json", exclude_none=True)


# ---------------------------------------------------------------------------
# Framing
# ---------------------------------------------------------------------------


def _fibonacci_sphere(count: int) -> np.ndarray:
    """count directions spread evenly over the unit sphere, plus the six axis
    and eight diagonal directions (where extremes of symmetric surfaces lie)."""
    k = np.arange(count) + 0.5
    polar = np.arccos(1 - 2 * k / count)
    azimuth = math.pi * (1 + 5**0.5) * k
    spread = np.stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)], axis=1)
    axes = np.vstack([np.eye(3), -np.eye(3)])
    diagonals = np.array([(a, b, c) for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]) / 3**0.5
    return np.vstack([spread, axes, diagonals])


def _homogeneous_parts(poly: SurfacePolynomial, directions: np.ndarray) -> np.ndarray:
    """F_k(d) for each direction d (rows) and degree k (columns): F(t d) =
    sum_k F_k(d) t^k."""
    exponents, coefficients = poly.as_arrays()
    values = np.prod(directions[:, None, :] ** exponents[None, :, :], axis=2) * coefficients  # (n_dirs, m)
    parts = np.zeros((len(directions), poly.degree + 1))
    for column, degree in enumerate(exponents.sum(axis=1)):
        parts[:, degree] += values[:, column]
    return parts


def surface_length_scale(poly: SurfacePolynomial) -> float:
    """The distance at which the surface's terms of different degree balance:
    max over k < n of (|F_k| / |F_n|)^(1/(n-k)), |F_k| the largest coefficient
    of degree k (1000^(1/4) ~ 5.6 for the Bicube, 1 for Whitney); 1 for a
    homogeneous surface, which looks the same at every scale."""
    largest = [0.0] * (poly.degree + 1)
    for monomial, c in poly.terms.items():
        largest[sum(monomial)] = max(largest[sum(monomial)], abs(float(c)))
    n = poly.degree
    scales = [(largest[k] / largest[n]) ** (1.0 / (n - k)) for k in range(n) if largest[k]]
    return max(scales) if scales else 1.0


#: An unbounded, unclipped surface is framed to this many length scales.
UNBOUNDED_EXTENT = 3.0


def surface_extent(poly: SurfacePolynomial) -> float:
    """Radius about the origin to frame for a surface without a clip sphere.

    When the top-degree part F_n is definite (the same strict sign in every
    sampled direction) the real surface is bounded: the radius is the largest
    real root |t| of F(t d) = 0 over about 500 sampled directions d, plus 5%
    (about 7.4 for the Bicube, whose corners reach |x| = |y| = |z| ~ 4.3; 1.0
    for the unit sphere). Otherwise (unbounded, or no real points found)
    UNBOUNDED_EXTENT times :func:`surface_length_scale`. An estimate for
    framing, not a bound.
    """
    directions = _fibonacci_sphere(480)
    parts = _homogeneous_parts(poly, directions)
    top = parts[:, poly.degree]
    definite = poly.degree % 2 == 0 and (bool(np.all(top > 0)) or bool(np.all(top < 0)))
    if definite and np.min(np.abs(top)) > 1e-6 * np.max(np.abs(top)):
        reach = 0.0
        for row in parts:
            roots = np.roots(row[::-1])
            real = roots[np.abs(roots.imag) <= 1e-7 * (1 + np.abs(roots))]
            if real.size:
                reach = max(reach, float(np.max(np.abs(real.real))))
        if reach > 0:
            return 1.05 * reach
    return UNBOUNDED_EXTENT * surface_length_scale(poly)


def _enclose(spheres: list[tuple[Vector, float]]) -> tuple[Vector, float]:
    """A sphere holding all the given spheres (Ritter's method: start from the
    largest, grow to take in each one outside; exact for one or two spheres,
    within a few percent of the smallest otherwise)."""
    ordered = sorted(spheres, key=lambda s: -s[1])
    centre, radius = np.array(ordered[0][0], dtype=float), ordered[0][1]
    for _ in range(2):
        for other_centre, other_radius in ordered[1:]:
            offset = np.asarray(other_centre, dtype=float) - centre
            distance = float(np.linalg.norm(offset))
            if distance + other_radius <= radius * (1 + 1e-12):
                continue
            new_radius = (radius + distance + other_radius) / 2
            centre = centre + offset / distance * (new_radius - radius)
            radius = new_radius
    return (float(centre[0]), float(centre[1]), float(centre[2])), float(radius)


# ---------------------------------------------------------------------------
# Errors, loading
# ---------------------------------------------------------------------------


class SceneError(ValueError):
    """A scene that cannot be used. ``str()`` lists every problem, one per
    line, each with where it is; ``problems`` holds them as (location,
    message) pairs (location "" for a problem with the whole input)."""

    def __init__(self, message: str, problems: list[tuple[str, str]] | None = None) -> None:
        super().__init__(message)
        self.problems = problems if problems is not None else [("", message)]


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


def _yaml_loader():
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        """SafeLoader that refuses a key given twice (plain YAML keeps the last)."""

        def construct_mapping(self, node, deep=False):
            seen: dict[Any, Any] = {}
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                if isinstance(key, typing.Hashable) and key in seen:
                    raise yaml.constructor.ConstructorError(
                        "while reading a mapping", node.start_mark, f"the key {key!r} is given twice", key_node.start_mark
                    )
                seen[key] = True
            return super().construct_mapping(node, deep=deep)

    return UniqueKeyLoader


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


def load_scene(name_or_path: str | Path) -> Scene:
    """A preset name (see argand.scene.presets.PRESETS), or the path of a
    .yaml, .yml or .json scene file. A preset name wins over a file of the
    same name in the working directory. Raises SceneError."""
    from argand.scene.presets import PRESETS, preset_path

    if isinstance(name_or_path, str) and name_or_path in PRESETS:
        path = preset_path(name_or_path)
    else:
        path = Path(name_or_path)
        looks_like_a_file = isinstance(name_or_path, Path) or path.suffix or len(path.parts) > 1
        if not path.exists():
            if looks_like_a_file:
                raise SceneError(f"no preset or file named {str(name_or_path)!r}: the file does not exist")
            close = difflib.get_close_matches(str(name_or_path), PRESETS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SceneError(
                f"no preset or file named {str(name_or_path)!r}{hint}; presets: {', '.join(PRESETS)}; "
                f"or give a {', '.join(SCENE_SUFFIXES)} file"
            )
        if path.is_dir():
            raise SceneError(f"{path} is a folder, not a scene file")
        if path.suffix.lower() not in SCENE_SUFFIXES:
            ending = f"not {path.suffix!r}" if path.suffix else "and this name has no ending"
            raise SceneError(f"{path}: a scene file ends in {', '.join(SCENE_SUFFIXES)}, {ending}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read the file: {exc}") from None
    return scene_from_text(text, "json" if path.suffix.lower() == ".json" else "yaml", source=str(path))
