"""The scene crosses into C++ typed: render.h's structs are bound as classes
whose fields are checked when set (a wrong type or value names the field),
argand.render.convert builds them from the pydantic scene, and the scene
defaults, the status names and the ladder level names are defined once, in
C++, and read from there."""

from __future__ import annotations

import ast
import copy
import math
from pathlib import Path

import numpy as np
import pytest

from argand.core import _core
from argand.render.convert import object_transform, to_core_scene
from argand.render.frames import LADDER_LEVEL_NAMES, STATUS_NAMES, FrameParams, plan, render_frame
from argand.scene import load_scene, scene_from_dict
from argand.scene import model

STRUCTS = (_core.Material, _core.SurfaceSpec, _core.Light, _core.CameraSpec, _core.SceneSpec)


# ---------------------------------------------------------------------------
# Round trip: the pydantic scene's values arrive in C++ unchanged
# ---------------------------------------------------------------------------


def full_scene():
    return scene_from_dict({
        "objects": [
            {"surface": "x^2 + y^2 - z^2 - 1", "space": "real", "clip_radius": 2.5,
             "material": {"color": [0.1, 0.2, 0.3], "diffuse": 0.5, "specular": 0.25, "shininess": 12,
                          "reflectivity": 0.2, "transparency": 0.3, "ior": 1.33},
             "transform": {"translate": [1, -2, 0.5], "scale": 2, "rotate": [10, 20, 30]}},
            {"surface": "x*y*z - 0.125"},
        ],
        "camera": {"position": [7, -6, 5], "look_at": [0.5, 0.25, 0], "up": [0, 1, 1], "fov": 33},
        "lights": [{"direction": [1, 2, 3], "color": "#ff8000", "intensity": 0.7},
                   {"position": [-4, 0, 9]}],
        "background": [0.2, 0.3, 0.4],
    })


def test_to_core_scene_carries_every_field_of_the_pydantic_scene():
    scene = full_scene()
    core = to_core_scene(scene)
    assert isinstance(core, _core.SceneSpec) and len(core.objects) == 2
    first, second = core.objects
    poly = scene.objects[0].polynomial
    assert first.terms == tuple((i, j, k, c) for (i, j, k), c in sorted(poly.terms.items()))
    assert first.degree == 2 and second.degree == 3
    assert first.complex_space is False and second.complex_space is True
    assert first.clip_radius == 2.5 and second.clip_radius == 0.0
    m = scene.objects[0].material
    assert first.material == _core.Material(color=m.color, diffuse=0.5, specular=0.25, shininess=12.0,
                                            reflectivity=0.2, transparency=0.3, ior=1.33)
    linear, translate = object_transform(scene.objects[0].transform)
    assert first.linear == tuple(linear) and first.translate == (1.0, -2.0, 0.5)
    # object = linear (world - translate): the translated, scaled, rotated origin maps back to 0.
    assert np.allclose(np.reshape(first.linear, (3, 3)) @ (np.array(translate) - translate), 0)
    assert core.camera == _core.CameraSpec(position=[7, -6, 5], look_at=[0.5, 0.25, 0], up=[0, 1, 1], fov_degrees=33)
    assert list(core.lights) == [
        _core.Light(vector=[1, 2, 3], directional=True, color=(1.0, 128 / 255, 0.0), intensity=0.7),
        _core.Light(vector=[-4, 0, 9], directional=False, color=[1, 1, 1], intensity=1.0),
    ]
    assert core.background == (0.2, 0.3, 0.4)


