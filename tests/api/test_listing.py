"""The job list at scale: 100 jobs of 720 frames each (rows written straight
into a real SQLite file, each frame with the figures a real render gives),
served by a real uvicorn on loopback. A page of summaries has a size and a
time that do not grow with the jobs' frames; the frames come from each
job's own frames route, a page at a time."""

from __future__ import annotations

import math
import time
import uuid

import httpx
from sqlalchemy import insert

from argand.api.app import create_app
from argand.farm.assembly import frame_figures
from argand.farm.database import engine_for, upgrade
from argand.farm.models import Frame, Job
from argand.farm.settings import Settings
from argand.render import FrameParams, render_frame
from argand.scene import load_scene
from tests.helpers.served import served

JOBS, FRAMES = 100, 720


def _fill(settings: Settings) -> list[str]:
    """JOBS done jobs of FRAMES frames (a δ sweep), every frame done with a real frame's figures."""
    figures = dict(frame_figures(render_frame(load_scene("plucker"), FrameParams(width=32, height=32), workers=1)),
                   assembly_s=0.01, encode_s=0.01)
    scene = load_scene("plucker").to_dict()
    ids, now = [], time.time()
    with engine_for(settings.sqlalchemy_url).begin() as c:
        for j in range(JOBS):
            job_id = uuid.uuid4().hex[:12]
            ids.append(job_id)
            c.execute(insert(Job).values(id=job_id, status="done", scene_name="plucker", scene=scene, width=512,
                                         height=512, tile=64, method="auto", priority=5, created=now + j,
                                         started=now + j, finished=now + j + 1))
            c.execute(insert(Frame), [dict(job_id=job_id, index=i, sigma=0.0, delta=i * math.pi / 1000, sigma_index=0,
                                           delta_index=i, status="done", tiles_total=64, tiles_done=64,
                                           finished=now + j, figures=figures, assembly_s=0.01)
                                      for i in range(FRAMES)])
    return ids


def test_a_page_of_100_jobs_of_720_frames_is_small_and_quick(tmp_path):
    settings = Settings(data_dir=tmp_path / "data")
    upgrade(settings.sqlalchemy_url)
    ids = _fill(settings)
    with served(create_app(settings)) as url, httpx.Client(base_url=url, timeout=60) as c:
        c.get("/api/jobs?per_page=1")  # the first request opens the database
        times, sizes = [], []
        for _ in range(3):
            start = time.perf_counter()
            r = c.get("/api/jobs?per_page=200")
            times.append(time.perf_counter() - start)
            sizes.append(len(r.content))
        assert r.status_code == 200
        page = r.json()
        assert page["total"] == JOBS and [j["id"] for j in page["jobs"]] == ids[::-1]
        first = page["jobs"][0]
        assert (first["frames_total"], first["frames_done"], first["sigma_count"], first["delta_count"]) == \
               (FRAMES, FRAMES, 1, FRAMES)
        assert first["thumbnail_url"] == f"/api/jobs/{ids[-1]}/frames/0/thumbnail.png"
        # A summary does not grow with its frames: under 1.5 KB a job (the frames
        # themselves made the page 13.9 MB here before, in 2 s).
        assert max(sizes) < JOBS * 1500, sizes
        assert sorted(times)[1] < 1.0, times
        # The frames: the job's own route, bounded by its page size.
        start = time.perf_counter()
        frames = c.get(f"/api/jobs/{ids[0]}/frames?per_page=1000")
        took = time.perf_counter() - start
        assert frames.status_code == 200 and frames.json()["total"] == FRAMES
        assert [f["index"] for f in frames.json()["frames"]] == list(range(FRAMES))
        assert frames.json()["frames"][5]["figures"] is not None
        assert took < 2.0, took
        assert c.get(f"/api/jobs/{ids[0]}/frames?per_page=100&page=8").json()["frames"][-1]["index"] == FRAMES - 1
    print(f"\n100 jobs x 720 frames: GET /api/jobs?per_page=200 {max(sizes)} bytes, {min(times):.3f}-{max(times):.3f} s; "
          f"one job's 720 frames {len(frames.content)} bytes, {took:.3f} s")
