"""Scene files (YAML or JSON), validated with pydantic.

A scene says only what it needs: ``objects: [{surface: "x^2*z + y^2"}]`` is
complete; every other field has a default, and a missing camera frames the
scene (:meth:`Scene.default_camera`). Unknown fields are refused, and every
problem is reported with where it is (``objects.0.clip_radius: ...``).

The pydantic models (Scene, SceneObject, Material, Transform, Camera, Light)
and the parsing of scene text are in argand.scene.schema, imported the first
time one of them is read from here: this module's own names (check_samples,
the bounds, the framing, SceneError) load without pydantic, as
argand.render.frames' FrameParams needs them for every frame and `argand
render` of a preset does without pydantic (argand.scene.presets.preset_scene,
tests/test_startup.py).
"""

from __future__ import annotations

import difflib
import math
import re
import typing
from pathlib import Path
from typing import Any

import numpy as np

from argand.core import _core
from argand.core._core import MAX_SAMPLES
from argand.scene.expression import SurfacePolynomial

#: Read from argand.scene.schema on first use (the pydantic models and scene text).
_SCHEMA_NAMES = frozenset({"Material", "Transform", "SceneObject", "Camera", "Light", "Scene", "MaterialColor",
                           "LightColor", "BackgroundColor", "Vector", "scene_from_dict", "scene_from_text"})


def __getattr__(name: str) -> Any:
    if name in _SCHEMA_NAMES:
        from argand.scene import schema

        return getattr(schema, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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


def _vector(value: Any) -> Any:
    if isinstance(value, (list, tuple)) and len(value) == 3 and all(_is_number(v) for v in value):
        return tuple(value)
    shown = list(value) if isinstance(value, (list, tuple)) else value
    raise ValueError(f"expected three numbers [x, y, z], not {shown!r}")


# The defaults are C++'s (render.h's default member initialisers, exported
# by _core): one definition, which tests/scene/test_model.py checks.
_MATERIAL = _core.Material()
_CAMERA = _core.CameraSpec()
_LIGHT = _core.Light()
_SCENE = _core.SceneSpec()


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


def framing_position(centre: Any, radius: float) -> tuple[float, float, float]:
    """Where the default camera stands to frame the sphere (centre, radius):
    from DEFAULT_VIEW, FRAMING_MARGIN times the distance at which the sphere
    fills the vertical field of view DEFAULT_FOV (Scene.default_camera)."""
    distance = FRAMING_MARGIN * radius / math.sin(math.radians(DEFAULT_FOV / 2))
    return tuple(c + distance * d for c, d in zip(centre, DEFAULT_VIEW))  # type: ignore[return-value]


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


def _enclose(spheres: list[tuple[Any, float]]) -> tuple[tuple[float, float, float], float]:
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

    # YAML 1.1 (PyYAML) reads 1e-3 or 2E5, a number without a dot, as a
    # string, so `clip_radius: 1e-3` was refused as "not a number": a float
    # resolver for those as well, as YAML 1.2 and JSON read them.
    UniqueKeyLoader.add_implicit_resolver(
        "tag:yaml.org,2002:float", re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$"), list("-+0123456789"))
    return UniqueKeyLoader


def load_scene(name_or_path: str | Path) -> Any:
    """A preset name (see argand.scene.presets.PRESETS), or the path of a
    .yaml, .yml or .json scene file. A preset name wins over a file of the
    same name in the working directory. Raises SceneError."""
    from argand.scene.presets import PRESETS, preset_path
    from argand.scene.schema import scene_from_text

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
