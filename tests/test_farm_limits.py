"""Every request bounded, no 500s, no stuck job (issue 12): the HTTP layer on
uvicorn in process over a real SQLite file and a real embedded Redis, and
the worker's task body called directly for what fails in a worker."""

from __future__ import annotations

import copy
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest
from sqlalchemy import update

from served import start as served_start
from test_farm_work import farm_parts, queued_messages, submit  # noqa: F401  (the fixture)

from argand.farm import rendering
from argand.farm.database import engine_for, session_scope
from argand.farm.models import Job, Tile
from argand.farm.reaper import Reaper


def _serve(settings):
    from argand.api.app import create_app

    return served_start(create_app(settings))


@pytest.fixture
def api(farm_parts):  # noqa: F811
    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"max_active_jobs": 3, "max_body_bytes": 64 * 1024})
    server, thread, url = _serve(settings)
    with httpx.Client(base_url=url, timeout=60) as c:
        yield c, settings, redis_server
    server.should_exit = True
    thread.join(10)


JOB = {"scene": "plucker", "width": 16, "height": 16, "tile": 16}


def _refused(c, body, *, raw: bytes | None = None) -> str:
    r = (c.post("/api/jobs", content=raw, headers={"content-type": "application/json"}) if raw is not None
         else c.post("/api/jobs", json=body))
    assert r.status_code == 422, (body if raw is None else raw[:80], r.status_code, r.text[:300])
    return r.text


def test_bad_values_are_422_with_the_reason(api):
    c, _, _ = api
    # The angle parser's own refusals (argand.render.angles), each a 422 naming the field.
    assert "got null (None)" in _refused(c, {**JOB, "sigma": None})
    assert "got dict {}" in _refused(c, {**JOB, "sigma": {}})
    assert "got null (None)" in _refused(c, {**JOB, "deltas": [None]})
    assert "the most is 200" in _refused(c, {**JOB, "sigma": "-" * 5000 + "1"})
    assert "the most is 200" in _refused(c, {**JOB, "sigma": "0x" + "f" * 300})
    assert "within double range" in _refused(c, None, raw=b'{"scene": "plucker", "sigma": 1' + b"0" * 400 + b"}")
    assert "Field required" in _refused(c, {})
    assert "less than or equal to 10000" in _refused(c, {**JOB, "deltas": {"start": 0, "stop": 1, "count": 10**12}})
    assert "at most 10000" in _refused(c, {**JOB, "deltas": [0.0] * 10_001})
    assert "exceed the limit of 720" in _refused(c, {**JOB, "deltas": {"start": 0, "stop": 0.1, "count": 5000}})
    assert "less than or equal to 8192" in _refused(c, {**JOB, "width": 10**30})
    r = c.get("/api/jobs", params={"page": 1042210733140914176})
    assert r.status_code == 422 and "less than or equal to 1000000" in r.text
    r = c.get("/api/jobs", params={"page": 1000000, "per_page": 200})
    assert r.status_code == 200 and r.json()["jobs"] == []


def test_the_band_rule_and_unplannable_scenes_are_refused_at_submission(api):
    c, _, _ = api
    from argand.render import BAND_RULE

    assert "band rule" in _refused(c, {**JOB, "sigma": 3.0, "deltas": [1.0]}) and BAND_RULE in _refused(c, {**JOB, "sigma": 3.0, "deltas": [1.0]})
    assert "band rule" in _refused(c, {**JOB, "sigma": -0.1})
    scene = next(p["scene"] for p in c.get("/api/presets").json() if p["name"] == "plucker")
    for change, reason in (({"camera": {"position": [1e308, 1e308, 1.0]}}, "camera"),
                           ({"transform": {"scale": 5e-324}}, "camera"),
                           ({"clip_radius": 1e308}, "finite number"),
                           ({"surface": "1e300*x^2*z - x*y + y^2*z"}, "overflows binary64")):
        bad = _changed(scene, change)
        r = c.post("/api/jobs", json={**JOB, "scene": bad})
        assert r.status_code == 422, (change, r.status_code, r.text[:300])
        assert r.json()["detail"].startswith("the scene cannot be rendered: ") and reason in r.json()["detail"], r.text
    assert c.get("/api/jobs").json()["total"] == 0  # nothing refused was stored


