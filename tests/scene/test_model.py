"""Scene files: minimal scenes, clear validation errors, framing, the presets."""

from __future__ import annotations

import json
import math
import random
from pathlib import Path

import pytest
import yaml
from pydantic import ValidationError

from argand.scene import PRESETS, Camera, Scene, SceneError, load_scene, parse_surface, scene_from_dict, scene_from_text
from argand.scene.model import DEFAULT_FOV, surface_extent, surface_length_scale
from argand.scene.presets import PRESET_DIR, preset_path

REPO = Path(__file__).resolve().parents[2]
MINIMAL = {"objects": [{"surface": "x^2*z + y^2"}]}


def with_object(**fields) -> dict:
    return {"objects": [{"surface": "x^2 + y^2 - z", **fields}]}


# ---------------------------------------------------------------------------
# Valid scenes
# ---------------------------------------------------------------------------


def test_minimal_scene_is_complete():
    s = scene_from_dict(MINIMAL)
    obj = s.objects[0]
    assert obj.space == "complex" and obj.clip_radius is None and obj.transform is None
    assert obj.polynomial.degree == 3 and obj.polynomial is obj.polynomial  # parsed once, cached
    assert obj.material.color == (0.85, 0.55, 0.25) and obj.material.ior == 1.5
    assert s.camera is None and s.lights is None
    assert max(s.background) < 0.2  # dark grey
    camera = s.resolved_camera()
    assert camera == s.default_camera() and camera.fov == DEFAULT_FOV
    assert camera.look_at == (0.0, 0.0, 0.0) and camera.up == (0.0, 0.0, 1.0)


def test_full_scene():
    s = scene_from_dict(
        {
            "objects": [
                {
                    "surface": "x^2 + y^2 + z^2 - 1",
                    "space": "real",
                    "clip_radius": 3,
                    "material": {
                        "color": "#FF8000",
                        "diffuse": 0.5,
                        "specular": 1,
                        "shininess": 8,
                        "reflectivity": 0.25,
                        "transparency": 0.75,
                        "ior": 1.33,
                    },
                    "transform": {"translate": [1, 2, 3], "scale": 0.5, "rotate": [0, 90, 45]},
                }
            ],
            "camera": {"position": [5, 0, 1], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 30},
            "lights": [{"direction": [1, 1, 1], "color": [1, 0.9, 0.8], "intensity": 2}, {"position": [0, 0, 9]}],
            "background": [0, 0, 0],
        }
    )
    assert s.objects[0].material.color == (1.0, 128 / 255, 0.0)
    assert s.objects[0].transform.translate == (1.0, 2.0, 3.0)
    assert s.resolved_camera() is s.camera
    assert s.lights[1].position == (0.0, 0.0, 9.0) and s.lights[1].direction is None


@pytest.mark.parametrize("name", PRESETS)
def test_to_dict_round_trips_through_json(name):
    s = load_scene(name)
    data = json.loads(json.dumps(s.to_dict()))
    assert scene_from_dict(data) == s
    assert "camera" not in data  # None is left out, not written as null


def test_models_are_frozen():
    s = scene_from_dict(MINIMAL)
    with pytest.raises(ValidationError):
        s.objects[0].clip_radius = 2


# ---------------------------------------------------------------------------
# Invalid scenes: pydantic's ValidationError from the models, and SceneError
# with one readable line per problem from scene_from_dict
# ---------------------------------------------------------------------------

