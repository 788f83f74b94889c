"""A farm that heals itself, with real processes (`argand serve`, its Celery
workers and embedded Redis, a SQLite file): a whole-farm kill -9 then a
restart on the same folder, a broker that loses every message mid-job, a
SIGTERM to the supervisor, and what a worker's environment holds. In
process (a real Redis and SQLite, the reaper's own functions called): lost
messages sent again by a resume, stale messages dropped."""

from __future__ import annotations

import os
import re
import signal
import time
from pathlib import Path

import httpx
import redis as redis_py

from argand.farm import control
from argand.farm.queue import broker_client
from argand.farm.reaper import Reaper, still_idle, take_census
from tests.farm.test_farm import Farm, check_frames_against_local
from tests.farm.test_faults import _db, _wait
from tests.farm.test_work import farm_parts, queued_messages, submit  # noqa: F401  (the fixture)
from tests.serve.test_supervisor import _alive, _children

TOKEN = "tok-9c2e6b1f70"


def _renders(data: Path, job_id: str) -> list[int]:
    return [r for (r,) in _db(data, "select renders from tiles where job_id = :j", j=job_id)]


def _metric(url: str, name: str) -> float | None:
    text = httpx.get(url + "/metrics", timeout=30).text
    m = re.search(rf"^{name} (\S+)$", text, re.M)
    return None if m is None else float(m.group(1))


def test_a_farm_killed_whole_and_restarted_finishes_within_the_heartbeat_timeout(tmp_path):
    """kill -9 of `argand serve`, its workers and Redis at once (a power cut)
    while tiles run, then `argand serve` again on the same folder: the tiles
    the dead workers held, and the messages they had prefetched, are given
    back at once (the restarted supervisor holds the folder's lock, so the
    workers of the run before are known dead; and a worker's identity is
    new in every process, so no new worker beats under a dead one's name).
    The job finishes within the heartbeat timeout plus a run's time, not
    after twice the hard time limit (here 2 x 60 s); every tile is counted
    once and the frames equal a local render."""
    # One frame per run and a job of some seconds: a job rendered 8 bands a
    # run at 64x64 can finish between two polls, before any tile is seen running.
    limits = {"ARGAND_TILE_SOFT_TIME_LIMIT_S": "50", "ARGAND_TILE_HARD_TIME_LIMIT_S": "60", "ARGAND_BANDS_PER_RUN": "1"}
    data = tmp_path / "data"
    farm = Farm(data, workers=2, **limits).start()
    try:
        names = {w["name"] for w in farm.get("/api/workers")}
        assert all(re.fullmatch(r"w\d\+[0-9a-f]{8}@.+", n) for n in names), names
        r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": {"start": 0, "stop": "pi/9", "count": 24},
                                    "width": 128, "height": 128, "tile": 16})
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]
        _wait(lambda: _db(data, "select count(*) from tiles where job_id = :j and status = 'running'", j=job_id)[0][0]
              > 0, 120, "tiles running")
        os.killpg(farm.proc.pid, signal.SIGKILL)  # the supervisor, its workers and Redis, at once
        farm.proc.wait()
    finally:
        farm.stop()
    held = _db(data, "select count(*) from tiles where job_id = :j and status = 'running'", j=job_id)[0][0]
    assert held > 0  # the crash left claimed tiles behind
    again = Farm(data, workers=2, **limits)
    start = time.monotonic()
    again.start()
    try:
        assert not {w["name"] for w in again.get("/api/workers") if w["alive"]} & names
        job = again.wait_job(job_id, 120)
        took = time.monotonic() - start
        assert job["status"] == "done", job
        assert took < 60, took  # the start, the heartbeat timeout (3 s) and runs of seconds; not 2 x 60 s
        assert set(_renders(data, job_id)) == {1}
        assert "previous run" in again.log.read_text()
        check_frames_against_local(again, job, "whitney-in-sphere")
    finally:
        again.stop()
    print(f"\nrestart to done: {took:.1f} s ({held} tiles were held by the dead workers)")


