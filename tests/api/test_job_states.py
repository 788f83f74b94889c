"""A job's state, its frames' states, its progress and its ETA tell the truth
in every state (queued, running, paused, canceled, failed, done), through
the job's own view, the list and the event stream; finished frames can be
downloaded whatever the job's state. The API in process on a real SQLite
file and a real embedded Redis; the tiles are rendered by the worker's own
functions (argand.farm.tile_work), called here so each state is reached
exactly."""

from __future__ import annotations

import json

import time

import httpx
import pytest

from argand.api.routes.jobs import POLL_S
from argand.farm import tile_work
from argand.farm.states import FRAME_SHOWN
from tests.api.test_api import _served
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

WORKER = "w-states"


def _views(c: httpx.Client, job_id: str) -> list[dict]:
    """The job as its own view, as the list shows it (its frames from the frames route), and as its event
    stream's first message."""
    own = c.get(f"/api/jobs/{job_id}").json()
    summary = next(j for j in c.get("/api/jobs?per_page=50").json()["jobs"] if j["id"] == job_id)
    listed = {**summary, "frames": c.get(summary["frames_url"]).json()["frames"]}  # the list's frames route
    assert summary["frames_done"] == sum(f["status"] == "done" for f in listed["frames"])
    time.sleep(2.5 * POLL_S)  # the last stream's poller has stopped: this stream's first poll is new
    with c.stream("GET", f"/api/jobs/{job_id}/events", timeout=30) as stream:
        lines = stream.iter_lines()
        assert next(lines) == "event: progress"
        event = json.loads(next(lines).removeprefix("data: "))
    return [own, listed, event]


def _check(c: httpx.Client, job_id: str, status: str, frames: list[str], eta: bool) -> dict:
    """Every view says ``status``, these frame states, an ETA only if ``eta``,
    and the done frames' files are served."""
    for view in _views(c, job_id):
        assert view["status"] == status, view
        assert [f["status"] for f in view["frames"]] == frames, (status, view["frames"])
        assert (view["eta_s"] is not None and view["eta_s"] > 0) if eta else view["eta_s"] is None, (status, view["eta_s"])
        assert 0 <= view["progress"] <= 1 and view["progress"] == view["tiles_done"] / view["tiles_total"]
    own = c.get(f"/api/jobs/{job_id}").json()
    assert all(f["status"] in FRAME_SHOWN for f in own["frames"])
    for f in own["frames"]:
        if f["status"] == "done":
            for url in (f["png_url"], f["exr_url"], f["thumbnail_url"]):
                r = c.get(url)
                assert r.status_code == 200 and len(r.content) > 100, (status, url, r.status_code)
        else:
            assert f["png_url"] is None and f["exr_url"] is None
    return own


def test_job_and_frame_states_progress_and_eta_in_every_state(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    with _served(farm_parts) as (c, _, _app):
        r = c.post("/api/jobs", json={"scene": "plucker", "deltas": [0, 0.1, 0.2], "width": 32, "height": 32, "tile": 16})
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]
        # queued: nothing rendered, no ETA.
        job = _check(c, job_id, "queued", ["queued"] * 3, eta=False)
        assert job["progress"] == 0
        # running: frame 0 done, two tiles of frame 1 done; the ETA is the time left.
        assert tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], WORKER) == "rendered"
        assert tile_work.run_tiles(settings, job_id, 1, [0, 1], WORKER) == "rendered"
        job = _check(c, job_id, "running", ["done", "rendering", "queued"], eta=True)
        assert job["tiles_done"] == 6 and job["tiles_total"] == 12
        # paused: nothing renders, so no ETA; the frames not done say paused.
        assert c.post(f"/api/jobs/{job_id}/pause").json()["status"] == "paused"
        _check(c, job_id, "paused", ["done", "paused", "paused"], eta=False)
        assert c.post(f"/api/jobs/{job_id}/resume").json()["status"] == "running"
        _check(c, job_id, "running", ["done", "rendering", "queued"], eta=True)
        # canceled: no frame left rendering, no ETA (it grew for ever), the done frame still served.
        assert c.post(f"/api/jobs/{job_id}/cancel").json()["status"] == "canceled"
        job = _check(c, job_id, "canceled", ["done", "canceled", "canceled"], eta=False)
        assert job["tiles_done"] == 6 and job["animation_url"] is None
        # failed: a tile fails max_tile_attempts (2) times.
        assert c.post(f"/api/jobs/{job_id}/retry").json()["status"] == "running"
        for _ in range(settings.max_tile_attempts):
            why, claimed = tile_work.claim(settings, job_id, 2, [3], WORKER, None)
            assert why is None and claimed == [3]
            tile_work.release(settings, job_id, 2, WORKER, claimed, resend=True, reason="RuntimeError: broken")
        job = _check(c, job_id, "failed", ["done", "failed", "failed"], eta=False)
        assert job["error"].startswith("tile 2/3 failed 2 times")
        # done: every tile rendered; no ETA (not "0 s"), progress 1.
        assert c.post(f"/api/jobs/{job_id}/retry").json()["status"] == "running"
        assert tile_work.run_tiles(settings, job_id, 1, [0, 1, 2, 3], WORKER) == "rendered"
        assert tile_work.run_tiles(settings, job_id, 2, [0, 1, 2, 3], WORKER) == "rendered"
        job = _check(c, job_id, "done", ["done"] * 3, eta=False)
        assert job["progress"] == 1


def test_the_meta_lists_every_state_a_frame_may_show(farm_parts):  # noqa: F811
    with _served(farm_parts) as (c, _, _app):
        shown = c.get("/api/meta").json()["frame_states"]
    assert set(shown) >= {"queued", "rendering", "assembling", "done", "canceled", "paused", "failed"}


@pytest.mark.parametrize("status,frame,shown", [
    ("canceled", "rendering", "canceled"), ("canceled", "done", "done"), ("paused", "queued", "paused"),
    ("failed", "assembling", "failed"), ("running", "rendering", "rendering"), ("queued", "queued", "queued"),
])
def test_a_frame_not_done_of_a_stopped_job_shows_the_jobs_state(status, frame, shown):
    from argand.farm.states import shown_frame_status

    assert shown_frame_status(status, frame) == shown
