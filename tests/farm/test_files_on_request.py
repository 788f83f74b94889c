"""A frame's files made on their first request (Settings.files_on_request,
the default): a job is done once its tiles are, with no picture encoded and
no tile's pixels kept; the figures of each frame are the tiles' counts. A
frame's PNG, thumbnail and EXR are then decided again from the job's root
field when first asked for, and must be the very files the assembler would
have written from the workers' pixels (the local render of the same scene,
size and tiling, encoded by the same writers); the animation (GIF, MP4,
WebP) and a grid's atlas are made from them. Every file is written once
and served from the store afterwards; a frame that is not done has none."""

from __future__ import annotations

import concurrent.futures
import io

import httpx
import numpy as np
import pytest
from PIL import Image

from argand.media import gif
from argand.media.frame_files import read_exr, to_srgb8
from argand.render import FrameParams, render_frame
from argand.render.frames import AOV_CHANNELS, frame_figures
from argand.scene import load_scene
from tests.farm.test_farm import Farm, tile_rows

W, H, TILE = 72, 56, 16

#: A frame's figures that come from its pixels (seconds and ns per pixel are the workers' own).
COUNTED = ("certified_share", "status_shares", "hit_share", "escalations", "escalated_share", "escalation_levels",
           "exact_pixels", "exact_multiple_roots", "exact_over_cap", "root_calls", "sigma", "delta", "width", "height",
           "samples", "method")


@pytest.fixture(scope="module")
def lazy_farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("files") / "data", workers=2, ARGAND_FILES_ON_REQUEST="true",
             ARGAND_EXR_ON_REQUEST="true").start()
    yield f
    f.stop()


def _job(farm: Farm, body: dict) -> dict:
    r = farm.post("/api/jobs", {"width": W, "height": H, "tile": TILE, **body})
    assert r.status_code == 201, r.text
    job = farm.wait_job(r.json()["id"], 240)
    assert job["status"] == "done", job
    return job


def _png(farm: Farm, url: str) -> tuple[bytes, np.ndarray]:
    r = httpx.get(farm.url + url, timeout=120)
    assert r.status_code == 200 and r.headers["content-type"] == "image/png", (url, r.status_code, r.text[:200])
    return r.content, np.asarray(Image.open(io.BytesIO(r.content)))


def test_a_done_job_holds_no_picture_until_one_is_asked_for(lazy_farm):
    job = _job(lazy_farm, {"scene": "chmutov-octic", "deltas": {"start": 0, "stop": "pi/9", "count": 4}})
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    names = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
    # The root field's tiles only: no PNG, thumbnail, EXR, JSON, GIF
    # fragment or animation, and no tile's pixels left behind.
    assert [n for n in names if not n.startswith("field/")] == [], names
    # The tiles' figures travelled in window chunks (one file for a
    # window's frames), gone with the job's end like every chunk.
    assert any(c.startswith("w-") for c in tile_rows(lazy_farm, job["id"], "chunk") if c), \
        sorted(set(tile_rows(lazy_farm, job["id"], "chunk")))
    scene = load_scene("chmutov-octic")
    for fr in job["frames"]:
        local = render_frame(scene, FrameParams(sigma=fr["sigma"], delta=fr["delta"], width=W, height=H), tile=TILE)
        want = frame_figures(local)
        assert {k: fr["figures"][k] for k in COUNTED} == {k: want[k] for k in COUNTED}, fr["index"]
        # The JSON on request: the figures and the index, as argand render
        # writes them (without the farm's assembly times), then kept.
        r = httpx.get(lazy_farm.url + fr["json_url"], timeout=60)
        assert r.status_code == 200 and r.headers["content-type"] == "application/json", r.text[:200]
        served = r.json()
        assert set(served) == set(want) | {"index"}, sorted(set(served) ^ (set(want) | {"index"}))
        assert served["index"] == fr["index"] and {k: served[k] for k in COUNTED} == {k: want[k] for k in COUNTED}
        assert (served["sigma"], served["delta"]) == (fr["sigma"], fr["delta"])
        assert (folder / f"frame_{fr['index']:04d}.json").read_bytes() == r.content