def test_fields_read_back_what_was_set_and_copies_are_independent():
    s = _core.SurfaceSpec(terms=[(2, 0, 0, 1.0), (0, 0, 0, -0.5)], degree=2, clip_radius=3, linear=np.eye(3).ravel())
    assert s.terms == ((2, 0, 0, 1.0), (0, 0, 0, -0.5)) and s.degree == 2 and s.clip_radius == 3.0
    assert s.linear == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    s.material.diffuse = 0.25  # nested structs change in place
    assert s.material.diffuse == 0.25
    scene = _core.SceneSpec(objects=[s])
    scene.objects[0].degree = 3  # the scene's own list, not a copy
    scene.camera.look_at = (1, 2, 3)
    assert scene.objects[0].degree == 3 and scene.camera.look_at == (1.0, 2.0, 3.0)
    twin = copy.deepcopy(scene)
    assert twin == scene
    twin.objects[0].terms = [(1, 0, 0, 1.0)]
    twin.camera.fov_degrees = 20
    assert twin != scene and scene.objects[0].terms == s.terms and scene.camera.fov_degrees == 40.0
    assert eval(repr(_core.CameraSpec()), vars(_core)) == _core.CameraSpec()  # repr names every field


def test_a_typed_scene_renders_as_the_pydantic_scene_does():
    scene = load_scene("steiner")
    params = FrameParams(delta=0.2, width=12, height=10)
    a = render_frame(scene, params, workers=1)
    b = render_frame(to_core_scene(scene), params, workers=1)
    assert np.array_equal(a.rgba, b.rgba) and all(np.array_equal(a.aovs[k], b.aovs[k], equal_nan=True) for k in a.aovs)


# ---------------------------------------------------------------------------
# Bad types and bad values: refused, naming the field
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("cls, field, value, error, message", [
    (_core.CameraSpec, "fov_degrees", "40", TypeError, "CameraSpec.fov_degrees: expected a number, got str '40'"),
    (_core.CameraSpec, "fov_degrees", True, TypeError, "CameraSpec.fov_degrees: expected a number, got bool"),
    (_core.CameraSpec, "fov_degrees", 180, ValueError, r"CameraSpec.fov_degrees must be in \(1.0, 179.0\), got 180.0"),
    (_core.CameraSpec, "position", [1, 2], ValueError, "CameraSpec.position: expected 3 numbers, got 2 items"),
    (_core.CameraSpec, "up", [0, 0, math.nan], ValueError, r"CameraSpec.up\[2\] must be finite, got nan"),
    (_core.CameraSpec, "look_at", "abc", TypeError, "CameraSpec.look_at: expected 3 numbers, got str"),
    (_core.CameraSpec, "look_at", [0, None, 0], TypeError, r"CameraSpec.look_at\[1\]: expected a number, got NoneType"),
    (_core.Material, "diffuse", 1.5, ValueError, r"Material.diffuse must be in \[0.0, 1.0\], got 1.5"),
    (_core.Material, "shininess", 0, ValueError, r"Material.shininess must be in \(0.0, 10000.0\], got 0.0"),
    (_core.Material, "ior", 0.5, ValueError, r"Material.ior must be in \[1.0, 4.0\], got 0.5"),
    (_core.Material, "color", [1, -0.5, 0], ValueError, r"Material.color\[1\] must be in \[0.0, 1.0\], got -0.5"),
    (_core.Material, "color", 0.5, TypeError, "Material.color: expected 3 numbers, got float"),
    (_core.SurfaceSpec, "degree", 2.0, TypeError, "SurfaceSpec.degree: expected an integer, got float"),
    (_core.SurfaceSpec, "degree", 0, ValueError, f"SurfaceSpec.degree must be in 1..{_core.MAX_SURFACE_DEGREE}, got 0"),
    (_core.SurfaceSpec, "complex_space", 1, TypeError, "SurfaceSpec.complex_space: expected True or False, got int"),
    (_core.SurfaceSpec, "clip_radius", -1, ValueError, "SurfaceSpec.clip_radius must be >= 0.0, got -1.0"),
    (_core.SurfaceSpec, "clip_radius", math.inf, ValueError, "SurfaceSpec.clip_radius must be finite, got inf"),
    (_core.SurfaceSpec, "linear", [1, 0, 0], ValueError, "SurfaceSpec.linear: expected 9 numbers, got 3 items"),
    (_core.SurfaceSpec, "terms", [(1, 0, 0)], ValueError, r"SurfaceSpec.terms\[0\]: expected \(ex, ey, ez, coeff\), got 3 items"),
    (_core.SurfaceSpec, "terms", [(1, 0, 0, 1.0), (0, 0.5, 0, 1.0)], TypeError,
     r"SurfaceSpec.terms\[1\].ey: expected an integer, got float"),
    (_core.SurfaceSpec, "terms", [(1, 0, -1, 1.0)], ValueError, r"SurfaceSpec.terms\[0\].ez must be in 0..12, got -1"),
    (_core.SurfaceSpec, "terms", [(1, 0, 0, math.nan)], ValueError, r"SurfaceSpec.terms\[0\].coeff must be finite"),
    (_core.SurfaceSpec, "material", {"diffuse": 0.5}, TypeError, "SurfaceSpec.material: expected a Material, got dict"),
    (_core.Light, "intensity", -0.1, ValueError, "Light.intensity must be >= 0.0, got -0.1"),
    (_core.Light, "directional", "yes", TypeError, "Light.directional: expected True or False, got str"),
    (_core.SceneSpec, "objects", [{"terms": []}], TypeError, r"SceneSpec.objects\[0\]: expected a SurfaceSpec, got dict"),
    (_core.SceneSpec, "objects", [_core.SurfaceSpec()] * (_core.MAX_OBJECTS + 1), ValueError,
     f"SceneSpec.objects: {_core.MAX_OBJECTS + 1} items; at most {_core.MAX_OBJECTS} are allowed"),
    (_core.SceneSpec, "lights", [_core.CameraSpec()], TypeError, r"SceneSpec.lights\[0\]: expected a Light, got CameraSpec"),
    (_core.SceneSpec, "camera", None, TypeError, "SceneSpec.camera: expected a CameraSpec, got NoneType"),
    (_core.SceneSpec, "background", [0, 0, 0, 1], ValueError, "SceneSpec.background: expected 3 numbers, got 4 items"),
])
def test_a_wrong_type_or_value_is_refused_naming_the_field(cls, field, value, error, message):
    obj = cls()
    before = getattr(obj, field)
    with pytest.raises(error, match=message):
        setattr(obj, field, value)
    assert getattr(obj, field) == before  # nothing half set
    with pytest.raises(error, match=message):  # the keyword constructor checks the same way
        cls(**{field: value})