def _changed(scene: dict, change: dict) -> dict:
    out = copy.deepcopy(scene)
    for key, value in change.items():
        (out if key == "camera" else out["objects"][0])[key] = value
    return out


def test_tiles_per_job_and_jobs_in_flight_are_bounded(api):
    c, settings, _ = api
    r = c.post("/api/jobs", json={"scene": "plucker", "width": 512, "height": 512, "tile": 8,
                                  "deltas": {"start": 0, "stop": 0.5, "count": 60}})
    assert r.status_code == 422 and "tiles" in r.text and str(settings.max_job_tiles) in r.text
    for _ in range(3):
        assert c.post("/api/jobs", json=JOB).status_code == 201
    r = c.post("/api/jobs", json=JOB)
    assert r.status_code == 429 and "limit is 3" in r.text
    first = c.get("/api/jobs").json()["jobs"][0]["id"]
    assert c.post(f"/api/jobs/{first}/cancel").status_code == 200
    assert c.post("/api/jobs", json=JOB).status_code == 201


def test_a_body_above_the_limit_is_413_before_it_is_parsed(api):
    c, settings, _ = api
    big = b'{"scene": "plucker", "deltas": [' + b"0," * 40_000 + b"0]}"
    r = c.post("/api/jobs", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413 and str(settings.max_body_bytes) in r.json()["detail"]

    def chunks():
        for _ in range(100):
            yield b" " * 1024
    r = c.post("/api/jobs", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 413
    assert c.post("/api/jobs", json=JOB).status_code == 201  # the service is still there
    assert c.get("/api/meta").json()["limits"]["max_body_bytes"] == settings.max_body_bytes


def test_parallel_first_requests_of_a_channel_png_all_succeed(api):
    c, settings, _ = api
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    assert rendering.run_tiles(settings, job_id, 0, list(range(4)), "w-test") == "rendered"
    with ThreadPoolExecutor(6) as pool:
        answers = list(pool.map(lambda _: c.get(f"/api/jobs/{job_id}/frames/0/status.png"), range(6)))
    assert [r.status_code for r in answers] == [200] * 6
    assert len({r.content for r in answers}) == 1 and answers[0].content[:8] == b"\x89PNG\r\n\x1a\n"
    folder = settings.data_path / "store" / "jobs" / job_id
    assert not [p.name for p in folder.rglob("*.tmp*")]
    assert c.get("/api/jobs/%2e%2e/frames/0/status.png").status_code == 404


def test_a_scene_that_fails_in_the_worker_fails_its_job_with_the_reason(farm_parts):  # noqa: F811
    """A job stored before the submission checks (or changed since): the
    worker's plan fails; the tiles go back and are sent again, and after the
    attempts the job fails saying why: no tile stays running."""
    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    scene = {"objects": [{"surface": "1e300*x^2*z - x*y + y^2*z", "clip_radius": 2.0}]}
    with engine_for(settings.sqlalchemy_url).begin() as conn:
        conn.execute(update(Job).where(Job.id == job_id).values(scene=scene))
    sent = queued_messages(redis_server)
    with pytest.raises(Exception):
        rendering.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        assert {t.status for t in s.query(Tile).filter(Tile.job_id == job_id)} == {"queued"}
    assert queued_messages(redis_server) == sent + 1
    with pytest.raises(Exception):
        rendering.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        assert job.status == "failed" and job.error.startswith("tile 0/0 failed 2 times (") and len(job.error) > 30
        assert "running" not in {t.status for t in s.query(Tile).filter(Tile.job_id == job_id)}


def test_the_reaper_sends_again_what_it_puts_back(farm_parts):  # noqa: F811
    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    why, claimed = rendering.claim(settings, job_id, 0, [0, 1, 2, 3], "w-stuck", None)
    assert why is None and claimed == [0, 1, 2, 3]
    with engine_for(settings.sqlalchemy_url).begin() as conn:  # running far past the hard time limit
        conn.execute(update(Tile).where(Tile.job_id == job_id).values(started=time.time() - 10 * settings.tile_hard_time_limit_s))
    sent = queued_messages(redis_server)
    assert Reaper(settings).round() == 4
    assert queued_messages(redis_server) > sent
    assert rendering.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-new") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
