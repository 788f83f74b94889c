"""The HTTP layer in process (uvicorn on a free loopback port, in a thread,
on a real SQLite file and a real embedded Redis; no worker): answers for jobs that do not exist and for bad
paths, and a job submitted over HTTP lands in the database as queued work."""

from __future__ import annotations

import threading
import time

import httpx
import pytest
import uvicorn

from test_farm import free_port
from test_farm_work import farm_parts, queued_messages  # noqa: F401  (the fixture)


@pytest.fixture
def client(farm_parts):  # noqa: F811
    from argand.api.app import create_app

    settings, redis_server = farm_parts
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(create_app(settings), host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert server.started
    with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30) as c:
        yield c, redis_server
    server.should_exit = True
    thread.join(10)


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
