"""Antialiasing whose certification stays honest: a pixel of `samples`
samples (a side x side grid of strata, each sampled at its centre) has the
mean colour of its samples, the worst status and the highest ladder level of
its samples, and the share of certified samples in `certified_share`.

The samples of a W x H frame are, to the bit, the pixel centres of the
(side W) x (side H) frame, traced in that frame's order, so the individual
samples are checked against an independent single-sample render of the
finer frame, and the certified ones against the exact truth
(tests/helpers/pixel_truth.py)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import httpx
import numpy as np
import pytest

from argand.core import _core
from argand.render.convert import to_core_scene
from argand.render.explain import explain_pixel
from argand.render.frames import AOV_CHANNELS, MAX_SAMPLES, FrameParams, plan, render_frame
from argand.media.frame_files import read_exr
from argand.scene import SceneError, load_scene, scene_from_dict

from tests.helpers.pixel_truth import check_pixel, is_wrong, pixel_truth, scene_objects
from tests.helpers.random_surfaces import random_scene

ARGAND = str(Path(sys.executable).with_name("argand"))


def moved(preset: str, look_at) -> _core.SceneSpec:
    core = to_core_scene(load_scene(preset))
    core.camera.look_at = look_at  # the frame's centre on a singular line: cluster pixels beside certified ones
    return core


CASES = [
    # (id, scene, delta, samples, width, height, tile, exact tier's pixels per tile). Without the exact
    # tier the singular lines leave cluster samples beside certified ones (mixed pixels); with it, the
    # tier's budget is spent on the samples in the finer frame's order too.
    ("steiner-axis-9", lambda: moved("steiner", [0.4, 0.0, 0.0]), 0.0, 9, 19, 17, 8, 0),
    ("whitney-handle-9", lambda: moved("whitney", [0.0, 0.0, -0.7]), 0.3, 9, 19, 17, 8, 0),
    ("plucker-axis-9", lambda: moved("plucker", [0.0, 0.0, 0.3]), 0.1, 9, 17, 13, 8, 0),
    ("dense-5-seeded-4", lambda: random_scene("dense", 5, seed=4), math.pi / 18, 4, 20, 14, 8, 0),
    ("steiner-axis-9-exact", lambda: moved("steiner", [0.4, 0.0, 0.0]), 0.0, 9, 19, 17, 8, 64),
    ("whitney-handle-9-exact-1", lambda: moved("whitney", [0.0, 0.0, -0.7]), 0.3, 9, 19, 17, 8, 1),
    ("plucker-axis-9-exact-1", lambda: moved("plucker", [0.0, 0.0, 0.3]), 0.1, 9, 17, 13, 8, 1),
]


def blocks(a: np.ndarray, side: int) -> np.ndarray:
    """(side h, side w, ...) -> (h, w, side * side, ...): each pixel's samples, sample k = j side + i."""
    H, W = a.shape[:2]
    h, w = H // side, W // side
    b = a.reshape(h, side, w, side, *a.shape[2:]).swapaxes(1, 2)
    return b.reshape(h, w, side * side, *a.shape[2:])


def renders(make, delta, samples, width, height, tile, exact):
    scene, side = make(), math.isqrt(samples)
    coarse = render_frame(scene, FrameParams(delta=delta, width=width, height=height, samples=samples,
                                             exact_pixels_per_block=exact), tile=tile, workers=1)
    fine = render_frame(scene, FrameParams(delta=delta, width=side * width, height=side * height,
                                           exact_pixels_per_block=exact), tile=side * tile, workers=1)
    return scene, side, coarse, fine