BAD = [
    # unknown keys
    ({"objects": [{"surface": "x^2"}], "objets": []}, "objets: unknown field 'objets'"),
    (with_object(colour="red"), "objects.0.colour: unknown field 'colour' (did you mean material: {color: ...}?)"),
    (with_object(material={"colr": "#ffffff"}), "objects.0.material.colr: unknown field 'colr' (did you mean 'color'?)"),
    (with_object(clipradius=2), "allowed: surface, space, clip_radius, material, transform"),
    # clip_radius
    (with_object(clip_radius="abc"), "objects.0.clip_radius: Input should be a valid number"),
    (with_object(clip_radius="abc"), "(got 'abc')"),
    (with_object(clip_radius=-1), "objects.0.clip_radius: Input should be greater than 0 (got -1)"),
    (with_object(clip_radius=0), "objects.0.clip_radius: Input should be greater than 0"),
    (with_object(clip_radius=float("nan")), "objects.0.clip_radius: Input should be a finite number"),
    (with_object(clip_radius=float("inf")), "objects.0.clip_radius: Input should be a finite number"),
    # space
    (with_object(space="quaternion"), "objects.0.space: Input should be 'complex' or 'real' (got 'quaternion')"),
    # surface
    ({"objects": [{"surface": "x^2 + w"}]}, "objects.0.surface: unknown name 'w' (the variables are x, y and z) at column 7"),
    ({"objects": [{"surface": "(x + y"}]}, "unmatched '('"),
    ({"objects": [{"surface": "3"}]}, "degree 0"),
    ({"objects": [{"surface": 3}]}, "objects.0.surface: Input should be a valid string (got 3)"),
    ({"objects": [{"space": "real"}]}, "objects.0.surface: required field missing"),
    # objects
    ({"objects": []}, "objects: List should have at least 1 item"),
    ({}, "objects: required field missing"),
    ({"objects": "x^2"}, "objects: Input should be a valid list"),
    # colours
    (with_object(material={"color": "#zzzzzz"}), "a colour is '#rrggbb' or [r, g, b]"),
    (with_object(material={"color": "red"}), "not 'red'"),
    (with_object(material={"color": "ff8000"}), "not 'ff8000'"),
    (with_object(material={"color": [1, 2, 0]}), "colour components must be in [0.0, 1.0], got [1, 2, 0]"),
    (with_object(material={"color": [0.5, 0.5]}), "not [0.5, 0.5]"),
    (with_object(material={"color": ["1", 0, 0]}), "objects.0.material.color"),
    ({**MINIMAL, "background": "#12345"}, "background: a colour is"),
    # material ranges
    (with_object(material={"diffuse": 1.5}), "objects.0.material.diffuse: Input should be less than or equal to 1"),
    (with_object(material={"transparency": -0.1}), "objects.0.material.transparency"),
    (with_object(material={"ior": 0.9}), "objects.0.material.ior: Input should be greater than or equal to 1"),
    (with_object(material={"shininess": 0}), "objects.0.material.shininess"),
    (with_object(material={"transparency": 0.8, "reflectivity": 0.5}), "reflectivity + transparency must not exceed 1"),
    # transform
    (with_object(transform={"scale": 0}), "objects.0.transform.scale: Input should be greater than 0"),
    (with_object(transform={"translate": [1, 2]}), "objects.0.transform.translate: expected three numbers [x, y, z], not [1, 2]"),
    (with_object(transform={"rotate": "x"}), "objects.0.transform.rotate: expected three numbers"),
    # camera
    ({**MINIMAL, "camera": {"position": [1, 1, 1], "fov": 200}}, "camera.fov: Input should be less than 179 (got 200)"),
    ({**MINIMAL, "camera": {"position": [1, 1, 1], "fov": 1}}, "camera.fov: Input should be greater than 1"),
    ({**MINIMAL, "camera": {"fov": 30}}, "camera.position: required field missing"),
    ({**MINIMAL, "camera": {"position": [0, 0, 5], "up": [0, 0, 1]}}, "parallel to the view direction"),
    ({**MINIMAL, "camera": {"position": [0, 0, 0]}}, "camera position and look_at must differ"),
    # lights
    ({**MINIMAL, "lights": [{"color": [1, 1, 1]}]}, "lights.0: a light has either a direction or a position"),
    ({**MINIMAL, "lights": [{"direction": [1, 0, 0], "position": [1, 0, 0]}]}, "exactly one of them"),
    ({**MINIMAL, "lights": [{"direction": [0, 0, 0]}]}, "direction must not be [0, 0, 0]"),
    ({**MINIMAL, "lights": [{"direction": [1, 0, 0], "intensity": -1}]}, "lights.0.intensity"),
]