def test_a_broker_that_lost_its_messages_is_refilled_from_the_database(tmp_path):
    """FLUSHALL of the farm's Redis mid-job (what a lost AOF tail, a Redis
    replaced without its volume or a failover do): /metrics and /healthz show
    the queued tiles that no message carries, and the reaper's census sends
    them again: the job finishes with no user action, every tile once, the
    frames equal to a local render."""
    data = tmp_path / "data"
    farm = Farm(data, workers=1, ARGAND_QUEUE_CHECK_S="2").start()
    try:
        r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": {"start": 0, "stop": "pi/9", "count": 40},
                                    "width": 64, "height": 64, "tile": 16})
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]

        def tiles(status: str) -> int:
            return _db(data, "select count(*) from tiles where job_id = :j and status = :s", j=job_id, s=status)[0][0]

        _wait(lambda: tiles("done") > 0, 120, "the first tiles")
        assert tiles("queued") > 0  # work left that only messages can bring to a worker
        redis_py.Redis(unix_socket_path=str(data / "redis" / "redis.sock")).flushall()
        unsent = _metric(farm.url, "argand_tiles_unsent")
        health = httpx.get(farm.url + "/healthz", timeout=30).json()["queue"]
        assert unsent is not None and unsent > 0, unsent
        assert health["ok"] and health["unsent_tiles"] > 0 and health["unsent_by_job"][job_id] > 0, health
        job = farm.wait_job(job_id, 240)
        assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"] == 40 * 16, job
        assert set(_renders(data, job_id)) == {1}
        time.sleep(5.5)  # the collector's census is at most 5 s old
        assert _metric(farm.url, "argand_tiles_unsent") == 0
        check_frames_against_local(farm, job, "whitney-in-sphere")
    finally:
        farm.stop()
    print(f"\nlost messages: {unsent:.0f} queued tiles without a message after the FLUSHALL")


def test_sigterm_stops_the_farm_cleanly_and_workers_never_see_the_token(tmp_path):
    """The workers' environment holds the settings they need, not the API
    token; SIGTERM to `argand serve` is Ctrl-C: the API drains, the children
    stop, the exit status is 0."""
    farm = Farm(tmp_path / "data", workers=1, ARGAND_API_TOKEN=TOKEN).start()
    try:
        [worker] = farm.get("/api/workers")
        environ = Path(f"/proc/{worker['pid']}/environ").read_bytes().split(b"\0")
        assert not [v for v in environ if v.startswith(b"ARGAND_API_TOKEN") or TOKEN.encode() in v]
        assert any(v.startswith(b"ARGAND_DATA_DIR=") for v in environ)
        children = _children(farm.proc.pid)
        assert any(" worker " in c for c in children.values()) and any("redis-server" in c for c in children.values())
        farm.proc.send_signal(signal.SIGTERM)
        assert farm.proc.wait(60) == 0, farm.log.read_text()[-2000:]
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and any(_alive(p) for p in children):
            time.sleep(0.2)
        assert not [c for p, c in children.items() if _alive(p)]
    finally:
        farm.stop()


def test_a_resume_of_an_active_job_sends_again_what_the_broker_lost(farm_parts):  # noqa: F811
    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0, 0.1, 0.2], 32, 32, 16)
    sent = queued_messages(redis_server)
    assert sent >= 1
    client = broker_client(settings)
    client.flushall()
    assert take_census(settings, client).unsent == {job_id: {(f, t) for f in range(3) for t in range(4)}}
    assert control.set_job_status(settings, job_id, "resume") == "queued"
    assert queued_messages(redis_server) == sent and take_census(settings, client).unsent == {}
    control.set_job_status(settings, job_id, "resume")  # nothing is lost: nothing sent
    assert queued_messages(redis_server) == sent


def _census(reaper: Reaper, client) -> int:
    """The reaper's next census, once it is due (bounded wait)."""
    _wait(reaper.census_due, 10, "the next census")
    return reaper.reconcile(client)


