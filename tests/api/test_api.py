"""The HTTP layer in process (uvicorn on a free loopback port, in a thread,
on a real SQLite file and a real embedded Redis; no worker): answers for jobs that do not exist and for bad
paths, and a job submitted over HTTP lands in the database as queued work."""

from __future__ import annotations

import contextlib
import json
import threading
import time

import httpx
import pytest

from tests.helpers.served import served
from tests.farm.test_work import farm_parts, queued_messages  # noqa: F401  (the fixture)


@pytest.fixture
def client(farm_parts):  # noqa: F811
    with _served(farm_parts) as (c, redis_server, _app):
        yield c, redis_server


@contextlib.contextmanager
def _served(farm_parts):  # noqa: F811
    from argand.api.app import create_app

    settings, redis_server = farm_parts
    app = create_app(settings)
    with served(app) as url, httpx.Client(base_url=url, timeout=30) as c:
        yield c, redis_server, app


def test_a_job_that_does_not_exist_is_a_404_on_every_route(client):
    c, _ = client
    for method, path in (("GET", "/api/jobs/nope"), ("POST", "/api/jobs/nope/cancel"), ("POST", "/api/jobs/nope/retry"),
                         ("DELETE", "/api/jobs/nope"), ("GET", "/api/jobs/nope/frames/0.png"),
                         ("GET", "/api/jobs/nope/frames/0/status.png"), ("GET", "/api/jobs/nope/animation.webp"),
                         ("GET", "/api/jobs/nope/events")):
        r = c.request(method, path)
        assert r.status_code == 404 and r.json()["detail"] == "no job 'nope'", (method, path, r.text)
    r = c.patch("/api/jobs/nope", json={"priority": 3})
    assert r.status_code == 404 and r.json()["detail"] == "no job 'nope'"


def test_submit_stores_queued_work_and_refuses_what_is_not_allowed(client):
    c, redis_server = client
    r = c.post("/api/jobs", json={"scene": "plucker", "deltas": [0, "pi/18"], "width": 32, "height": 32, "tile": 16})
    assert r.status_code == 201, r.text
    job = r.json()
    assert job["status"] == "queued" and job["tiles_total"] == 2 * 4 and [f["status"] for f in job["frames"]] == ["queued"] * 2
    # The answer does not wait on the broker: the API's drainer sends the job's messages from the outbox.
    deadline = time.monotonic() + 10
    while queued_messages(redis_server) < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert queued_messages(redis_server) >= 1
    r = c.post(f"/api/jobs/{job['id']}/explode")
    assert r.status_code == 422 and "cancel" in r.text
    r = c.get(f"/api/jobs/{job['id']}/frames/0/hue.png")
    assert r.status_code == 422 and "beauty, modulus, argument, status" in r.text
    assert c.get(f"/api/jobs/{job['id']}/frames/0.png").status_code == 404  # not rendered yet
    assert c.get("/api/jobs?status=lost").status_code == 422
    assert c.post(f"/api/jobs/{job['id']}/pause").json()["status"] == "paused"
    assert c.post(f"/api/jobs/{job['id']}/pause").json()["status"] == "paused"  # again: nothing changes
    assert c.post(f"/api/jobs/{job['id']}/cancel").json()["status"] == "canceled"
    assert c.delete(f"/api/jobs/{job['id']}").status_code == 204 and c.get(f"/api/jobs/{job['id']}").status_code == 404


def _set_tiles_done(settings, job_id: str, done: dict[int, int]) -> None:
    """What a worker's commits do to the frames' counters, written directly."""
    from sqlalchemy import update

    from argand.farm.database import session_scope
    from argand.farm.models import Frame

    with session_scope(settings.sqlalchemy_url) as s:
        for index, n in done.items():
            s.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == index).values(tiles_done=n))
        s.commit()