@pytest.mark.parametrize("data, message", BAD)
def test_bad_scenes_give_clear_errors(data, message):
    with pytest.raises(ValidationError):
        Scene.model_validate(data)
    with pytest.raises(SceneError) as info:
        scene_from_dict(data)
    assert message in str(info.value), str(info.value)
    assert str(info.value).startswith("invalid scene:\n")
    assert info.value.problems and all(where and text for where, text in info.value.problems)


def test_every_problem_is_listed_and_surface_carets_stay_aligned():
    with pytest.raises(SceneError) as info:
        scene_from_dict(
            {
                "objects": [{"surface": "x^2 + w"}, {"surface": "x", "clip_radius": -2}],
                "camera": {"position": [1, 1, 1], "fov": 0},
            }
        )
    text = str(info.value)
    assert [where for where, _ in info.value.problems] == ["objects.0.surface", "objects.1.clip_radius", "camera.fov"]
    lines = text.splitlines()
    shown = next(line for line in lines if line.endswith("x^2 + w"))
    caret = lines[lines.index(shown) + 1]
    assert caret.index("^") == shown.index("w")


def test_not_a_mapping():
    for data in (["x^2"], None, "x^2", 3):
        with pytest.raises(SceneError, match="a scene must be a mapping with an 'objects' list"):
            scene_from_dict(data)


# ---------------------------------------------------------------------------
# Framing: the default camera
# ---------------------------------------------------------------------------


def test_surface_extent_of_bounded_surfaces():
    # A sphere of radius 2: 2, plus 5%.
    assert surface_extent(parse_surface("x^2 + y^2 + z^2 - 4")) == pytest.approx(2.1, rel=1e-6)
    # The Bicube reaches |x| = 1000^(1/4) ~ 5.62 on the axes and radius
    # sqrt(3) (1000/3)^(1/4) ~ 7.40 at its corners.
    corner = math.sqrt(3) * (1000 / 3) ** 0.25
    assert corner <= surface_extent(parse_surface("x^4 + y^4 + z^4 - 1000")) <= 1.06 * corner
    # Mitchell's surface reaches x^2 = (20 + sqrt(128)) / 8 on the x axis.
    axis = math.sqrt((20 + math.sqrt(128)) / 8)
    assert axis <= surface_extent(parse_surface(load_scene("mitchell").objects[0].surface)) <= 1.1 * axis


def test_surface_extent_of_unbounded_surfaces():
    whitney = parse_surface("x^2*z + y^2")
    assert surface_length_scale(whitney) == 1.0 and surface_extent(whitney) == 3.0
    # Scaled by 10, the same shape needs 10 times the room.
    assert surface_extent(parse_surface("x^2*z + 10*y^2")) == pytest.approx(30.0)
    # A homogeneous cone looks the same at every scale.
    assert surface_extent(parse_surface("x^2 + y^2 - z^2")) == 3.0
    # No real points at all: framed by its length scale.
    assert surface_extent(parse_surface("x^2 + y^2 + z^2 + 4")) == pytest.approx(6.0)


def test_default_camera_frames_the_clip_sphere():
    s = scene_from_dict({"objects": [{"surface": "x^2*z + y^2", "clip_radius": 2}]})
    check_framing(s)
    assert s.bounding_sphere() == ((0.0, 0.0, 0.0), 2.0)
    position = s.default_camera().position
    assert position[2] > 0 and position[0] > position[1] > 0  # from above, a 3/4 view


