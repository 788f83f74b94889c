"""Every request bounded, no 500s, no stuck job: the HTTP layer on
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

from tests.helpers.served import start as served_start
from tests.farm.test_work import farm_parts, queued_messages, submit  # noqa: F401  (the fixture)

from argand.frames.frame_set import frame_grid
from argand.farm import tile_work
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
    # The angle parser's own refusals (argand.frames.angles), each a 422 naming the field.
    # A top-level null is the field left out (the OpenAPI document allows it); a null inside a list is not.
    r = c.post("/api/jobs", json={**JOB, "sigma": None})
    assert r.status_code == 201 and r.json()["sigma_count"] == 1, r.text[:300]
    assert "got bool True" in _refused(c, {**JOB, "sigma": True})
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
    # A tile off the renderer's 8x8 seed blocks (the frame's bits would depend on the cut); the
    # document says so (multipleOf), and the service's limits name the rule for the front end.
    assert "multiple of 8" in _refused(c, {**JOB, "tile": 20})
    tile_schema = c.get("/openapi.json").json()["components"]["schemas"]["JobRequest"]["properties"]["tile"]
    assert any(s.get("multipleOf") == 8 for s in tile_schema.get("anyOf", [tile_schema])), tile_schema
    assert c.get("/api/meta").json()["limits"]["tile_multiple"] == 8
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
                           ({"transform": {"scale": 5e-324}}, "objects.0: SurfaceSpec.linear[0] must be finite"),
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
    assert r.status_code == 429 and "limit is 3" in r.text and r.headers["retry-after"] == "30"
    first = c.get("/api/jobs").json()["jobs"][0]["id"]
    assert c.post(f"/api/jobs/{first}/cancel").status_code == 200
    assert c.post("/api/jobs", json=JOB).status_code == 201
    # Retrying the canceled job would make a fourth active one: refused like a submission.
    r = c.post(f"/api/jobs/{first}/retry")
    assert r.status_code == 429 and "limit is 3" in r.text and r.headers["retry-after"] == "30"
    assert c.get(f"/api/jobs/{first}").json()["status"] == "canceled"


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
    assert tile_work.run_tiles(settings, job_id, 0, list(range(4)), "w-test") == "rendered"
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
        tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        assert {t.status for t in s.query(Tile).filter(Tile.job_id == job_id)} == {"queued"}
    assert queued_messages(redis_server) == sent + 1
    with pytest.raises(Exception):
        tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        assert job.status == "failed" and job.error.startswith("tile 0/0 failed 2 times (") and len(job.error) > 30
        assert "running" not in {t.status for t in s.query(Tile).filter(Tile.job_id == job_id)}


def test_the_reaper_sends_again_what_it_puts_back(farm_parts):  # noqa: F811
    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    why, claimed = tile_work.claim(settings, job_id, 0, [0, 1, 2, 3], "w-stuck", None)
    assert why is None and claimed == [0, 1, 2, 3]
    with engine_for(settings.sqlalchemy_url).begin() as conn:  # running far past the hard time limit
        conn.execute(update(Tile).where(Tile.job_id == job_id).values(started=time.time() - 10 * settings.tile_hard_time_limit_s))
    sent = queued_messages(redis_server)
    assert Reaper(settings).round() == 4
    assert queued_messages(redis_server) > sent
    assert tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-new") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}


def test_event_streams_are_bounded_per_client_and_in_all(farm_parts):  # noqa: F811
    import contextlib

    settings, _ = farm_parts
    settings = settings.model_copy(update={"max_streams_per_client": 2, "max_streams": 3})
    server, thread, url = _serve(settings)
    clients = {ip: httpx.Client(base_url=url, timeout=30, transport=httpx.HTTPTransport(local_address=ip))
               for ip in ("127.0.0.1", "127.0.0.2", "127.0.0.3")}
    try:
        job_id = clients["127.0.0.1"].post("/api/jobs", json=JOB).json()["id"]  # no worker: it stays queued
        path = f"/api/jobs/{job_id}/events"
        with contextlib.ExitStack() as open_streams:
            for ip in ("127.0.0.1", "127.0.0.1", "127.0.0.2"):
                r = open_streams.enter_context(clients[ip].stream("GET", path))
                assert r.status_code == 200
            r = clients["127.0.0.1"].get(path)
            assert r.status_code == 429 and "this client (127.0.0.1) has 2 event streams open" in r.json()["detail"]
            assert "ARGAND_MAX_STREAMS_PER_CLIENT" in r.json()["detail"] and r.headers["retry-after"] == "5"
            r = clients["127.0.0.3"].get(path)
            assert r.status_code == 429 and "the farm serves 3 event streams" in r.json()["detail"]
            assert clients["127.0.0.1"].get(f"/api/jobs/{job_id}").status_code == 200  # the rest still answers
        # Closed streams give their slots back.
        deadline = time.monotonic() + 10
        while True:
            with clients["127.0.0.3"].stream("GET", path) as r:
                if r.status_code == 200 or time.monotonic() > deadline:
                    break
            time.sleep(0.1)
        assert r.status_code == 200
    finally:
        for c in clients.values():
            c.close()
        server.should_exit = True
        thread.join(10)


def test_a_data_folder_below_its_free_space_floor_refuses_new_jobs(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    server, thread, url = _serve(settings.model_copy(update={"min_free_bytes": 1 << 60}))
    try:
        r = httpx.post(url + "/api/jobs", json=JOB, timeout=30)
        assert r.status_code == 507, r.text
        assert "MiB free, below the floor of" in r.json()["detail"] and "ARGAND_MIN_FREE_BYTES" in r.json()["detail"]
        assert httpx.get(url + "/api/jobs", timeout=30).json()["total"] == 0
        assert httpx.get(url + "/api/meta", timeout=30).json()["limits"]["min_free_bytes"] == 1 << 60
    finally:
        server.should_exit = True
        thread.join(10)


def test_a_priority_change_resends_at_a_bounded_rate(farm_parts):  # noqa: F811
    """30 PATCHes used to put 7,529 messages in Redis. Now the same priority
    sends nothing, and a job's queued tiles are sent again at most once per
    PRIORITY_RESEND_S: at once for the first change, once more (at the last
    priority asked) for all the changes that follow within that time."""
    from argand.farm import control, outbox
    from argand.farm.models import Outbox

    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    sent = queued_messages(redis_server)
    assert sent >= 1
    control.set_priority(settings, job_id, 5)  # the priority it has: nothing
    assert queued_messages(redis_server) == sent
    control.set_priority(settings, job_id, 7)  # the first change: sent at once
    once = queued_messages(redis_server)
    assert once == 2 * sent
    for p in [1, 2, 3, 4, 6, 8, 9] * 4:
        control.set_priority(settings, job_id, p)
    assert queued_messages(redis_server) == once  # the next re-send waits for its time
    with session_scope(settings.sqlalchemy_url) as s:
        waiting = s.query(Outbox).filter(Outbox.job_id == job_id).all()
        assert len(waiting) == sent and {m.priority for m in waiting} == {9}
        assert all(m.not_before >= time.time() + outbox.PRIORITY_RESEND_S - 2 for m in waiting)
        s.get(Job, job_id).priority_resent = time.time() - 1  # its time has come
        for m in waiting:
            m.not_before = time.time() - 1
    assert outbox.drain(settings) == sent
    assert queued_messages(redis_server) == once + sent  # 3 sets in all, not 30
    # A stopped job's waiting messages are dropped, not sent.
    control.set_priority(settings, job_id, 2)
    control.set_job_status(settings, job_id, "cancel")
    with session_scope(settings.sqlalchemy_url) as s:
        for m in s.query(Outbox).filter(Outbox.job_id == job_id):
            m.not_before = 0
    assert outbox.drain(settings) == 0
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.query(Outbox).count() == 0


def test_messages_wait_in_the_outbox_while_redis_is_down(farm_parts):  # noqa: F811
    """In process: with Redis stopped, a submission, a tile given back and a
    resume each store their messages (no error reaches the caller); the
    first drain after Redis is back sends each exactly once."""
    from argand.farm import control, outbox
    from argand.serve.embedded_redis import EmbeddedRedis

    settings, redis_server = farm_parts
    redis_server.stop()
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    n, oldest = outbox.pending(settings)
    assert n >= 1 and oldest is not None
    with pytest.raises(Exception):
        outbox.drain(settings)
    assert outbox.pending(settings)[0] == n  # a failed send lets go of the rows at once
    why, claimed = tile_work.claim(settings, job_id, 0, [0, 1], "w-test", None)
    assert why is None
    tile_work.release(settings, job_id, 0, "w-test", claimed, resend=True, reason="RuntimeError: test")
    assert outbox.pending(settings)[0] == n + 1
    control.set_job_status(settings, job_id, "pause")
    assert control.set_job_status(settings, job_id, "resume") == "running"
    after_resume = outbox.pending(settings)[0]
    assert after_resume > n + 1
    restarted = EmbeddedRedis(redis_server.socket_path).start()
    try:
        assert outbox.drain(settings) == after_resume
        assert queued_messages(restarted) == after_resume and outbox.pending(settings) == (0, None)
        for frame in (0, 1):
            assert tile_work.run_tiles(settings, job_id, frame, [0, 1, 2, 3], "w-test") == "rendered"
        with session_scope(settings.sqlalchemy_url) as s:
            assert s.get(Job, job_id).status == "done"
            assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
    finally:
        restarted.stop()


def test_the_soft_time_limit_gives_back_the_tiles_a_run_did_not_start(farm_parts, monkeypatch):  # noqa: F811
    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"tile_soft_time_limit_s": 1, "tile_hard_time_limit_s": 100})
    job_id = submit(settings, "plucker", [0.0], 64, 64, 16)
    real = tile_work.render_tile_bands_into

    def slow(*args, **kwargs):
        time.sleep(0.4)
        return real(*args, **kwargs)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", slow)
    sent = queued_messages(redis_server)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == tile_work.SOFT_LIMIT
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        done = [i for i, t in sorted(tiles.items()) if t.status == "done"]
        assert 1 <= len(done) <= 4 and done == list(range(len(done)))  # the first tile always renders
        rest = [t for t in tiles.values() if t.status != "done"]
        assert all(t.status == "queued" and t.attempts == 0 and t.worker is None for t in rest)
        assert rest[0].error.startswith("TimeLimitExceeded: the run of 16 tiles passed the soft time limit of 1 s")
    assert queued_messages(redis_server) == sent + 1  # the rest, sent again
    monkeypatch.setattr(tile_work, "render_tile_bands_into", real)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}


def test_the_watchdog_writes_why_then_stops_a_run_past_its_hard_limit(farm_parts):  # noqa: F811
    """The watchdog's decision and its note, with the kill handed to the test
    (test_farm_faults.py has the real SIGKILL of a real worker)."""
    from argand.worker import watchdog

    settings, _ = farm_parts
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    why, claimed = tile_work.claim(settings, job_id, 0, [0, 1, 2, 3], "w-slow", None)
    assert why is None
    killed = threading.Event()
    dog = watchdog.Watchdog(settings, kill=killed.set)
    dog.start()
    try:
        tile_work.ACTIVITY.update(run=(job_id, 0, claimed, "w-slow"), hard_at=time.monotonic() + 1.0, tile=f"{job_id}/0/2")
        assert not killed.wait(0.6)  # before the deadline: nothing
        assert killed.wait(5)
    finally:
        tile_work.ACTIVITY.update(run=None, hard_at=None, tile=None)
        dog.stop.set()
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = s.query(Tile).filter(Tile.job_id == job_id).all()
        assert {t.status for t in tiles} == {"running"} and {t.worker for t in tiles} == {"w-slow"}  # not given away
        assert {t.error for t in tiles} == {f"TimeLimitExceeded: the run of 4 tiles passed the hard time limit of "
                                           f"{settings.tile_hard_time_limit_s} s (tile {job_id}/0/2); its worker was stopped"}


def test_a_planning_failure_says_what_and_where(api):
    c, _, _ = api
    r = c.post("/api/jobs", json={**JOB, "sigma": 0.5, "deltas": [0.1, 0.2, 3.0, 0.2]})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "band rule" in detail and "(σ = 0.5, δ = 3)" in detail and "1 of the 4 frames" in detail, detail
    r = c.post("/api/jobs", json={**JOB, "sigma": 3.5})
    assert "(σ = 3.5, δ = 0)" in r.json()["detail"], r.text
    scene = next(p["scene"] for p in c.get("/api/presets").json() if p["name"] == "plucker")
    bad = _changed(scene, {"camera": {"position": [1e308, 1e308, 1.0]}})
    r = c.post("/api/jobs", json={**JOB, "scene": bad, "sigma": 0.5, "deltas": [0.2, 0.1]})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail.startswith("the scene cannot be rendered: ") and detail.endswith("[at frame 1 (σ = 0.5, δ = 0.1)]"), detail
    r = c.post("/api/jobs", json={**JOB, "scene": bad, "sigma": 0.5, "deltas": [0.2]})
    assert r.json()["detail"].endswith("[at σ = 0.5, δ = 0.2]"), r.text


def test_reads_need_the_token_when_asked(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    from pydantic import SecretStr

    settings = settings.model_copy(update={"api_token": SecretStr("s3cret-token"), "token_for_reads": True})
    server, thread, url = _serve(settings)
    try:
        for path in ("/api/jobs", "/api/workers", "/metrics", "/api/meta"):
            r = httpx.get(url + path, timeout=30)
            assert r.status_code == 401 and r.headers["www-authenticate"] == "Bearer", path
            assert httpx.get(url + path, headers={"Authorization": "Bearer s3cret-token"}, timeout=30).status_code == 200
        for path in ("/readyz", "/openapi.json", "/"):
            assert httpx.get(url + path, timeout=30).status_code == 200, path
        ops = httpx.get(url + "/openapi.json", timeout=30).json()["paths"]
        assert ops["/api/jobs"]["get"]["security"] == [{"bearer": []}]
    finally:
        server.should_exit = True
        thread.join(10)


def test_the_reaper_sends_what_an_api_left_in_the_outbox(farm_parts):  # noqa: F811
    """An API killed between its commit and its drainer's send leaves the
    job's messages as rows: the reaper's next round sends them."""
    from argand.farm.submission import JobSpec, create_job
    from argand.scene import load_scene

    settings, redis_server = farm_parts
    job_id = create_job(settings, JobSpec("plucker", load_scene("plucker"), frame_grid([0.0], [0.0, 0.1]), 32, 32, 16),
                        send=False)
    assert queued_messages(redis_server) == 0
    Reaper(settings).round()
    assert queued_messages(redis_server) >= 2
    for frame in (0, 1):
        assert tile_work.run_tiles(settings, job_id, frame, [0, 1, 2, 3], "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