@pytest.mark.parametrize("name, make, delta, samples, width, height, tile, exact", CASES, ids=[c[0] for c in CASES])
def test_a_sampled_pixel_is_the_mean_colour_and_worst_status_of_its_samples(name, make, delta, samples, width,
                                                                             height, tile, exact):
    scene, side, coarse, fine = renders(make, delta, samples, width, height, tile, exact)
    a, f = coarse.aovs, {k: blocks(v, side) for k, v in fine.aovs.items()}
    rgba = blocks(fine.rgba, side)
    # Status: the worst (highest code) of the samples'; escalation: the highest level.
    assert np.array_equal(a["status"], f["status"].max(axis=2))
    assert np.array_equal(a["escalation"], f["escalation"].max(axis=2))
    # certified_share: the counted share of certified samples, in [0, 1].
    counted = (f["status"] == 0).sum(axis=2) / samples
    assert np.array_equal(a["certified_share"], counted.astype(np.float32))
    assert a["certified_share"].min() >= 0.0 and a["certified_share"].max() <= 1.0
    assert np.array_equal(a["status"] == 0, a["certified_share"] == 1.0)  # certified iff every sample is
    # Colour: the mean of the samples' colours; A: the share of samples that hit.
    assert np.allclose(coarse.rgba[..., :3], rgba[..., :3].astype(np.float64).mean(axis=2), rtol=1e-6, atol=1e-7)
    assert np.array_equal(coarse.rgba[..., 3], (rgba[..., 3] > 0).mean(axis=2).astype(np.float32))
    # Z, arg, re, im, count: those of one sample, the hitting sample of least |t| (else the first sample).
    hit = rgba[..., 3] > 0
    for y in range(height):
        for x in range(width):
            if not hit[y, x].any():
                assert a["Z"][y, x] == np.inf and a["re"][y, x] == a["im"][y, x] == a["arg"][y, x] == 0
                assert a["count"][y, x] == f["count"][y, x, 0]
                continue
            z = np.where(hit[y, x], f["Z"][y, x], np.inf)
            assert a["Z"][y, x] == z.min()
            shown = [(f["Z"][y, x, k], f["arg"][y, x, k], f["re"][y, x, k], f["im"][y, x, k], f["count"][y, x, k])
                     for k in np.flatnonzero(z == z.min())]
            assert (a["Z"][y, x], a["arg"][y, x], a["re"][y, x], a["im"][y, x], a["count"][y, x]) in shown
    # The frame's figures: a pixel is certified when all its samples are.
    assert coarse.certified_share == float(np.mean(a["status"] == 0))
    if exact:  # the tier ran (within its budget of `exact` rays per tile)
        assert fine.figures["exact_pixels"] > 0
    if exact == 0 and name != "dense-5-seeded-4":
        assert 0 < coarse.certified_share < 1 and ((a["certified_share"] > 0) & (a["certified_share"] < 1)).any()


