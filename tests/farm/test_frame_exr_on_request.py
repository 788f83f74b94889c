"""A frame's EXR written on its first request (Settings.exr_on_request, the
default): the assembler writes the PNG, figures, thumbnail and GIF fragment
only; GET /frames/{i}.exr decides the frame again from the job's root field
and keeps the file. Its pixels must be, in every channel, the frame the
workers rendered (its PNG) and the local render of the same scene, size and
tiling; a frame that is not done is a 404, and a job whose stored field is
gone is solved again, never answered with something else."""

from __future__ import annotations

import io
import shutil

import httpx
import numpy as np
import pytest
from PIL import Image

from argand.media.frame_files import read_exr, to_srgb8
from argand.render import FrameParams, render_frame
from argand.render.frames import AOV_CHANNELS
from argand.scene import load_scene
from tests.farm.test_farm import Farm

W, H, TILE = 72, 56, 16


@pytest.fixture(scope="module")
def lazy_farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("lazy") / "data", workers=2, ARGAND_EXR_ON_REQUEST="true").start()
    yield f
    f.stop()


def _job(farm: Farm, scene: str, deltas) -> dict:
    r = farm.post("/api/jobs", {"scene": scene, "deltas": deltas, "width": W, "height": H, "tile": TILE})
    assert r.status_code == 201, r.text
    job = farm.wait_job(r.json()["id"], 180)
    assert job["status"] == "done", job
    return job


def _check_exr(path, local) -> None:
    names, px = read_exr(path)
    for i, c in enumerate("RGBA"):
        assert px[..., names.index(c)].tobytes() == local.rgba[..., i].tobytes(), c
    for aov in AOV_CHANNELS:
        assert px[..., names.index(aov)].tobytes() == local.aovs[aov].astype(np.float32).tobytes(), aov


def test_a_frames_exr_is_written_on_request_and_is_the_frame_the_workers_rendered(lazy_farm, tmp_path):
    job = _job(lazy_farm, "chmutov-octic", {"start": 0, "stop": "pi/9", "count": 4})
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    assert not list(folder.glob("frame_*.exr"))  # nothing encoded until asked
    assert len(list((folder / "field").glob("*.tape"))) == ((W + TILE - 1) // TILE) * ((H + TILE - 1) // TILE)
    scene = load_scene("chmutov-octic")
    for fr in job["frames"]:
        local = render_frame(scene, FrameParams(sigma=fr["sigma"], delta=fr["delta"], width=W, height=H), tile=TILE)
        r = httpx.get(lazy_farm.url + fr["exr_url"], timeout=60)
        assert r.status_code == 200 and r.headers["content-type"] == "image/x-exr"
        (tmp_path / "f.exr").write_bytes(r.content)
        _check_exr(tmp_path / "f.exr", local)
        # The PNG the assembler wrote from the workers' tiles shows the same pixels.
        png = np.asarray(Image.open(io.BytesIO(httpx.get(lazy_farm.url + fr["png_url"], timeout=30).content)))
        assert np.array_equal(png, to_srgb8(local.rgba)), fr["index"]
        # Kept: the second request is the same file.
        assert (folder / f"frame_{fr['index']:04d}.exr").read_bytes() == r.content
        assert httpx.get(lazy_farm.url + fr["exr_url"], timeout=30).content == r.content
    # The channel previews read the EXR (written first when missing).
    second = job["frames"][1]["index"]
    (folder / f"frame_{second:04d}.exr").unlink()
    r = httpx.get(f"{lazy_farm.url}/api/jobs/{job['id']}/frames/{second}/status.png", timeout=60)
    assert r.status_code == 200 and r.content[:4] == b"\x89PNG"
    assert (folder / f"frame_{second:04d}.exr").exists()


def test_a_job_without_its_stored_field_is_solved_again(lazy_farm, tmp_path):
    job = _job(lazy_farm, "steiner", [0.3])
    folder = lazy_farm.data / "store" / "jobs" / job["id"]
    shutil.rmtree(folder / "field")
    r = httpx.get(lazy_farm.url + job["frames"][0]["exr_url"], timeout=60)
    assert r.status_code == 200
    (tmp_path / "f.exr").write_bytes(r.content)
    _check_exr(tmp_path / "f.exr", render_frame(load_scene("steiner"), FrameParams(sigma=0.0, delta=0.3, width=W,
                                                                                   height=H), tile=TILE))