def test_the_list_is_each_jobs_own_view_without_the_scene_the_axes_and_the_frames(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    with _served(farm_parts) as (c, _, _app):
        ids = [c.post("/api/jobs", json={"scene": "plucker", "deltas": [0, 0.1, 0.2][:n], "width": 32, "height": 32,
                                         "tile": 16}).json()["id"] for n in (1, 3)]
        _set_tiles_done(settings, ids[1], {0: 4, 2: 1})  # 5 of the 3 x 4 tiles
        page = c.get("/api/jobs?per_page=5").json()
        assert page["total"] == 2 and [j["id"] for j in page["jobs"]] == ids[::-1]
        for listed in page["jobs"]:
            own = c.get(f"/api/jobs/{listed['id']}").json()
            grown = set(own) - set(listed)  # what grows with the frames: the job's own view only
            assert {"scene", "sigmas", "deltas", "frames"} <= grown and not set(listed) - set(own)
            assert grown <= {"scene", "sigmas", "deltas", "sigma_labels", "delta_labels", "frames"}
            assert {k: v for k, v in own.items() if k not in grown | {"eta_s"}} == \
                   {k: v for k, v in listed.items() if k != "eta_s"}
            frames = c.get(listed["frames_url"]).json()
            assert frames["total"] == listed["frames_total"] == len(own["frames"]) and frames["frames"] == own["frames"]
            assert (listed["sigma_count"], listed["delta_count"]) == (len(own["sigmas"]), len(own["deltas"]))
        second = next(j for j in page["jobs"] if j["id"] == ids[1])
        assert (second["tiles_done"], second["tiles_total"], second["progress"]) == (5, 12, 5 / 12)
        assert (second["frames_total"], second["frames_done"], second["thumbnail_url"]) == (3, 0, None)
        assert c.get("/api/jobs?per_page=5&status=done").json() == {"total": 0, "page": 1, "per_page": 5, "jobs": []}
        # The frames route pages: in index order, the last page short, past the end empty.
        pages = [c.get(f"/api/jobs/{ids[1]}/frames?per_page=2&page={n}").json() for n in (1, 2, 3)]
        assert [[f["index"] for f in p["frames"]] for p in pages] == [[0, 1], [2], []]
        assert all(p["total"] == 3 and p["per_page"] == 2 for p in pages)
        assert c.get(f"/api/jobs/{ids[1]}/frames?per_page=1001").status_code == 422
        assert c.get("/api/jobs/nosuchjob/frames").status_code == 404


def _events(c, job_id: str, out: list) -> None:
    with c.stream("GET", f"/api/jobs/{job_id}/events", timeout=60) as stream:
        name = None
        for line in stream.iter_lines():
            if line.startswith("event: "):
                name = line.removeprefix("event: ")
            elif line.startswith("data: "):
                out.append((name, json.loads(line.removeprefix("data: "))))
                if name in ("end", "deleted", "error"):
                    return


def test_the_streams_of_a_job_share_one_poller_and_follow_it_to_its_end(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    with _served(farm_parts) as (c, _, app):
        job_id = c.post("/api/jobs", json={"scene": "plucker", "deltas": [0, 0.1], "width": 32, "height": 32,
                                           "tile": 16}).json()["id"]
        seen = [[], [], []]
        threads = [threading.Thread(target=_events, args=(c, job_id, out)) for out in seen]
        for th in threads:
            th.start()
        deadline = time.monotonic() + 30
        while not all(any(n == "progress" for n, _ in out) for out in seen) and time.monotonic() < deadline:
            time.sleep(0.05)
        pollers = dict(app.state.job_pollers)
        assert list(pollers) == [(settings.sqlalchemy_url, job_id)] and pollers[next(iter(pollers))].streams == 3
        _set_tiles_done(settings, job_id, {1: 2})
        time.sleep(1.2)  # two polls
        assert c.post(f"/api/jobs/{job_id}/cancel").json()["status"] == "canceled"
        for th in threads:
            th.join(30)
        for out in seen:
            names = [n for n, _ in out]
            assert names[0] == "progress" and names[-2:] == ["progress", "end"] and out[-1][1] == {"status": "canceled"}
            assert out[-2][1]["status"] == "canceled" and out[-2][1]["tiles_done"] == 2 and out[-2][1]["tiles_total"] == 8
            assert [f["index"] for f in out[-2][1]["frames"]] == [0, 1]
        time.sleep(0.2)
        assert app.state.job_pollers == {}  # the poller stopped with the job
        # A job that is gone: its stream says so.
        other = c.post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16}).json()["id"]
        out: list = []
        th = threading.Thread(target=_events, args=(c, other, out))
        th.start()
        deadline = time.monotonic() + 30
        while not out and time.monotonic() < deadline:
            time.sleep(0.05)
        assert c.delete(f"/api/jobs/{other}").status_code == 204
        th.join(30)
        assert [n for n, _ in out] == ["progress", "deleted"]


def test_a_stream_whose_job_does_not_change_gets_keep_alives(farm_parts, monkeypatch):  # noqa: F811
    """No progress for a while (a queued job, no worker here) must not look like
    a dead connection: the stream sends an SSE comment every KEEPALIVE_S (the
    load test saw clients time out reads of 60 s on paused and queued jobs)."""
    from argand.api.routes import jobs as job_routes

    monkeypatch.setattr(job_routes, "KEEPALIVE_S", 0.3)
    with _served(farm_parts) as (c, _, app):
        job_id = c.post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16}).json()["id"]
        lines: list[str] = []
        with c.stream("GET", f"/api/jobs/{job_id}/events", timeout=10) as stream:
            for line in stream.iter_lines():
                lines.append(line)
                if lines.count(": keep-alive") >= 2:
                    break
        assert lines[0] == "event: progress" and lines[1].startswith("data: ")
        assert lines.count(": keep-alive") == 2
