"""The peers benchmark (argand bench peers) at its smoke size, when surf and
POV-Ray are installed: the camera mapping is right (the peers' pictures of a
sphere and the Bicube are Argand's, pixel for pixel up to the silhouette),
the exact truth agrees with tests/helpers/pixel_truth.py, the wrong pixels
it reports are real, and the files are written."""

from __future__ import annotations

import json
import random
import shutil

import numpy as np
import pytest

from argand.bench import peers
from argand.bench.peers_scenes import real_truth, truth_objects
from argand.render import primary_ray
from argand.render.convert import to_core_scene
from argand.scene import scene_from_dict

from tests.helpers.pixel_truth import pixel_truth

HAVE_PEERS = shutil.which(peers.SURF) is not None and shutil.which(peers.POVRAY) is not None
needs_peers = pytest.mark.skipif(not HAVE_PEERS, reason=f"{peers.SURF} or {peers.POVRAY} not installed "
                                 "(make setup installs the Debian packages surf-alggeo and povray as root)")

#: An off-centre look_at and a tilted view: the mapping is exercised in every axis.
SPHERE = {"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "clip_radius": 2}],
          "camera": {"position": [4, 3, 2], "look_at": [0.3, 0.2, 0.1], "up": [0, 0, 1]}}


def _silhouette_only(diff: np.ndarray, argand_hit: np.ndarray) -> bool:
    return bool(np.all(peers._boundary(argand_hit)[diff]))


@needs_peers
@pytest.mark.parametrize("scene_data", [SPHERE, "bicube"], ids=["sphere", "bicube"])
def test_the_peers_see_argands_picture(tmp_path, scene_data):
    from argand.scene import load_scene

    scene = scene_from_dict(scene_data) if isinstance(scene_data, dict) else load_scene(scene_data)
    core = to_core_scene(scene)
    size = 72
    result, _ = peers.run_argand(scene, size)
    argand_hit = result.rgba[..., 3] > 0
    assert np.all(result.aovs["status"] == 0)
    assert 500 < argand_hit.sum() < size * size - 500  # a picture, not a blank
    surf, cpu, info = peers.run_surf(core, size, tmp_path)
    assert cpu >= 0 and info["spec_z"] > 0
    pictures = {"surf": surf}
    for sturm in (False, True):
        pictures[f"povray{'-sturm' if sturm else ''}"], trace, whole = peers.run_povray(core, size, sturm, tmp_path)
        assert 0 <= trace <= whole + 0.01
    for name, hit in pictures.items():
        diff = hit != argand_hit
        assert diff.sum() <= 3 and _silhouette_only(diff, argand_hit), (name, int(diff.sum()))


