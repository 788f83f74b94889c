"""GET /api/jobs/{id}/band.png and band.exr: any band (σ, δ) of a done job,
bands the job never rendered included, decided from the root field the
workers stored, equal pixel for pixel to the frame `argand render --sigma S
--delta D --tile T` makes of the job's scene, size and tiling; a field that
is missing or damaged is solved again, never read; the figures in headers;
clear refusals. A real SQLite farm store, an embedded
Redis, uvicorn on a loopback port; the job's tiles rendered by the
worker's own task body (tile_work.run_tiles)."""

from __future__ import annotations

import io
import json
import math
import random
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from argand.farm import tile_work
from argand.frames.angles import parse_angle
from argand.frames.frame_set import atlas_grid, root_atlas_cuts
from argand.render.convert import to_core_scene
from argand.media.frame_files import EXR_CHANNELS, read_exr, to_srgb8
from argand.render import FrameParams, render_frame
from argand.scene import load_scene
from tests.api.test_api import _served
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

W, H, TILE = 40, 32, 16


def _finish(settings, c, scene: str, deltas: list) -> str:
    r = c.post("/api/jobs", json={"scene": scene, "deltas": deltas, "width": W, "height": H, "tile": TILE})
    assert r.status_code == 201, r.text
    job = r.json()
    tiles = (W + TILE - 1) // TILE * ((H + TILE - 1) // TILE)
    for index in range(len(deltas)):
        assert tile_work.run_tiles(settings, job["id"], index, list(range(tiles)), "w-test") == "rendered"
    assert c.get(f"/api/jobs/{job['id']}").json()["status"] == "done"
    return job["id"]


def _png_pixels(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


def test_any_band_of_a_done_job_equals_the_local_render(farm_parts, tmp_path):  # noqa: F811
    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "whitney", [0, "pi/18"])
        rng = random.Random(5)
        pairs = [("0", "0"), ("pi/9", "pi/4"), ("0", "pi"), ("pi/2", "pi/2"), ("1.25", "0.3"), ("pi", "0")]
        pairs += [(repr(s), repr(rng.uniform(0, math.pi - s))) for s in (rng.uniform(0, math.pi) for _ in range(4))]
        scene = load_scene("whitney")
        for sigma, delta in pairs:
            local = render_frame(scene, FrameParams(sigma=parse_angle(sigma), delta=parse_angle(delta), width=W,
                                                    height=H), tile=TILE)
            r = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": sigma, "delta": delta})
            assert r.status_code == 200, r.text
            # The first band read the field the workers stored; the rest, the API's copy.
            assert r.headers["X-Argand-Root-Field"] == ("store" if (sigma, delta) == pairs[0] else "memory")
            assert r.headers["content-type"] == "image/png"
            assert np.array_equal(_png_pixels(r.content), to_srgb8(local.rgba)), (sigma, delta)
            assert float(r.headers["X-Argand-Certified-Share"]) == local.certified_share
            assert json.loads(r.headers["X-Argand-Status-Shares"]) == local.status_shares()
            assert float(r.headers["X-Argand-Sigma"]) == parse_angle(sigma)
            again = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": sigma, "delta": delta})
            assert again.content == r.content and again.headers["X-Argand-Cache"] == "hit"
        # The EXR: every channel, the status AOV included, as the local render's.
        r = c.get(f"/api/jobs/{job_id}/band.exr", params={"sigma": "pi/7", "delta": "pi/5"})
        assert r.status_code == 200 and r.headers["content-type"] == "image/x-exr"
        path = tmp_path / "band.exr"
        path.write_bytes(r.content)
        local = render_frame(scene, FrameParams(sigma=math.pi / 7, delta=math.pi / 5, width=W, height=H), tile=TILE)
        names, got = read_exr(path)
        assert sorted(names) == sorted(EXR_CHANNELS)
        for i, name in enumerate(names):
            want = local.rgba[..., "RGBA".index(name)] if name in "RGBA" else local.aovs[name].astype(np.float32)
            assert np.array_equal(got[..., i], want), name
        assert np.any(local.aovs["status"] == 0)


