"""Each limit of a scene field is written once, in C++ (_core.FIELD_LIMITS):
the typed scene's setters check it and the pydantic scene model reads it.
Checked here from both sides: every limit is enforced by both, with the same
bounds; a value on a bound (or, for an open bound, the nearest double inside
it) is accepted, and the nearest double outside is refused naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import annotated_types
import pytest

from argand.core import _core
from argand.scene import model
from argand.scene.model import SceneError, scene_from_dict

#: Where each FIELD_LIMITS field is in a scene file: (the pydantic model and
#: its field, the path of the value in the scene's data, the colour components
#: when the field holds [r, g, b]).
SCENE_FIELDS = {
    "Material.color": (model.Material, "color", ("objects", 0, "material", "color"), True),
    "Material.diffuse": (model.Material, "diffuse", ("objects", 0, "material", "diffuse"), False),
    "Material.specular": (model.Material, "specular", ("objects", 0, "material", "specular"), False),
    "Material.shininess": (model.Material, "shininess", ("objects", 0, "material", "shininess"), False),
    "Material.reflectivity": (model.Material, "reflectivity", ("objects", 0, "material", "reflectivity"), False),
    "Material.transparency": (model.Material, "transparency", ("objects", 0, "material", "transparency"), False),
    "Material.ior": (model.Material, "ior", ("objects", 0, "material", "ior"), False),
    "SurfaceSpec.clip_radius": (model.SceneObject, "clip_radius", ("objects", 0, "clip_radius"), False),
    "Light.color": (model.Light, "color", ("lights", 0, "color"), True),
    "Light.intensity": (model.Light, "intensity", ("lights", 0, "intensity"), False),
    "CameraSpec.fov_degrees": (model.Camera, "fov", ("camera", "fov"), False),
    "SceneSpec.background": (model.Scene, "background", ("background",), True),
}
#: Bounded number fields of the scene model with no field of the typed scene
#: behind them (a transform's scale becomes a matrix; samples are checked by
#: _core.sample_side, with FrameParams).
SCENE_ONLY = {(model.Transform, "scale"), (model.Scene, "samples")}


def scene_with(path: tuple, value) -> dict:
    data: dict = {"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "material": {}}],
                  "camera": {"position": [4, 3, 2]}, "lights": [{"direction": [1, 1, 1]}]}
    where = data
    for step in path[:-1]:
        where = where[step]
    where[path[-1]] = value
    return data


def core_struct(field: str):
    struct, name = field.split(".")
    return getattr(_core, struct)(), name


def inside_and_outside(lo: float, hi: float, lo_open: bool, hi_open: bool) -> tuple[list[float], list[float]]:
    """The values at the finite bounds that must be accepted (the bound, or the
    nearest double inside an open one) and refused (the nearest double
    outside a closed bound, or an open bound itself)."""
    accepted, refused = [], []
    for bound, is_open, inward in ((lo, lo_open, math.inf), (hi, hi_open, -math.inf)):
        if math.isinf(bound):
            continue
        accepted.append(math.nextafter(bound, inward) if is_open else bound)
        refused.append(bound if is_open else math.nextafter(bound, -inward))
    return accepted, refused


def test_every_limit_names_a_number_field_of_the_typed_scene_and_of_the_scene_model():
    assert set(_core.FIELD_LIMITS) == set(SCENE_FIELDS)
    for field, (lo, hi, lo_open, hi_open) in _core.FIELD_LIMITS.items():
        obj, name = core_struct(field)
        assert name in type(obj).FIELDS
        assert lo < hi and isinstance(lo_open, bool) and isinstance(hi_open, bool)
        cls, attr, _, _ = SCENE_FIELDS[field]
        assert attr in cls.model_fields


def pydantic_bounds(cls, attr: str) -> dict[str, float]:
    found = {}
    for rule in cls.model_fields[attr].metadata:
        for kind in ("ge", "gt", "le", "lt"):
            if isinstance(rule, getattr(annotated_types, kind.capitalize())):
                found[kind] = getattr(rule, kind)
    return found


def test_the_scene_model_has_the_same_bounds_and_no_others():
    for field, (cls, attr, _, is_colour) in SCENE_FIELDS.items():
        if is_colour:
            continue  # checked by value below: a colour's bounds are in its validator
        expected = model.bounds(field)
        if field == "SurfaceSpec.clip_radius":
            # A scene says "no clip sphere" with null; C++ says it with 0, its lower bound.
            expected = {"gt": _core.FIELD_LIMITS[field][0]}
        assert pydantic_bounds(cls, attr) == expected, field
    covered = {(cls, attr) for cls, attr, _, _ in SCENE_FIELDS.values()}
    for cls in (model.Material, model.Transform, model.SceneObject, model.Camera, model.Light, model.Scene):
        for attr in cls.model_fields:
            if pydantic_bounds(cls, attr):
                assert (cls, attr) in covered | SCENE_ONLY, f"{cls.__name__}.{attr} has bounds C++ does not share"


@pytest.mark.parametrize("field", sorted(SCENE_FIELDS))
def test_both_sides_accept_the_bounds_and_refuse_just_outside_naming_the_field(field):
    lo, hi, lo_open, hi_open = _core.FIELD_LIMITS[field]
    _, _, path, is_colour = SCENE_FIELDS[field]
    accepted, refused = inside_and_outside(lo, hi, lo_open, hi_open)
    if field == "SurfaceSpec.clip_radius":
        accepted, refused = [math.nextafter(lo, math.inf)], [lo, math.nextafter(lo, -math.inf)]
        # C++ takes its own lower bound, 0: no clip sphere.
        obj, name = core_struct(field)
        setattr(obj, name, lo)
        assert getattr(obj, name) == lo
    assert accepted and refused
    where = ".".join(str(step) for step in path)
    for value in accepted:
        given = [value, value, value] if is_colour else value
        obj, name = core_struct(field)
        setattr(obj, name, given)
        assert getattr(obj, name) == (tuple(given) if is_colour else value)
        scene = scene_from_dict(scene_with(path, given))
        assert scene is not None
    for value in refused:
        given = [value, value, value] if is_colour else value
        obj, name = core_struct(field)
        before = getattr(obj, name)
        if not (field == "SurfaceSpec.clip_radius" and value == lo):
            with pytest.raises(ValueError, match=rf"^{field}(\[\d\])? must be "):
                setattr(obj, name, given)
            assert getattr(obj, name) == before
        with pytest.raises(SceneError) as info:
            scene_from_dict(scene_with(path, given))
        assert [w for w, _ in info.value.problems] == [where], info.value


def test_the_stub_declares_the_table():
    stub = (Path(__file__).parents[2] / "src/argand/core/_core.pyi").read_text()
    assert "FIELD_LIMITS: dict[str, tuple[float, float, bool, bool]]" in stub
    assert all(isinstance(v, tuple) and len(v) == 4 for v in _core.FIELD_LIMITS.values())


def test_a_field_doc_says_its_bounds():
    assert _core.Material.ior.__doc__ == "Index of refraction, in [1.0, 4.0]."
    assert _core.Material.shininess.__doc__ == "Phong exponent, in (0.0, 10000.0]."
    assert _core.Light.color.__doc__ == "[r, g, b], each in [0.0, 1.0]."
    assert _core.CameraSpec.position.__doc__ == "The eye."