def test_a_frames_files_are_the_local_render_s_and_are_kept(lazy_farm, tmp_path):
    job = _job(lazy_farm, {"scene": "whitney", "deltas": {"start": 0, "stop": "pi/4", "count": 3}})
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    scene = load_scene("whitney")
    for fr in job["frames"]:
        i = fr["index"]
        local = render_frame(scene, FrameParams(sigma=fr["sigma"], delta=fr["delta"], width=W, height=H), tile=TILE)
        srgb = to_srgb8(local.rgba)
        data, png = _png(lazy_farm, fr["png_url"])
        assert np.array_equal(png, srgb), i
        assert (folder / f"frame_{i:04d}.png").read_bytes() == data  # kept
        _thumb_bytes, thumb = _png(lazy_farm, fr["thumbnail_url"])
        assert np.array_equal(thumb, srgb)  # (72 px: under the thumbnail size, every pixel)
        assert not (folder / f"frame_{i:04d}.exr").exists()  # the EXR only when asked for
        r = httpx.get(lazy_farm.url + fr["exr_url"], timeout=120)
        assert r.status_code == 200
        (tmp_path / "f.exr").write_bytes(r.content)
        names, px = read_exr(tmp_path / "f.exr")
        for k, c in enumerate("RGBA"):
            assert px[..., names.index(c)].tobytes() == local.rgba[..., k].tobytes(), c
        for aov in AOV_CHANNELS:
            assert px[..., names.index(aov)].tobytes() == local.aovs[aov].astype(np.float32).tobytes(), aov
        # Served from the store afterwards: the same bytes.
        assert _png(lazy_farm, fr["png_url"])[0] == data
    # The animation: the GIF the assembler would have spliced, byte for byte.
    locals_ = [render_frame(scene, FrameParams(sigma=f["sigma"], delta=f["delta"], width=W, height=H), tile=TILE)
               for f in job["frames"]]
    want = gif.splice([gif.encode_frame(to_srgb8(r.rgba)) for r in locals_], fps=8.0)
    r = httpx.get(f"{lazy_farm.url}/api/jobs/{job['id']}/animation.gif", timeout=120)
    assert r.status_code == 200 and r.content == want
    r = httpx.get(f"{lazy_farm.url}/api/jobs/{job['id']}/animation.mp4", timeout=120)
    assert r.status_code == 200 and r.content[4:8] == b"ftyp"


def test_the_animation_and_the_atlas_of_a_job_nobody_looked_at(lazy_farm):
    """The animation and the atlas make the frames' files they need first."""
    job = _job(lazy_farm, {"scene": "steiner", "sigmas": {"start": 0, "stop": "pi/4", "count": 2},
                           "deltas": {"start": 0, "stop": "pi/6", "count": 2}})
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    r = httpx.get(f"{lazy_farm.url}/api/jobs/{job['id']}/atlas.png", timeout=120)
    assert r.status_code == 200 and r.content[:4] == b"\x89PNG"
    assert sorted(p.name for p in folder.glob("thumb_*.png")) == [f"thumb_{i:04d}.png" for i in range(4)]
    r = httpx.get(f"{lazy_farm.url}/api/jobs/{job['id']}/animation.gif", timeout=120)
    assert r.status_code == 200 and r.content[:6] == b"GIF89a"
    assert sorted(p.name for p in folder.glob("frame_*.png")) == [f"frame_{i:04d}.png" for i in range(4)]


def test_first_requests_that_come_together_write_one_file(lazy_farm):
    job = _job(lazy_farm, {"scene": "bicube", "deltas": [0.2]})
    url = lazy_farm.url + job["frames"][0]["png_url"]
    with concurrent.futures.ThreadPoolExecutor(6) as pool:
        answers = list(pool.map(lambda _: httpx.get(url, timeout=120), range(6)))
    assert {r.status_code for r in answers} == {200}
    assert len({r.content for r in answers}) == 1
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    assert [p.name for p in folder.iterdir() if "tmp" in p.name or p.name.startswith(".")] == []


def test_a_frame_that_is_not_done_has_no_files(lazy_farm):
    r = lazy_farm.post("/api/jobs", {"scene": "endrass-octic", "deltas": {"start": 0, "stop": "pi/9", "count": 24},
                                     "width": 256, "height": 256})
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    assert lazy_farm.post(f"/api/jobs/{job_id}/pause").status_code == 200
    frames = lazy_farm.get(f"/api/jobs/{job_id}/frames?per_page=100")["frames"]
    waiting = [f for f in frames if f["status"] != "done"]
    assert waiting  # (24 octic frames do not finish between a submit and a pause)
    i = waiting[-1]["index"]
    for path in (f"frames/{i}.png", f"frames/{i}/thumbnail.png", f"frames/{i}.exr", f"frames/{i}.json",
                 "animation.gif"):
        r = httpx.get(f"{lazy_farm.url}/api/jobs/{job_id}/{path}", timeout=30)
        assert r.status_code == 404 and "not ready" in r.json()["detail"], path
    assert not list((lazy_farm.data / "store" / "jobs" / job_id).glob(f"*_{i:04d}.png"))
    assert not (lazy_farm.data / "store" / "jobs" / job_id / f"frame_{i:04d}.exr").exists()
    assert not (lazy_farm.data / "store" / "jobs" / job_id / f"frame_{i:04d}.json").exists()
    # (A frame the job does not have: 404 too.)
    assert httpx.get(f"{lazy_farm.url}/api/jobs/{job_id}/frames/99.exr", timeout=30).status_code == 404
    assert httpx.delete(f"{lazy_farm.url}/api/jobs/{job_id}", timeout=30).status_code == 204