@pytest.mark.parametrize("samples", [4, 9, 64])
def test_the_samples_are_the_finer_frame_s_pixel_centres_to_the_bit(samples):
    side = math.isqrt(samples)
    core = to_core_scene(load_scene("bicube"))
    coarse = plan(core, FrameParams(width=5, height=3, samples=samples))
    fine = plan(core, FrameParams(width=side * 5, height=side * 3))
    for y in range(3):
        for x in range(5):
            rays = [_core.primary_ray(coarse, x, y, k) for k in range(samples)]
            assert rays == [_core.primary_ray(fine, side * x + k % side, side * y + k // side) for k in range(samples)]
            assert len({tuple(d) for _, d in rays}) == samples  # distinct sub-pixel directions
    # One sample: the pixel centre, the ray of an unsampled frame.
    one = plan(core, FrameParams(width=5, height=3))
    assert _core.primary_ray(plan(core, FrameParams(width=5, height=3, samples=1)), 2, 1) == _core.primary_ray(one, 2, 1)


def test_each_sample_s_status_and_answer_hold_against_the_exact_truth():
    """explain_pixel of every sample replays render_tile's path: its status
    is the finer frame's, the worst of them is the pixel's; every certified
    sample's answer is the truth's, and a certified sampled pixel shows the
    right root of its shown sample."""
    make, delta, samples, width, height, tile, exact = CASES[0][1:]
    scene, side, coarse, fine = renders(make, delta, samples, width, height, tile, exact)
    params = FrameParams(delta=delta, width=width, height=height, samples=samples, exact_pixels_per_block=exact)
    objects = scene_objects(scene)
    frame_plan = plan(scene, params)
    checked = 0
    for y in range(height):
        for x in range(width):
            statuses = []
            for k in range(samples):
                fx, fy = side * x + k % side, side * y + k // side
                e = explain_pixel(scene, params, x, y, tile=tile, sample=k)
                assert (e["status"], e["escalation"]) == (fine.aovs["status"][fy, fx], fine.aovs["escalation"][fy, fx])
                origin, direction = _core.primary_ray(frame_plan, x, y, k)
                assert (list(origin), list(direction)) == (list(e["origin"]), list(e["direction"]))
                statuses.append(e["status"])
                if e["status"] == 0:
                    truth = pixel_truth(scene, 0.0, delta, origin, direction, objects)
                    z = fine.aovs
                    got = (0, bool(fine.rgba[fy, fx, 3] > 0), float(z["re"][fy, fx]), float(z["im"][fy, fx]), float(z["Z"][fy, fx]))
                    assert not [p for p in check_pixel(truth, *got) if is_wrong(p)], (x, y, k)
                    checked += 1
            assert coarse.aovs["status"][y, x] == max(statuses)
            assert coarse.aovs["certified_share"][y, x] == np.float32(statuses.count(0) / samples)
    assert checked > 0.8 * width * height * samples
    with pytest.raises(ValueError, match="sample 9 is not one of the pixel's 9 samples"):
        explain_pixel(scene, params, 0, 0, sample=9)
    with pytest.raises(ValueError, match=r"sample must be in 0..8 \(the plan has 9 samples per pixel\), got -1"):
        _core.primary_ray(frame_plan, 0, 0, -1)


@pytest.mark.parametrize("bad", [0, 2, 3, 5, 65, 100, -4, 4.0, "4", True])
def test_bad_sample_counts_are_refused_saying_what_is_allowed(bad):
    allowed = "one of 1, 4, 9, 16, 25, 36, 49, 64"
    with pytest.raises(ValueError, match=f"samples per pixel must be {allowed}"):
        FrameParams(samples=bad)
    with pytest.raises(SceneError, match="samples"):
        scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}], "samples": bad})
    if isinstance(bad, int) and not isinstance(bad, bool):
        with pytest.raises(ValueError, match="samples must be a square from 1 to 64"):
            _core.plan_frame(to_core_scene(load_scene("bicube")), 0.0, 0.0, 4, 4, samples=bad)
    assert MAX_SAMPLES == _core.MAX_SAMPLES == 64


def test_a_scene_may_ask_for_samples_and_frames_carry_them():
    scene = scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}], "samples": 16})
    assert scene.samples == 16 and scene_from_dict(scene.to_dict()) == scene
    r = render_frame(scene, FrameParams(width=4, height=4, samples=scene.samples), workers=1)
    assert r.figures["samples"] == 16 and r.figures["ns_per_sample"] == pytest.approx(r.figures["ns_per_pixel"] / 16)
    assert "certified_share" in AOV_CHANNELS


# ---------------------------------------------------------------------------
# The CLI and the farm
# ---------------------------------------------------------------------------


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ARGAND, *args], capture_output=True, text=True, timeout=300)


def test_cli_renders_samples_and_explains_one_sample(tmp_path):
    r = run("render", "whitney", "--delta", "0.3", "--size", "9x7", "--samples", "4", "--tile", "8",
            "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    names, px = read_exr(tmp_path / "out" / "frame_0000.exr")
    local = render_frame(load_scene("whitney"), FrameParams(delta=0.3, width=9, height=7, samples=4), tile=8, workers=1)
    for aov in AOV_CHANNELS:
        assert np.array_equal(px[..., names.index(aov)], local.aovs[aov].astype(np.float32)), aov
    share = px[..., names.index("certified_share")]
    assert share.min() >= 0 and share.max() <= 1
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(tmp_path / "out" / "frame_0000.exr"))
    assert inp.spec().getattribute("argand:samples") == 4
    inp.close()
    e = run("render", "whitney", "--delta", "0.3", "--size", "9x7", "--samples", "4", "--explain", "4,3,2")
    assert e.returncode == 0, e.stderr
    assert "sample 2 of 4 of pixel (4, 3) of 9x7" in e.stdout and "status " in e.stdout
    centre = run("render", "whitney", "--size", "9x7", "--explain", "4,3")
    assert centre.returncode == 0 and "pixel (4, 3) of 9x7" in centre.stdout
    bad = run("render", "whitney", "--size", "9x7", "--samples", "3", "--out", str(tmp_path / "bad"))
    assert bad.returncode != 0 and "--samples: samples per pixel must be one of 1, 4, 9" in bad.stderr
    assert "Traceback" not in bad.stderr and not (tmp_path / "bad").exists()
    bad = run("render", "whitney", "--size", "9x7", "--samples", "4", "--explain", "1,1,4")
    assert bad.returncode != 0 and "sample 4 is not one of the pixel's 4 samples" in bad.stderr