def test_default_camera_frames_the_union_of_moved_objects():
    s = scene_from_dict(
        {
            "objects": [
                {"surface": "x^2 + y^2 + z^2 - 1", "transform": {"translate": [10, 0, 0]}},
                {"surface": "x^2*z + y^2", "clip_radius": 2, "transform": {"translate": [-4, 0, 0], "scale": 0.5}},
            ]
        }
    )
    centre, radius = s.bounding_sphere()
    # Exact for two spheres: x from -5 to 11.05.
    assert centre == pytest.approx((3.025, 0, 0)) and radius == pytest.approx(8.025)
    check_framing(s)


def test_bounding_sphere_holds_every_object():
    rng = random.Random(2)
    for _ in range(30):
        objects = [
            {
                "surface": "x^2*z + y^2",
                "clip_radius": rng.uniform(0.1, 5),
                "transform": {"translate": [rng.uniform(-20, 20) for _ in range(3)], "scale": rng.uniform(0.2, 3)},
            }
            for _ in range(rng.randint(1, 6))
        ]
        s = scene_from_dict({"objects": objects})
        centre, radius = s.bounding_sphere()
        for obj in s.objects:
            c, r = obj.bounding_sphere()
            assert math.dist(centre, c) + r <= radius * (1 + 1e-9)
        check_framing(s)


def check_framing(s: Scene) -> None:
    """The bounding sphere lies inside the camera's vertical field of view."""
    camera = s.default_camera()
    centre, radius = s.bounding_sphere()
    assert camera.look_at == pytest.approx(centre)
    distance = math.dist(camera.position, centre)
    assert radius / distance < math.sin(math.radians(camera.fov / 2))
    assert radius / distance > 0.8 * math.sin(math.radians(camera.fov / 2))  # and fills most of it


def test_an_explicit_camera_is_kept():
    s = scene_from_dict({**MINIMAL, "camera": {"position": [0, -5, 1]}})
    assert s.resolved_camera() == Camera(position=(0, -5, 1))


# ---------------------------------------------------------------------------
# Presets
# ---------------------------------------------------------------------------

# The paper's Table 1, exactly as printed (with "·" written "*").
TABLE_1 = {
    "whitney": "x^2*z + y^2",
    "plucker": "x^2*z - x*y + y^2*z",
    "bicube": "x^4 + y^4 + z^4 - 1000",
    "mitchell": "4*(x^4 + (y^2 + z^2)^2) + 17*x^2*(y^2 + z^2) - 20*(x^2 + y^2 + z^2) + 17",
    "steiner": "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2",
}


@pytest.mark.parametrize(
    "name, degrees",
    [("whitney", [3]), ("plucker", [3]), ("bicube", [4]), ("mitchell", [4]), ("steiner", [4]), ("whitney-in-sphere", [3, 2])],
)
def test_presets_load_with_their_degrees(name, degrees):
    s = load_scene(name)
    assert [o.polynomial.degree for o in s.objects] == degrees
    if name in TABLE_1:
        assert s.objects[0].surface == TABLE_1[name]


def test_whitney_in_sphere_is_figure_7():
    umbrella, sphere = load_scene("whitney-in-sphere").objects
    assert umbrella.surface == TABLE_1["whitney"] and umbrella.space == "complex"
    assert sphere.space == "real" and sphere.clip_radius is None
    r2 = -sphere.polynomial.terms[(0, 0, 0)]
    assert sphere.polynomial.terms == {(2, 0, 0): 1, (0, 2, 0): 1, (0, 0, 2): 1, (0, 0, 0): -r2}
    assert umbrella.clip_radius < math.sqrt(r2)  # the umbrella is inside the sphere
    assert 0.6 <= sphere.material.transparency <= 0.7
    assert sphere.material.ior == pytest.approx(1.3) and sphere.material.reflectivity == pytest.approx(0.15)


def test_unbounded_presets_are_clipped():
    for name in ("whitney", "plucker", "steiner"):
        assert load_scene(name).objects[0].clip_radius is not None