def test_the_band_png_is_the_png_argand_render_writes(farm_parts, tmp_path):  # noqa: F811
    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "steiner", [0])
        r = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": "0.2", "delta": "pi/6"})
        assert r.status_code == 200
    out = tmp_path / "cli"
    run = subprocess.run([sys.executable, "-m", "argand.cli", "render", "steiner", "--sigma", "0.2", "--delta", "pi/6",
                          "--size", f"{W}x{H}", "--tile", str(TILE), "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    (png,) = out.glob("*.png")
    assert np.array_equal(_png_pixels(r.content), _png_pixels(png.read_bytes()))


def test_bad_bands_and_jobs_are_refused_clearly(farm_parts):  # noqa: F811
    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "bicube", [0])
        for sigma, delta, words in (("pi/2", "pi", "band rule"), ("-0.1", "0", "band rule"), ("pi/0", "0", "σ"),
                                    ("0", "1e999", "δ"), ("0", "x+1", "δ"), ("nan", "0", "σ")):
            r = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": sigma, "delta": delta})
            assert r.status_code == 422, (sigma, delta, r.text)
            assert words in r.json()["detail"], (sigma, delta, r.json())
        r = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": "0"})
        assert r.status_code == 422  # δ missing
        assert c.get("/api/jobs/nosuchjob/band.png", params={"sigma": "0", "delta": "0"}).status_code == 404
        queued = c.post("/api/jobs", json={"scene": "bicube", "deltas": [0], "width": 16, "height": 16}).json()["id"]
        r = c.get(f"/api/jobs/{queued}/band.exr", params={"sigma": "0", "delta": "0"})
        assert r.status_code == 409 and "queued" in r.json()["detail"]


def test_the_root_arguments_show_where_the_picture_can_change(farm_parts):  # noqa: F811
    """Whitney's umbrella: every root of its primary rays lies at |arg| below
    π/6, so the histogram is empty above it, and the bands above it show
    the empty picture; the counts are the roots of the sampled rays."""
    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "whitney", [0])
        r = c.get(f"/api/jobs/{job_id}/arguments")
        assert r.status_code == 200, r.text
        hist = r.json()
        edges, counts = np.array(hist["edges"]), np.array(hist["counts"])
        assert edges[0] == 0.0 and edges[-1] == math.pi and len(counts) == len(edges) - 1
        assert hist["pixels"] == W * H  # (a grid of 48 covers every pixel of a 40x32 frame)
        # Roots whose points lie in the clipping ball (radius 2): at most the cubic's 3 per ray.
        assert counts.sum() == hist["roots"] and 0 < hist["roots"] <= 3 * W * H - hist["unverified_roots"]
        assert counts[edges[1:] > math.pi / 6 + 1e-9].sum() == 0 and counts[edges[:-1] < 0.05].sum() > 0
        above = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": "pi/5", "delta": "pi/2"})
        assert json.loads(above.headers["X-Argand-Status-Shares"])["certified"] == 1.0
        assert np.all(_png_pixels(above.content) == _png_pixels(above.content)[0, 0])  # background only
        assert c.get("/api/jobs/nosuchjob/arguments").status_code == 404


def test_an_atlas_laid_out_where_the_roots_are(farm_parts):  # noqa: F811
    """GET /arguments?atlas=N gives the cuts where the job's roots are and
    the bands between them; a job submitted with atlas_layout "roots"
    renders exactly those bands, the ones `argand render --atlas N
    --atlas-layout roots` renders for the scene and size; bad requests are
    refused saying why."""
    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "whitney", [0])
        body = c.get(f"/api/jobs/{job_id}/arguments", params={"atlas": 5}).json()
        cuts = body["atlas"]["cuts"]
        assert body["atlas"]["steps"] == 5 and len(cuts) == 6 and cuts[0] == 0.0 and cuts[-1] == math.pi
        # Whitney's roots lie below π/6: most cuts are there.
        assert sum(0 < x < math.pi / 6 for x in cuts) >= 3, cuts
        want = [(p.sigma, p.delta) for p in atlas_grid(5, root_atlas_cuts(to_core_scene(load_scene("whitney")), W, H, 5)).points]
        assert [tuple(b) for b in body["atlas"]["bands"]] == want
        assert "atlas" not in c.get(f"/api/jobs/{job_id}/arguments").json()
        for bad in (0, 141, "x"):
            assert c.get(f"/api/jobs/{job_id}/arguments", params={"atlas": bad}).status_code == 422
        r = c.post("/api/jobs", json={"scene": "whitney", "atlas": 5, "atlas_layout": "roots", "width": W, "height": H})
        assert r.status_code == 201, r.text
        frames = c.get(f"/api/jobs/{r.json()['id']}/frames").json()
        frames = frames["frames"] if isinstance(frames, dict) else frames
        assert sorted((f["sigma"], f["delta"]) for f in frames) == sorted(want)
        for body, words in (({"atlas_layout": "roots", "deltas": [0.1]}, "atlas_layout"),
                            ({"atlas": 3, "atlas_layout": "shuffled"}, "atlas_layout")):
            r = c.post("/api/jobs", json={"scene": "whitney", "width": W, "height": H, **body})
            assert r.status_code == 422 and words in r.text, r.text


@pytest.mark.parametrize("damage", ["missing", "flipped", "truncated", "other rays"])
def test_a_missing_or_damaged_field_is_solved_again_never_read(farm_parts, damage):  # noqa: F811
    """A tile's stored field that is gone, has a flipped bit, is cut short or
    was recorded for other rays: the band is solved from scratch (and the
    answer is still the local render's), never decided from those bytes."""
    from argand.farm import bands
    from argand.farm.store import store_for
    from argand.render.field import stored_tape, tape_of_stored

    settings, _redis = farm_parts
    with _served(farm_parts) as (c, _redis_server, _app):
        job_id = _finish(settings, c, "chmutov-octic", [0])
        other = _finish(settings, c, "bicube", [0])
        layout = store_for(settings).job(job_id)
        path = layout.field_tile(2)
        data = path.read_bytes()
        if damage == "missing":
            path.unlink()
        elif damage == "flipped":
            path.write_bytes(data[:60] + bytes([data[60] ^ 0x04]) + data[61:])
        elif damage == "truncated":
            path.write_bytes(data[: len(data) // 2])
        else:  # a valid tape of another scene's same tile
            path.write_bytes(stored_tape(tape_of_stored(store_for(settings).job(other).field_tile(2).read_bytes())))
        with bands._lock:
            bands._fields.clear()
        r = c.get(f"/api/jobs/{job_id}/band.png", params={"sigma": "0.1", "delta": "0.7"})
        assert r.status_code == 200, r.text
        assert r.headers["X-Argand-Root-Field"] == "solved"
        local = render_frame(load_scene("chmutov-octic"), FrameParams(sigma=0.1, delta=0.7, width=W, height=H),
                             tile=TILE)
        assert np.array_equal(_png_pixels(r.content), to_srgb8(local.rgba))
        assert float(r.headers["X-Argand-Certified-Share"]) == local.certified_share
