"""Faults with real processes: Redis down at submission, a kill
-9 of the API alone, a run past its hard time limit, a store that refuses
writes. Each asserts that the job ends (done, or failed with its reason), no
tile is lost and none is rendered twice, and the frames equal an undisturbed
local render."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from sqlalchemy import create_engine, text

from tests.farm.test_farm import ARGAND, Farm, check_frames_against_local, free_port, tile_renders
from argand.frames.frame_set import frame_grid
from argand.serve.embedded_redis import EmbeddedRedis

FAST = {"ARGAND_HEARTBEAT_INTERVAL_S": "0.5", "ARGAND_HEARTBEAT_TIMEOUT_S": "3"}


def _db(data: Path, sql: str, **params) -> list:
    eng = create_engine(f"sqlite:///{data / 'argand.db'}")
    try:
        with eng.connect() as c:
            return c.execute(text(sql), params).all()
    finally:
        eng.dispose()


def _wait(cond, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}")


def test_a_job_submitted_while_redis_is_down_runs_once_it_is_back(tmp_path):
    """The farm's Redis stopped: POST /api/jobs still answers 201 at once
    (the job and its messages are one transaction in the database; the
    messages wait in the outbox); Redis back, the job finishes, every tile
    rendered once, the frames equal to a local render."""
    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    farm = Farm(tmp_path / "data", workers=2)
    farm.env["ARGAND_REDIS_URL"] = redis_server.url
    farm.start()
    try:
        redis_server.stop()
        start = time.monotonic()
        r = farm.post("/api/jobs", {"scene": "steiner", "deltas": [0, "pi/18", "pi/9"], "width": 48, "height": 48,
                                    "tile": 16})
        answered = time.monotonic() - start
        assert r.status_code == 201, r.text
        assert answered < 5, answered  # it did not wait on the broker
        job_id = r.json()["id"]
        health = httpx.get(farm.url + "/healthz", timeout=30)
        assert health.status_code == 503
        checks = {c["name"]: c for c in health.json()["checks"]}
        assert not checks["redis"]["ok"] and checks["outbox"]["pending"] >= 1
        time.sleep(3)  # the drainers try, and keep the rows
        assert farm.get(f"/api/jobs/{job_id}")["status"] == "queued"
        assert _db(farm.data, "select count(*) from outbox where job_id = :j", j=job_id)[0][0] >= 1
        redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()  # the same files
        job = farm.wait_job(job_id, 180)
        assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"] == 3 * 9
        assert sorted(set(tile_renders(farm, job_id))) == [1]
        assert _db(farm.data, "select count(*) from outbox")[0][0] == 0
        check_frames_against_local(farm, job, "steiner")
    finally:
        farm.stop()
        redis_server.stop()


def _start(args: list[str], env: dict, log: Path) -> subprocess.Popen:
    with open(log, "a") as out:
        return subprocess.Popen([ARGAND, *args], env=env, stdout=out, stderr=subprocess.STDOUT)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def test_a_killed_api_loses_nothing(tmp_path):
    """`argand api` and `argand worker` as separate processes (as deployed):
    kill -9 of the API right after it accepted a job; the workers and Redis
    keep going and finish every job (the reaper sends what the API's drainer
    had not); a restarted API serves the same jobs, done, every tile once."""
    data = tmp_path / "data"
    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    env = dict(os.environ, ARGAND_REDIS_URL=redis_server.url, ARGAND_DATA_DIR=str(data), **FAST)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    procs = []
    try:
        api = _start(["api", "--port", str(port)], env, tmp_path / "api.log")
        procs.append(api)
        _wait(lambda: _ready(url), 60, "the API")
        procs.append(_start(["worker", "--name", "w1@test"], env, tmp_path / "w1.log"))
        procs.append(_start(["worker", "--name", "w2@test"], env, tmp_path / "w2.log"))
        first = httpx.post(url + "/api/jobs", json={"scene": "whitney-in-sphere", "width": 96, "height": 96, "tile": 16,
                                                     "deltas": {"start": 0, "stop": "pi/9", "count": 12}}, timeout=60)
        second = httpx.post(url + "/api/jobs", json={"scene": "plucker", "deltas": [0, 0.1], "width": 32, "height": 32,
                                                      "tile": 16}, timeout=60)
        assert first.status_code == second.status_code == 201
        api.kill()  # kill -9, the API alone
        api.wait()
        ids = [first.json()["id"], second.json()["id"]]
        _wait(lambda: {s for (s,) in _db(data, "select status from jobs")} == {"done"}, 240, "both jobs to finish")
        api = _start(["api", "--port", str(port)], env, tmp_path / "api.log")
        procs.append(api)
        _wait(lambda: _ready(url), 60, "the restarted API")
        for job_id, tiles in zip(ids, (12 * 36, 2 * 4)):
            job = httpx.get(url + f"/api/jobs/{job_id}", timeout=30).json()
            assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"] == tiles
            renders = [r for (r,) in _db(data, "select renders from tiles where job_id = :j", j=job_id)]
            assert len(renders) == tiles and set(renders) == {1}
        assert httpx.get(url + "/api/jobs", timeout=30).json()["total"] == 2
    finally:
        for p in reversed(procs):
            _stop(p)
        redis_server.stop()


def _ready(url: str) -> bool:
    try:
        return httpx.get(url + "/readyz", timeout=2).status_code == 200
    except httpx.HTTPError:
        return False


def test_a_run_past_its_hard_time_limit_is_stopped_and_fails_with_the_reason(tmp_path):
    """One tile that takes far longer than the hard limit (a 1024x1024
    whitney-in-sphere frame at 16 samples per pixel as one tile: about 35 s
    here, 2 s at one sample since the batched kernel; the limits are 1 s and 2 s): the watchdog stops its worker at the hard limit each time, the
    reaper gives the tile back only once the worker's heartbeats stopped,
    and after the attempts the job fails saying why; `argand serve` starts
    workers in the killed ones' place and the next job finishes."""
    farm = Farm(tmp_path / "data", workers=2, ARGAND_TILE_SOFT_TIME_LIMIT_S="1", ARGAND_TILE_HARD_TIME_LIMIT_S="2",
                ARGAND_MAX_TILE_ATTEMPTS="2").start()
    try:
        r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": [0], "width": 1024, "height": 1024,
                                    "tile": 1024, "samples": 16})
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]
        start = time.monotonic()
        job = farm.wait_job(job_id, 120)
        took = time.monotonic() - start
        assert job["status"] == "failed", job
        assert job["error"].startswith("tile 0/0 failed 2 times (TimeLimitExceeded: ") and "hard time limit of 2 s" in job["error"], job["error"]
        assert took < 60, took  # not the 35 s x 2 a render would take, nor Redis's redelivery
        assert tile_renders(farm, job_id) == [0]
        [(status, attempts)] = _db(farm.data, "select status, attempts from tiles where job_id = :j", j=job_id)
        assert status == "failed" and attempts == 2
        log = farm.log.read_text()
        assert log.count("hard time limit of 2 s") >= 2 and "exited with -9" in log, log[-2000:]
        r = farm.post("/api/jobs", {"scene": "plucker", "deltas": [0], "width": 32, "height": 32, "tile": 16})
        assert farm.wait_job(r.json()["id"], 120)["status"] == "done"
    finally:
        farm.stop()


