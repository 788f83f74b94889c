"""Scene files: minimal scenes, clear validation errors, the presets."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from argand.scene import PRESETS, SceneError, load_scene, scene_from_dict
from argand.scene.presets import PRESET_DIR

REPO = Path(__file__).resolve().parents[1]


def test_minimal_scene_is_complete():
    s = scene_from_dict({"objects": [{"surface": "x^2*z + y^2"}]})
    assert s.objects[0].space == "complex" and s.objects[0].polynomial.degree == 3
    cam = s.resolved_camera()
    assert cam.fov == 40.0 and sum(v * v for v in cam.position) > 1


@pytest.mark.parametrize(
    "data, message",
    [
        ({"objects": [{"surface": "x^2 + w"}]}, "objects.0.surface: unknown name 'w'"),
        ({"objects": [{"surface": "x^2", "colour": "red"}]}, "objects.0.colour"),
        ({"objects": [{"surface": "x^2", "clip_radius": "abc"}]}, "objects.0.clip_radius"),
        ({"objects": [{"surface": "x^2", "clip_radius": -1}]}, "greater than 0"),
        ({"objects": [{"surface": "x^2", "space": "quaternion"}]}, "objects.0.space"),
        ({"objects": [{"surface": "x^2", "material": {"color": "#zzzzzz"}}]}, "colour"),
        ({"objects": [{"surface": "x^2", "material": {"transparency": 0.8, "reflectivity": 0.5}}]}, "must not exceed 1"),
        ({"objects": [{"surface": "x^2"}], "camera": {"position": [1, 1, 1], "fov": 200}}, "camera.fov"),
        ({"objects": [{"surface": "x^2"}], "camera": {"position": [0, 0, 5], "up": [0, 0, 1]}}, "parallel"),
        ({"objects": []}, "objects"),
        ({"objects": [{"surface": "(x + y"}]}, "unmatched '('"),
        ({"objects": [{"surface": "x^2"}], "lights": [{"color": [1, 1, 1]}]}, "either a direction or a position"),
    ],
)
def test_bad_scenes_give_clear_errors(data, message):
    with pytest.raises(SceneError) as info:
        scene_from_dict(data)
    assert message in str(info.value), str(info.value)


def test_not_a_mapping():
    with pytest.raises(SceneError, match="mapping"):
        scene_from_dict(["x^2"])


@pytest.mark.parametrize(
    "name, degrees",
    [("whitney", [3]), ("plucker", [3]), ("bicube", [4]), ("mitchell", [4]), ("steiner", [4]), ("whitney-in-sphere", [3, 2])],
)
def test_presets(name, degrees):
    s = load_scene(name)
    assert [o.polynomial.degree for o in s.objects] == degrees


def test_scenes_folder_matches_packaged_presets():
    for name in PRESETS:
        assert (REPO / "scenes" / f"{name}.yaml").read_bytes() == (PRESET_DIR / f"{name}.yaml").read_bytes()


def test_load_scene_errors(tmp_path):
    with pytest.raises(SceneError, match="presets: whitney"):
        load_scene("no-such-scene")
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects:\n  - surface: [unclosed\n")
    with pytest.raises(SceneError, match="YAML error at line"):
        load_scene(bad)
    badjson = tmp_path / "bad.json"
    badjson.write_text('{"objects": [}')
    with pytest.raises(SceneError, match="JSON error at line 1"):
        load_scene(badjson)
    good = tmp_path / "good.json"
    good.write_text(json.dumps({"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "space": "real"}]}))
    assert load_scene(good).objects[0].space == "real"