def test_unknown_fields_and_untyped_scenes_are_refused():
    with pytest.raises(TypeError, match="CameraSpec has no field 'fov'; its fields: position, look_at, up, fov_degrees"):
        _core.CameraSpec(fov=30)
    with pytest.raises(AttributeError):
        _core.SceneSpec().colour = (1, 1, 1)
    core = to_core_scene(load_scene("bicube"))
    with pytest.raises(TypeError, match=r"scene: expected a SceneSpec \(argand.render.convert.to_core_scene makes one\), got dict"):
        _core.plan_frame({"objects": []}, 0.0, 0.0, 4, 4)
    assert _core.plan_frame(core, 0.0, 0.0, 4, 4).width == 4
    # What only the whole scene can tell, plan_frame says (an empty scene, a term above the degree).
    with pytest.raises(ValueError, match="the scene has no objects"):
        _core.plan_frame(_core.SceneSpec(camera=core.camera), 0.0, 0.0, 4, 4)
    core.objects[0].degree = 3
    with pytest.raises(ValueError, match="object 0: a term exceeds the declared degree"):
        _core.plan_frame(core, 0.0, 0.0, 4, 4)


def test_numbers_may_come_from_numpy_but_not_as_bools_or_strings():
    cam = _core.CameraSpec(position=np.array([1.0, 2.0, 3.0]), fov_degrees=np.float32(30.0))
    assert cam.position == (1.0, 2.0, 3.0) and cam.fov_degrees == 30.0
    assert _core.SurfaceSpec(degree=np.int64(4)).degree == 4
    with pytest.raises(TypeError, match="CameraSpec.fov_degrees: expected a number, got bool"):
        cam.fov_degrees = np.bool_(True)