_FULL_STORE_RUN = """
import resource, signal, sys
from argand.farm import tile_work
from argand.farm.settings import Settings
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG instead
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), int(sys.argv[2])))
settings = Settings(data_dir=sys.argv[1], redis_url=sys.argv[3], exr_on_request=False, files_on_request=False)
try:
    print(tile_work.run_tiles(settings, sys.argv[4], 0, list(range(int(sys.argv[5]))), "w-limited"))
except OSError as exc:
    print("raised", exc.errno, exc)
"""


def test_a_full_store_fails_the_job_cleanly_and_a_retry_finishes_it(tmp_path):
    """A worker process whose files stop at 1 MiB (RLIMIT_FSIZE: what a
    full disk does to a writer, without filling this machine's): its tile
    chunks or the frame's EXR cannot be written; the job fails at once
    saying that the store cannot be written, no tile stays running, no
    partial or temporary file is left; with the limit gone, a retry
    finishes the frame, every tile rendered once, equal to a local render."""
    from argand.farm.database import upgrade
    from argand.farm.settings import Settings
    from argand.farm.submission import JobSpec, create_job
    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import EXR_CHANNELS, exr_pixels, read_exr
    from argand.scene import load_scene

    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    try:
        settings = Settings(data_dir=tmp_path / "data", redis_url=redis_server.url, exr_on_request=False, files_on_request=False)
        upgrade(settings.sqlalchemy_url)
        job_id = create_job(settings, JobSpec("steiner", load_scene("steiner"), frame_grid([0.0], [0.3]), 512, 512, 64))
        from argand.farm.database import engine_for

        with engine_for(settings.sqlalchemy_url).connect() as c:  # the database's WAL starts empty, far below the limit
            c.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
        run = subprocess.run([sys.executable, "-c", _FULL_STORE_RUN, str(settings.data_path), str(1 << 20),
                              redis_server.url, job_id, "64"], capture_output=True, text=True, timeout=300)
        assert run.stdout.startswith("raised"), (run.stdout, run.stderr[-2000:])
        [(status, error)] = _db(settings.data_path, "select status, error from jobs where id = :j", j=job_id)
        assert status == "failed" and error.startswith("the store cannot be written (") and "retry the job" in error, error
        tiles = _db(settings.data_path, "select status, attempts, renders from tiles where job_id = :j", j=job_id)
        assert {t[0] for t in tiles} <= {"queued", "done"} and "queued" in {t[0] for t in tiles}
        assert all((status, renders) in (("queued", 0), ("done", 1)) for status, _, renders in tiles)
        assert {t[1] for t in tiles if t[0] == "queued"} == {0}  # the store's fault: no attempt counted
        folder = settings.store_path / "jobs" / job_id
        assert not [p.name for p in folder.rglob("*") if p.is_file() and (".tmp" in p.name or p.suffix == ".exr")]
        from argand.farm import control, tile_work

        assert control.set_job_status(settings, job_id, "retry") == "running"
        assert tile_work.run_tiles(settings, job_id, 0, list(range(64)), "w-free") == "rendered"
        [(status,)] = _db(settings.data_path, "select status from jobs where id = :j", j=job_id)
        assert status == "done"
        assert {r for (r,) in _db(settings.data_path, "select renders from tiles where job_id = :j", j=job_id)} == {1}
        names, px = read_exr(folder / "frame_0000.exr")
        want = exr_pixels(render_frame(load_scene("steiner"), FrameParams(delta=0.3, width=512, height=512), tile=64,
                                       workers=1))
        assert (px[..., [names.index(n) for n in EXR_CHANNELS]].view("uint32") == want.view("uint32")).all()
    finally:
        redis_server.stop()