def test_presets_are_all_the_packaged_files():
    assert sorted(p.stem for p in PRESET_DIR.glob("*.yaml")) == sorted(PRESETS)
    assert all(preset_path(name).is_file() for name in PRESETS)
    with pytest.raises(ValueError, match="presets: whitney"):
        preset_path("nope")


#: scenes/ holds the presets' copies and this example of a scene of one's own.
EXAMPLE_SCENE = "my-scene.yaml"


def test_scenes_folder_equals_the_packaged_presets_byte_for_byte():
    # The packaged files are the source; scenes/ holds copies for readers of
    # the repository. Fix a difference with: cp src/argand/scene/presets/*.yaml scenes/
    source = REPO / "src" / "argand" / "scene" / "presets"
    assert sorted(p.name for p in (REPO / "scenes").glob("*.yaml")) == sorted([f"{n}.yaml" for n in PRESETS] + [EXAMPLE_SCENE])
    for name in PRESETS:
        assert (REPO / "scenes" / f"{name}.yaml").read_bytes() == (source / f"{name}.yaml").read_bytes(), name
        # and the package this test imports ships the same files
        assert preset_path(name).read_bytes() == (source / f"{name}.yaml").read_bytes(), name


def test_the_example_scene_loads_and_renders():
    """scenes/my-scene.yaml, the commented example the docs point to, is a
    valid scene whose surface shows in a small frame."""
    from argand.render import FrameParams, render_frame

    text = (REPO / "scenes" / EXAMPLE_SCENE).read_text()
    assert text.count("\n#") >= 3 and "argand render scenes/my-scene.yaml" in text  # commented, with its command
    scene = load_scene(str(REPO / "scenes" / EXAMPLE_SCENE))
    assert [o.polynomial.degree for o in scene.objects] == [4] and scene.samples == 1
    result = render_frame(scene, FrameParams(delta=math.pi / 18, width=48, height=48), workers=1)
    assert result.aovs["status"].shape == (48, 48) and result.rgba[..., 3].mean() > 0.2  # the torus covers the frame


def test_preset_files_are_minimal():
    """A preset says only what it needs: no field equal to its default."""
    defaults = Scene.model_validate(MINIMAL).objects[0]
    for name in PRESETS:
        data = yaml.safe_load(preset_path(name).read_text())
        assert set(data) == {"objects"}, name
        for obj in data["objects"]:
            for key, value in obj.items():
                if key not in ("surface", "material"):
                    assert value != getattr(defaults, key), (name, key)
            for key, value in obj.get("material", {}).items():
                assert value != getattr(defaults.material, key), (name, key)


# ---------------------------------------------------------------------------
# load_scene
# ---------------------------------------------------------------------------


def test_load_scene_reads_yaml_yml_json_and_paths(tmp_path):
    data = {"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "space": "real"}]}
    for suffix in (".yaml", ".yml", ".json"):
        path = tmp_path / f"scene{suffix}"
        path.write_text(json.dumps(data) if suffix == ".json" else yaml.safe_dump(data))
        assert load_scene(path).objects[0].space == "real"
        assert load_scene(str(path)) == load_scene(path)


def test_unknown_preset_lists_the_presets():
    with pytest.raises(SceneError) as info:
        load_scene("no-such-scene")
    message = str(info.value)
    assert "no preset or file named 'no-such-scene'" in message
    assert "presets: " + ", ".join(PRESETS) in message
    with pytest.raises(SceneError, match="did you mean 'whitney'"):
        load_scene("whitny")


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="the file does not exist"):
        load_scene(tmp_path / "nowhere.yaml")
    with pytest.raises(SceneError, match="the file does not exist"):
        load_scene("scenes/nowhere.yaml")