def test_the_census_drops_stale_messages_and_sends_what_two_censuses_found_lost(farm_parts):  # noqa: F811
    """Priority changes leave the older priority's copies in Redis, a stopped
    job leaves its messages: the reaper's census drops them. A tile without a
    message in two censuses in a row is sent again (once)."""
    from argand.farm import outbox
    from argand.farm.database import session_scope
    from argand.farm.models import Job

    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"queue_check_s": 0.01})
    client = broker_client(settings)
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    sent = queued_messages(redis_server)
    control.set_priority(settings, job_id, 7)
    with session_scope(settings.sqlalchemy_url) as s:
        s.get(Job, job_id).priority_resent = time.time() - 60
    control.set_priority(settings, job_id, 9)
    outbox.drain(settings)
    assert queued_messages(redis_server) == 3 * sent
    census = take_census(settings, client)
    assert census.unsent == {} and len(census.stale) == 2 * sent
    reaper = Reaper(settings)
    assert _census(reaper, client) == 0
    assert queued_messages(redis_server) == sent  # the copies at priority 9 alone
    assert take_census(settings, client).stale == []
    # Lost: seen once, then sent again at the second census, and only then.
    client.flushall()
    assert _census(reaper, client) == 0 and queued_messages(redis_server) == 0
    assert _census(reaper, client) == 2 * 4 and queued_messages(redis_server) == sent
    assert _census(reaper, client) == 0 and queued_messages(redis_server) == sent
    # A canceled job's messages can claim nothing: dropped.
    control.set_job_status(settings, job_id, "cancel")
    _census(reaper, client)
    assert queued_messages(redis_server) == 0


def test_a_message_that_looked_idle_is_kept_once_its_tiles_are_queued_again(farm_parts):  # noqa: F811
    """The census reads the tiles before the broker: a tile given back in
    between (queued again, with a new message) would make that message look
    idle. It is read again before anything is dropped."""
    from sqlalchemy import update

    from argand.farm import tile_work
    from argand.farm.database import session_scope
    from argand.farm.models import Tile

    settings, redis_server = farm_parts
    client = broker_client(settings)
    job_id = submit(settings, "plucker", [0.0], 32, 32, 16)
    sent = queued_messages(redis_server)
    why, claimed = tile_work.claim(settings, job_id, 0, [0, 1, 2, 3], "w-elsewhere", None)
    assert why is None and claimed == [0, 1, 2, 3]
    census = take_census(settings, client)
    assert len(census.idle) == sent and census.unsent == {}  # running: the waiting copy claims nothing
    with session_scope(settings.sqlalchemy_url) as s:  # given back meanwhile
        s.execute(update(Tile).where(Tile.job_id == job_id).values(status="queued", worker=None))
    assert still_idle(settings, census.idle) == []
    assert Reaper(settings.model_copy(update={"queue_check_s": 0.01})).reconcile(client) == 0
    assert queued_messages(redis_server) == sent  # kept


def test_healthz_shows_the_lost_work_and_shares_one_census_between_requests(farm_parts, monkeypatch):  # noqa: F811
    """/healthz is open: requests within CENSUS_REUSE_S of a census share it
    (a flood costs one census per that time), and the next one sees the repair."""
    from argand.api.routes import service
    from tests.api.test_api import _served

    settings, redis_server = farm_parts
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    broker_client(settings).flushall()
    monkeypatch.setattr(service, "CENSUS_REUSE_S", 3600.0)
    with _served(farm_parts) as (c, _, _app):
        first = c.get("/healthz").json()["queue"]
        assert first["ok"] and first["unsent_tiles"] == 8 and first["unsent_by_job"] == {job_id: 8}
        control.set_job_status(settings, job_id, "resume")  # sends them again
        assert queued_messages(redis_server) >= 1
        assert all(c.get("/healthz").json()["queue"] == first for _ in range(50))  # the same census
        monkeypatch.setattr(service, "CENSUS_REUSE_S", 0.0)
        assert c.get("/healthz").json()["queue"]["unsent_tiles"] == 0