def test_the_real_truth_is_pixel_truths_answer_at_sigma_delta_zero():
    scene = scene_from_dict(peers.SPECIAL_SCENES["steiner-axes"])
    core = to_core_scene(scene)
    objects = truth_objects(core)
    size = 31
    rng = random.Random(3)
    pixels = [(x, size // 2) for x in range(0, size, 3)] + [(rng.randrange(size), rng.randrange(size)) for _ in range(25)]
    hits = 0
    for x, y in pixels:
        origin, direction = primary_ray(core, size, size, x, y)
        mine = real_truth(objects, origin, direction)
        theirs = pixel_truth(core, 0.0, 0.0, origin, direction)
        assert mine.decision == theirs.decision and mine.hit == theirs.hit, (x, y, mine, theirs.describe())
        hits += bool(mine.hit)
    assert hits > 5
    # The centre row's rays lie in the plane z = 0, which holds the double
    # lines: a ray that crosses an axis inside the ball hits on a double root.
    origin, direction = primary_ray(core, size, size, size // 2 - 8, size // 2)
    assert direction[2] == 0.0 and origin[2] == 0.0
    centre = real_truth(objects, origin, direction)
    assert centre.hit and centre.multiple


@needs_peers
def test_smoke_run_writes_its_files_and_finds_the_peers_wrong_pixels(tmp_path):
    report = peers.bench_peers(out_dir=tmp_path, smoke=True)
    for name in ("peers.json", "peers.md", "peers.png", "peers_side.png"):
        assert (tmp_path / name).stat().st_size > 1000, name
    data = json.loads((tmp_path / "peers.json").read_text())
    assert data["available"] == {"surf": True, "povray": True, "povray-sturm": True}
    assert {"machine", "versions", "rows", "totals", "runs", "timing"} <= set(data)
    rows = {(r["case"], r["size"]): r for r in data["rows"]}
    assert set(rows) == {("bicube", 96), ("steiner", 96), ("steiner-axes", 95), ("torus-tangent", 95)}
    for r in data["rows"]:
        assert r["argand"]["wrong"] == 0, r  # no certified pixel of Argand's is contradicted
        for key in ("surf", "povray", "povray-sturm", "argand", "argand_process", "argand_real"):
            assert r["cpu_s"][key] is not None and r["cpu_s"][key] >= 0, (r["case"], key)
        assert r["real_path_differs"] == 0, r["case"]  # the real-root path decides every pixel alike
        assert r["cpu_s"]["argand_process"] > r["cpu_s"]["argand"]
        for p in peers.PEERS:
            e = r["peers"][p]
            assert e["wrong"] == e["spurious_hit"] + e["missed_multiple_root"] + e["missed_simple_root"]
    # Smooth, generic views: every peer draws Argand's picture.
    for case in ("bicube", "steiner"):
        for p in peers.PEERS:
            assert rows[(case, 96)]["peers"][p]["wrong"] <= 3, (case, p)
    # Steiner's double lines along the centre row: the truth says hit (a
    # double root), Argand does not certify them, and the peers miss some.
    axes = rows[("steiner-axes", 95)]
    assert axes["argand"]["uncertified"] >= 95 and axes["argand"]["uncertified_hits_true"] >= 95
    for p in peers.PEERS:  # along the double lines: the centre row (x, y axes) and column (the z axis)
        e = axes["peers"][p]
        assert e["wrong"] > 0 and e["centre_row"] + e["centre_column"] >= 0.7 * e["wrong"], (p, e)
    # POV-Ray's closed-form quartic loses the double roots of the centre row.
    assert axes["peers"]["povray"]["missed_multiple_root"] >= 20
    # The torus from its tangent plane: with Sturm sequences POV-Ray finds
    # the tangent circle's double roots, without them it misses some.
    torus = rows[("torus-tangent", 95)]
    assert torus["argand"]["uncertified_hits_true"] >= 40
    assert torus["peers"]["povray"]["missed_multiple_root"] > 0
    assert data["totals"]["96"]["argand"]["wrong"] == 0
    text = (tmp_path / "peers.md").read_text()
    assert "![peers: speed against wrong pixels](peers.png)" in text and "steiner-axes" in text
    assert "real-root path" in text and "Argand real path ms" in text


def test_a_missing_peer_is_reported_unavailable(tmp_path, monkeypatch):
    monkeypatch.setattr(peers, "SURF", "no-such-surf-binary")
    monkeypatch.setattr(peers, "POVRAY", "no-such-povray-binary")
    report = peers.bench_peers(out_dir=tmp_path, smoke=True, surfaces=("bicube",), sizes=(24,), special=())
    assert report["available"] == {"surf": False, "povray": False, "povray-sturm": False}
    assert report["versions"] == {"surf": "unavailable", "povray": "unavailable"}
    assert report["rows"][0]["peers"] == {} and report["rows"][0]["cpu_s"]["surf"] is None
    assert "Unavailable here (binary not found): surf, povray" in (tmp_path / "peers.md").read_text()
    assert (tmp_path / "peers.png").exists() and (tmp_path / "peers_side.png").exists()