# ---------------------------------------------------------------------------
# One definition: defaults, statuses, ladder levels, the stub
# ---------------------------------------------------------------------------


def test_scene_defaults_are_cpp_s_and_the_model_and_conversion_agree():
    """render.h's default member initialisers are the defaults: the pydantic
    model's defaults equal them, and a scene that says only its surface
    arrives in C++ with every other field at its C++ default."""
    m = model.Material()
    assert _core.Material(**{f: getattr(m, f) for f in _core.Material.FIELDS}) == _core.Material()
    cam, core_cam = model.Camera(position=(1.0, 2.0, 3.0)), _core.CameraSpec()
    assert (cam.look_at, cam.up, cam.fov) == (core_cam.look_at, core_cam.up, core_cam.fov_degrees)
    assert model.DEFAULT_FOV == core_cam.fov_degrees
    light, core_light = model.Light(direction=(0.0, 0.0, 1.0)), _core.Light()
    assert (light.color, light.intensity) == (core_light.color, core_light.intensity)
    minimal = scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}]})
    assert minimal.background == _core.SceneSpec().background
    core = to_core_scene(minimal)
    surface, default = core.objects[0], _core.SurfaceSpec()
    for field in ("complex_space", "clip_radius", "material", "linear", "translate"):
        assert getattr(surface, field) == getattr(default, field), field
    assert core.lights == _core.SceneSpec().lights and len(core.lights) == 2  # render.h's default_lights()
    assert core.background == _core.SceneSpec().background
    assert core.camera.fov_degrees == core_cam.fov_degrees
    # The identity transform of a placed-but-not-moved object is the default too.
    placed = to_core_scene(scene_from_dict({"objects": [{"surface": "x - 1", "transform": {}}]})).objects[0]
    assert (placed.linear, placed.translate) == (default.linear, default.translate)


def test_status_and_ladder_names_come_from_cpp():
    assert STATUS_NAMES == _core.STATUS_NAMES == {0: "certified", 1: "cluster", 2: "unverified", 3: "undecided"}
    assert LADDER_LEVEL_NAMES == _core.LADDER_LEVEL_NAMES and LADDER_LEVEL_NAMES[5] == "exact" and len(LADDER_LEVEL_NAMES) == 8
    frames_py = (Path(__file__).parents[2] / "src/argand/render/frames.py").read_text()
    assert '"certified"' not in frames_py and '"unseeded retry"' not in frames_py  # no second spelling


def test_the_stub_types_everything_the_module_exports():
    stub = ast.parse((Path(__file__).parents[2] / "src/argand/core/_core.pyi").read_text())
    typed = set()
    for node in stub.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            typed.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            typed.add(node.target.id)
    exported = {name for name in dir(_core) if not name.startswith("_")}
    assert exported - typed == set()
    assert {"SceneSpec", "SurfaceSpec", "Material", "Light", "CameraSpec", "STATUS_NAMES", "MAX_SAMPLES"} <= typed
    for cls in STRUCTS:  # every field of every struct is in its stub class
        body = next(n for n in stub.body if isinstance(n, ast.ClassDef) and n.name == cls.__name__).body
        names = {n.name for n in body if isinstance(n, ast.FunctionDef)} | {
            n.target.id for n in body if isinstance(n, ast.AnnAssign)}
        assert set(cls.FIELDS) <= names, cls.__name__


def test_a_plan_keeps_its_own_copy_of_the_scene():
    core = to_core_scene(load_scene("bicube"))
    frame_plan = plan(core, FrameParams(width=4, height=4))
    before = _core.primary_ray(frame_plan, 1, 1)
    core.camera.position = (0.0, 0.0, 100.0)
    assert _core.primary_ray(frame_plan, 1, 1) == before
