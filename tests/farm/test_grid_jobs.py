"""(σ, δ) jobs on the farm, real parts throughout: a grid job
over HTTP on a two-worker farm is `argand render` of the same grid, pixel
for pixel; its frames carry their (σ, δ) in the database, the figures and
the EXR headers; the MP4 decodes to every frame; atlas.png is served; the
band rule is a 422 that names every bad pair."""

from __future__ import annotations

import io
import json
import subprocess

import httpx
import numpy as np
import pytest

from tests.farm.test_farm import ARGAND, Farm
from tests.farm.test_limits import JOB, _refused, api  # noqa: F401  (the fixture)
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

from argand.render import BAND_RULE
from argand.media.frame_files import read_band, read_exr

GRID = {"scene": "whitney", "sigmas": {"start": 0, "stop": "pi/12", "count": 3},
        "deltas": {"start": "pi/36", "stop": "pi/9", "count": 3}, "width": 40, "height": 32, "tile": 16}


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("grid") / "data").start()
    yield f
    f.stop()


def test_a_grid_job_over_http_is_argand_render_of_the_same_grid(farm, tmp_path):
    r = farm.post("/api/jobs", GRID)
    assert r.status_code == 201, r.text
    local = tmp_path / "local"
    cli = subprocess.run([ARGAND, "render", "whitney", "--sigmas", "0:pi/12:3", "--deltas", "pi/36:pi/9:3",
                          "--size", "40x32", "--tile", "16", "--workers", "1", "--out", str(local)],
                         capture_output=True, text=True, timeout=300)
    assert cli.returncode == 0, cli.stderr
    job = farm.wait_job(r.json()["id"])
    assert job["status"] == "done", job.get("error")
    assert len(job["sigmas"]) == 3 and len(job["deltas"]) == 3 and len(job["frames"]) == 9
    assert [(f["sigma_index"], f["delta_index"]) for f in job["frames"]] == [(i, j) for i in range(3) for j in range(3)]
    for f in job["frames"]:
        k = f["index"]
        assert (f["sigma"], f["delta"]) == (job["sigmas"][f["sigma_index"]], job["deltas"][f["delta_index"]])
        mine = json.loads((local / f"frame_{k:04d}.json").read_text())
        assert (mine["sigma"], mine["delta"]) == (f["sigma"], f["delta"]) == (f["figures"]["sigma"], f["figures"]["delta"])
        farm_exr = farm.data / "store" / "jobs" / job["id"] / f"frame_{k:04d}.exr"
        assert read_band(farm_exr) == read_band(local / f"frame_{k:04d}.exr") == (f["sigma"], f["delta"])
        names, farm_px = read_exr(farm_exr)
        local_names, local_px = read_exr(local / f"frame_{k:04d}.exr")
        assert names == local_names
        assert np.array_equal(farm_px, local_px, equal_nan=True), k
    # Not every frame is the same picture: σ and δ both change what is seen.
    shares = {f["figures"]["hit_share"] for f in job["frames"]}
    assert len(shares) >= 5, shares

    # The MP4: every frame, at the frame's (even) size, H.264 in yuv420p.
    import av

    mp4 = httpx.get(farm.url + job["mp4_url"], timeout=120)
    assert mp4.status_code == 200 and mp4.headers["content-type"] == "video/mp4"
    with av.open(io.BytesIO(mp4.content)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"
        frames = [fr.to_ndarray(format="rgb24") for fr in container.decode(stream)]
    assert len(frames) == 9 and all(fr.shape == (32, 40, 3) for fr in frames)
    with av.open(str(local / "animation.mp4")) as container:
        assert sum(1 for _ in container.decode(video=0)) == 9
    # Each decoded frame is nearest to its own PNG (the MP4 keeps the order).
    from PIL import Image

    pngs = []
    for k in range(9):
        with Image.open(local / f"frame_{k:04d}.png") as im:
            pngs.append(np.asarray(im.convert("RGB")))
    for k, fr in enumerate(frames):
        err = [np.abs(fr.astype(int) - p.astype(int)).mean() for p in pngs]
        assert err[k] == min(err) and err[k] < 6, (k, err)
    assert httpx.get(farm.url + job["mp4_url"]).content == mp4.content  # made once, kept

    # The atlas: a PNG with a cell per frame, served, and written by argand render.
    atlas = httpx.get(farm.url + job["atlas_url"], timeout=60)
    assert atlas.status_code == 200 and atlas.headers["content-type"] == "image/png"
    for data in (atlas.content, (local / "atlas.png").read_bytes()):
        with Image.open(io.BytesIO(data)) as im:
            assert im.width > 3 * 40 and im.height > 3 * 32
    # A sweep (one σ) has no atlas.
    one = farm.post("/api/jobs", {**GRID, "sigmas": "pi/36", "width": 16, "height": 16}).json()
    one = farm.wait_job(one["id"])
    assert one["status"] == "done" and one["atlas_url"] is None and one["sigmas"] == [pytest.approx(0.0872664626)]
    assert httpx.get(farm.url + f"/api/jobs/{one['id']}/atlas.png").status_code == 404


def test_an_atlas_job_lays_out_the_triangle(farm):
    r = farm.post("/api/jobs", {"scene": "whitney", "atlas": 4, "width": 16, "height": 16, "tile": 16})
    assert r.status_code == 201, r.text
    job = farm.wait_job(r.json()["id"])
    assert job["status"] == "done" and len(job["frames"]) == 10
    assert [sum(1 for f in job["frames"] if f["sigma_index"] == i) for i in range(4)] == [4, 3, 2, 1]
    assert all(f["sigma_index"] + f["delta_index"] <= 3 for f in job["frames"])
    assert httpx.get(farm.url + job["atlas_url"], timeout=60).status_code == 200


def test_pairs_outside_the_band_rule_are_a_422_naming_them(api):  # noqa: F811
    c, _, _ = api
    text = _refused(c, {**JOB, "sigmas": [0.0, 2.0, 3.0], "deltas": [0.5, 1.5]})
    detail = json.loads(text)["detail"]
    assert BAND_RULE in detail and "3 of the 6 frames" in detail, detail
    for s, d in (("2", "1.5"), ("3", "0.5"), ("3", "1.5")):
        assert f"(σ = {s}, δ = {d})" in detail
    assert "(σ = 0, δ = 0.5)" not in detail
    # Below zero and above π: (0, fl(π)) keeps the rule (fl(π) < π), its neighbours do not.
    import math

    detail = json.loads(_refused(c, {**JOB, "sigmas": {"start": "-pi/9", "stop": "pi/9", "count": 3}, "deltas": "pi"}))["detail"]
    assert "2 of the 3 frames" in detail, detail
    for s in ("-π/9", "π/9"):
        assert f"(σ = {s}, δ = π)" in detail
    assert "(σ = 0," not in detail
    assert c.get("/api/jobs").json()["total"] == 0  # nothing refused was stored


def test_grid_requests_are_checked_before_anything_is_expanded(api):  # noqa: F811
    c, settings, _ = api
    big = _refused(c, {**JOB, "sigmas": {"start": 0, "stop": 0.1, "count": 1000}, "deltas": {"start": 0, "stop": 0.1, "count": 1000}})
    assert f"1000000 frames exceed the limit of {settings.max_frames}" in big
    assert "atlas lays out its own" in _refused(c, {**JOB, "atlas": 5, "deltas": [0.1]})
    assert "sigma (one value) or sigmas" in _refused(c, {**JOB, "sigma": 0, "sigmas": [0.1]})
    assert "less than or equal to 140" in _refused(c, {**JOB, "atlas": 10**6})
    assert "exceed the limit" in _refused(c, {**JOB, "atlas": 100})  # 5050 frames
    assert "sigmas must not be empty" in _refused(c, {**JOB, "sigmas": []})