def _make_unwritable(folder: Path) -> str:
    """``folder`` refuses writes: a read-only tmpfs mounted on it as root
    (root ignores permissions), else its permissions. Returns how."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        folder.chmod(0o555)
        return "chmod"
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(folder)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"running as root without the right to mount (permissions do not bind root): {r.stderr.strip()}")
    return "mount"


def _make_writable(folder: Path, how: str) -> None:
    if how == "chmod":
        folder.chmod(0o755)
    else:
        subprocess.run(["umount", str(folder)], check=True)


def test_an_unwritable_store_fails_the_job_cleanly_and_a_retry_finishes_it(tmp_path):
    """The job's folder in the store refuses writes (EACCES or EROFS): the
    run fails the job at once with the reason, nothing is left running or
    half-written; writable again, a retry finishes it, every tile once, the
    frame equal to a local render."""
    from argand.farm import control, tile_work
    from argand.farm.database import upgrade
    from argand.farm.settings import Settings
    from argand.farm.submission import JobSpec, create_job
    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import EXR_CHANNELS, exr_pixels, read_exr
    from argand.scene import load_scene

    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    how = None
    try:
        settings = Settings(data_dir=tmp_path / "data", redis_url=redis_server.url, exr_on_request=False, files_on_request=False)
        upgrade(settings.sqlalchemy_url)
        job_id = create_job(settings, JobSpec("steiner", load_scene("steiner"), frame_grid([0.0], [0.2]), 64, 64, 16))
        folder = settings.store_path / "jobs" / job_id
        how = _make_unwritable(folder)
        with pytest.raises(OSError):
            tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test")
        [(status, error)] = _db(settings.data_path, "select status, error from jobs where id = :j", j=job_id)
        assert status == "failed" and error.startswith("the store cannot be written (") and "retry the job" in error, error
        tiles = _db(settings.data_path, "select status, attempts from tiles where job_id = :j", j=job_id)
        assert set(tiles) == {("queued", 0)}
        assert not list(folder.rglob("*"))
        _make_writable(folder, how)
        how = None
        assert control.set_job_status(settings, job_id, "retry") == "running"
        assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
        assert {r for (r,) in _db(settings.data_path, "select renders from tiles where job_id = :j", j=job_id)} == {1}
        names, px = read_exr(folder / "frame_0000.exr")
        want = exr_pixels(render_frame(load_scene("steiner"), FrameParams(delta=0.2, width=64, height=64), tile=16, workers=1))
        assert (px[..., [names.index(n) for n in EXR_CHANNELS]].view("uint32") == want.view("uint32")).all()
    finally:
        if how is not None:
            _make_writable(settings.store_path / "jobs" / job_id, how)
        redis_server.stop()