def test_folder_and_wrong_suffix(tmp_path):
    with pytest.raises(SceneError, match="is a folder"):
        load_scene(tmp_path)
    text = tmp_path / "scene.txt"
    text.write_text("objects: []")
    with pytest.raises(SceneError, match=r"ends in \.yaml, \.yml, \.json"):
        load_scene(text)


@pytest.mark.parametrize(
    "content, message",
    [
        ("objects:\n  - surface: [unclosed\n", "YAML error at line 3, column 1"),
        ("objects:\n  - surface: 'x^2'\n   clip_radius: 2\n", "YAML error at line 3"),
        ("objects:\n  - surface: 'x^2'\n    clip_radius: 1\n    clip_radius: 2\n", "the key 'clip_radius' is given twice"),
        ("", "a scene must be a mapping"),
        ("- surface: x^2\n", "a scene must be a mapping"),
        ("objects:\n  - surface: x^2 + (y\n", "objects.0.surface: unmatched '(' at column 7"),
        ("objects:\n  - surface: x^2\n    clip_radius: abc\n", "objects.0.clip_radius: Input should be a valid number"),
    ],
)
def test_yaml_errors(tmp_path, content, message):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert message in str(info.value), str(info.value)
    assert str(info.value).startswith(f"{path}: ")


def test_numbers_without_a_dot_in_yaml_are_numbers(tmp_path):
    """1e-3 and 2E1 are numbers in YAML 1.2 and JSON; PyYAML (YAML 1.1)
    read them as strings, and a scene refused them as "not a number"."""
    path = tmp_path / "exponents.yaml"
    path.write_text("objects:\n  - surface: x^2 + y^2 + z^2 - 1\n    clip_radius: 2E0\n"
                    "    transform: {rotate: [0, 0, 1e1], scale: 5e-1, translate: [+1e0, -2e-1, 0]}\n")
    obj = load_scene(path).objects[0]
    assert obj.clip_radius == 2.0
    assert obj.transform.rotate == (0.0, 0.0, 10.0) and obj.transform.scale == 0.5
    assert obj.transform.translate == (1.0, -0.2, 0.0)
    # The same scene as JSON reads the same.
    json_path = tmp_path / "exponents.json"
    json_path.write_text(json.dumps({"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "clip_radius": 2e0, "transform": {
        "rotate": [0, 0, 1e1], "scale": 5e-1, "translate": [1e0, -2e-1, 0]}}]}))
    assert load_scene(json_path) == load_scene(path)


def test_duplicate_key_error_names_its_line(tmp_path):
    path = tmp_path / "twice.yaml"
    path.write_text("objects:\n  - surface: 'x^2'\n    clip_radius: 1\n    clip_radius: 2\n")
    with pytest.raises(SceneError, match="line 4"):
        load_scene(path)


def test_json_errors(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"objects": [}')
    with pytest.raises(SceneError, match="JSON error at line 1, column 14"):
        load_scene(path)
    path.write_text('{"objects": [{"surface": "x^2", "space": "imaginary"}]}')
    with pytest.raises(SceneError, match="objects.0.space: Input should be 'complex' or 'real'"):
        load_scene(path)


def test_unreadable_file(tmp_path):
    path = tmp_path / "binary.yaml"
    path.write_bytes(b"\xff\xfe\x00objects")
    with pytest.raises(SceneError, match="cannot read the file"):
        load_scene(path)


@pytest.mark.parametrize("kind", ["json", "yaml"])
@pytest.mark.parametrize(
    "text, message",
    [
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        ('{"objects": [{"surface": "x", "clip_radius": ' + "9" * 5000 + "}]}", "4300 digits"),
    ],
    ids=["deep", "huge-integer"],
)
def test_text_that_breaks_the_json_and_yaml_readers_is_a_scene_error(kind, text, message):
    # Deep nesting and huge integers make the JSON and YAML readers raise
    # RecursionError or a plain ValueError: both must become a SceneError.
    with pytest.raises(SceneError, match=message):
        scene_from_text(text, kind)