def test_the_farm_s_sampled_frame_equals_argand_render(tmp_path):
    from tests.farm.test_farm import Farm

    farm = Farm(tmp_path / "data").start()
    try:
        meta = farm.get("/api/meta")
        assert meta["limits"]["max_samples"] == 64 and meta["limits"]["samples"] == [1, 4, 9, 16, 25, 36, 49, 64]
        assert meta["defaults"]["samples"] == 1 and "certified_share" in meta["channels"]
        for bad, message in [(3, "samples per pixel must be one of 1, 4, 9"), (128, "less than or equal to 64"),
                             ("many", "valid integer"), (0, "greater than or equal to 1")]:
            r = farm.post("/api/jobs", {"scene": "whitney", "samples": bad})
            assert r.status_code == 422 and message in r.text, r.text
        # A sample costs what a pixel does: the job's size limit counts rays.
        r = farm.post("/api/jobs", {"scene": "whitney", "width": 4096, "height": 4096, "samples": 64})
        assert r.status_code == 422 and "16777216 pixels x 64 samples per pixel = 1073741824 rays" in r.text, r.text
        r = farm.post("/api/jobs", {"scene": "whitney", "deltas": [0.0, 0.3], "width": 20, "height": 14, "tile": 8,
                                    "samples": 9})
        assert r.status_code == 201, r.text
        job = farm.wait_job(r.json()["id"])
        assert job["status"] == "done" and job["scene"]["samples"] == 9
        for fr in job["frames"]:
            out = tmp_path / f"cli{fr['index']}"
            c = run("render", "whitney", "--delta", repr(fr["delta"]), "--size", "20x14", "--samples", "9",
                    "--tile", "8", "--out", str(out))
            assert c.returncode == 0, c.stderr
            names_cli, cli = read_exr(out / "frame_0000.exr")
            names_farm, farmed = read_exr(farm.data / "store" / "jobs" / job["id"] / f"frame_{fr['index']:04d}.exr")
            for name in names_cli:
                assert np.array_equal(farmed[..., names_farm.index(name)], cli[..., names_cli.index(name)]), name
            assert fr["figures"]["samples"] == 9
            assert 0 < fr["figures"]["certified_share"] <= 1
            png = httpx.get(farm.url + f"/api/jobs/{job['id']}/frames/{fr['index']}/certified_share.png", timeout=30)
            assert png.status_code == 200 and png.content[:4] == b"\x89PNG", png.text
    finally:
        farm.stop()


def test_a_message_carries_as_many_rays_at_any_samples():
    """The farm's runs count traced rays: at N samples a run holds N times
    fewer pixels, so a message takes as long (and meets the time limits)
    as at one sample."""
    from argand.farm.planning import batch_pixels, plan_runs, tile_rects
    from argand.farm.settings import Settings

    settings = Settings(batch_pixels=64 * 64)
    rects = tile_rects(64, 64, 16)
    for samples in (1, 4, 16):
        limit = batch_pixels(settings.batch_pixels, {"samples": samples})
        assert limit == 64 * 64 // samples
        runs = plan_runs({0: list(range(len(rects)))}, 1, rects, limit, 1)
        assert sorted(t for _, run in runs for t in run) == list(range(len(rects)))
        assert all(sum((rects[t][2] - rects[t][0]) * (rects[t][3] - rects[t][1]) for t in run) * samples <= 64 * 64
                   for _, run in runs)
