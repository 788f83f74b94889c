"""The farm's work model in pieces: how tiles become messages, the tile
store's files, and the upgrade of a database made by an earlier version.
(The whole farm, with real processes, is in test_farm.py.)"""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest
from sqlalchemy import create_engine, inspect, text

from argand.worker.farm import batch_runs, plan_runs, preview_order, tile_rects
from argand.worker.store import FrameStore, pack_arrays, unpack_arrays


def pixels(rects, tiles):
    return sum((rects[t][2] - rects[t][0]) * (rects[t][3] - rects[t][1]) for t in tiles)


@pytest.mark.parametrize("width,height,tile,frames,workers,batch", [
    (512, 512, 64, 36, 2, 512 * 512),  # the benchmark's job: whole frames
    (512, 512, 64, 36, 1, 512 * 512),  # one worker
    (96, 80, 16, 1, 2, 512 * 512),     # one small frame: split so both workers get work
    (1000, 700, 128, 3, 3, 100_000),   # ragged edges, batch smaller than a frame
    (40, 30, 64, 5, 4, 10),            # a tile larger than the batch: one tile per run
])
def test_runs_cover_every_tile_once_in_preview_order(width, height, tile, frames, workers, batch):
    rects = tile_rects(width, height, tile)
    by_frame = {f: list(range(len(rects))) for f in range(frames)}
    runs = plan_runs(by_frame, frames, rects, batch, workers)
    sent = [(f, t) for f, run in runs for t in run]
    assert sorted(sent) == sorted((f, t) for f in range(frames) for t in range(len(rects)))
    assert len(sent) == len(set(sent))
    for f, run in runs:
        assert run and (len(run) == 1 or pixels(rects, run[:-1]) < batch)  # a run stops once it reaches the batch
    first_seen = list(dict.fromkeys(f for f, _ in runs))
    assert first_seen == preview_order(frames)
    if frames == 1:  # a one-frame job is still shared: every worker gets four runs or more
        assert len(runs) >= 4 * workers


def test_whole_frames_travel_as_one_message_when_there_are_enough_of_them():
    rects = tile_rects(512, 512, 64)
    by_frame = {f: list(range(64)) for f in range(36)}
    for workers in (1, 2):
        assert [len(r) for _, r in plan_runs(by_frame, 36, rects, 512 * 512, workers)] == [64] * 36
    # A smaller batch cuts frames; a job too small to feed every worker four times is cut finer.
    assert [len(r) for _, r in plan_runs(by_frame, 36, rects, 128 * 128, 2)] == [4] * 36 * 16
    assert [len(r) for _, r in plan_runs({0: list(range(64))}, 1, rects, 512 * 512, 2)] == [8] * 8


def test_batch_runs_keeps_tile_order():
    rects = tile_rects(100, 10, 10)
    assert batch_runs(list(range(10)), rects, 250) == [[0, 1, 2], [3, 4, 5], [6, 7, 8], [9]]
    assert batch_runs([], rects, 250) == []


def test_tile_files_round_trip_exactly(tmp_path):
    rng = np.random.default_rng(7)
    px = rng.standard_normal((16, 24, 10)).astype(np.float32)
    px[0, 0, 4] = np.inf
    px[1, 1, 5] = np.nan
    arrays = {"px": px, "meta": np.array([3, 99], np.int64), "flags": np.arange(5, dtype=np.uint8)}
    back = unpack_arrays(pack_arrays(arrays))
    assert list(back) == list(arrays)
    for k in arrays:
        assert back[k].dtype == arrays[k].dtype and back[k].shape == arrays[k].shape
        assert np.array_equal(back[k], arrays[k], equal_nan=True)
    with pytest.raises(ValueError, match="bad magic"):
        unpack_arrays(b"PK\x03\x04" + bytes(20))

    store = FrameStore(str(tmp_path / "store"))
    tiles = {3: {"px": px, "meta": np.array([1, 2], np.int64)}, 4: {"px": px[::-1].copy(), "meta": np.array([0, 5], np.int64)}}
    store.write_chunk("job", 2, "00003-abc", tiles)
    got = store.read_chunk("job", 2, "00003-abc")
    assert set(got) == {3, 4}
    assert np.array_equal(got[4]["px"], px[::-1], equal_nan=True) and list(got[3]["meta"]) == [1, 2]
    # Atomic: no temporary file is left, and the frame's tiles go away with it.
    assert [p.name for p in (tmp_path / "store/jobs/job/tiles/0002").iterdir()] == ["00003-abc.chunk"]
    store.remove_tiles("job", 2)
    assert not (tmp_path / "store/jobs/job/tiles/0002").exists()
    store.write_chunk("job", 2, "again", tiles)  # the folder comes back when needed
    assert set(store.read_chunk("job", 2, "again")) == {3, 4}


OLD_SCHEMA = """
CREATE TABLE jobs (id VARCHAR(32) NOT NULL PRIMARY KEY, status VARCHAR(16) NOT NULL, scene_name VARCHAR(200) NOT NULL,
  scene JSON NOT NULL, sigma FLOAT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL, tile INTEGER NOT NULL,
  method VARCHAR(16) NOT NULL, priority INTEGER NOT NULL, created FLOAT NOT NULL, started FLOAT, finished FLOAT, error TEXT);
CREATE TABLE workers (name VARCHAR(200) NOT NULL PRIMARY KEY, host VARCHAR(200) NOT NULL, pid INTEGER NOT NULL,
  heartbeat FLOAT NOT NULL, current_tile VARCHAR(200), tiles_done INTEGER NOT NULL);
CREATE TABLE frames (id INTEGER NOT NULL PRIMARY KEY, job_id VARCHAR(32) NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  "index" INTEGER NOT NULL, sigma FLOAT NOT NULL, delta FLOAT NOT NULL, status VARCHAR(16) NOT NULL,
  tiles_total INTEGER NOT NULL, figures JSON, assembler VARCHAR(200), assembling_since FLOAT);
CREATE TABLE tiles (id INTEGER NOT NULL PRIMARY KEY, job_id VARCHAR(32) NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  frame_index INTEGER NOT NULL, tile_index INTEGER NOT NULL, status VARCHAR(16) NOT NULL, worker VARCHAR(200),
  started FLOAT, attempts INTEGER NOT NULL, renders INTEGER NOT NULL, seconds FLOAT);
INSERT INTO jobs VALUES ('old', 'running', 'bicube', '{}', 0, 32, 32, 16, 'auto', 5, 1.0, 2.0, NULL, NULL);
INSERT INTO frames VALUES (1, 'old', 0, 0, 0, 'done', 4, NULL, NULL, NULL), (2, 'old', 1, 0, 0.1, 'rendering', 4, NULL, NULL, NULL);
INSERT INTO tiles VALUES (1, 'old', 0, 0, 'done', NULL, NULL, 1, 1, 0.1), (2, 'old', 0, 1, 'done', NULL, NULL, 1, 1, 0.1),
  (3, 'old', 0, 2, 'done', NULL, NULL, 1, 1, 0.1), (4, 'old', 0, 3, 'done', NULL, NULL, 1, 1, 0.1),
  (5, 'old', 1, 0, 'done', NULL, NULL, 1, 1, 0.1), (6, 'old', 1, 1, 'queued', NULL, NULL, 0, 0, NULL),
  (7, 'old', 1, 2, 'running', 'w', 3.0, 1, 0, NULL), (8, 'old', 1, 3, 'done', NULL, NULL, 1, 1, 0.1);
"""


def test_a_database_from_an_earlier_version_is_brought_up_to_date(tmp_path):
    from argand.api.db import Frame, Job, engine_for, job_progress, migrate, session_scope

    path = tmp_path / "old.db"
    with sqlite3.connect(path) as conn:
        conn.executescript(OLD_SCHEMA)
    url = f"sqlite:///{path}"
    eng = engine_for(url)  # migrates on first use
    cols = {c["name"] for c in inspect(eng).get_columns("frames")}
    assert {"tiles_done", "finished"} <= cols
    assert "chunk" in {c["name"] for c in inspect(eng).get_columns("tiles")}
    assert "ix_tiles_key" in {i["name"] for i in inspect(eng).get_indexes("tiles")}
    with session_scope(url) as s:
        job = s.get(Job, "old")
        assert [f.tiles_done for f in job.frames] == [4, 2]  # what the old version had finished, counted
        assert job_progress(s, job) == (6, 8)
        assert s.get(Frame, 2).status == "rendering"
    assert migrate(eng) == []  # a second time: nothing to do
    with create_engine(url).connect() as c:  # the old rows are untouched
        assert c.execute(text("select count(*) from tiles where status = 'done'")).scalar() == 6


@pytest.fixture
def farm_parts(tmp_path, monkeypatch):
    """A real embedded Redis and a SQLite file, no worker: the tests call the
    task's body directly."""
    from argand.api.settings import Settings
    from argand.worker.broker import EmbeddedRedis

    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    settings = Settings(data_dir=tmp_path / "data", redis_url=redis_server.url, max_tile_attempts=2)
    yield settings, redis_server
    redis_server.stop()


def queued_messages(redis_server) -> int:
    import redis

    client = redis.Redis(unix_socket_path=str(redis_server.socket_path))
    return sum(client.llen(k) for k in client.keys("argand*") if client.type(k) == b"list")


def test_an_error_mid_run_keeps_what_is_done_and_gives_the_rest_back(farm_parts, monkeypatch):
    from argand.api.db import Frame, Job, Tile, session_scope
    from argand.render import frames as frames_module
    from argand.scene import load_scene
    from argand.worker import farm

    settings, redis_server = farm_parts
    job_id = farm.create_job(settings, "steiner", load_scene("steiner").to_dict(), 0.0, [0.0], 64, 64, 16, 5)
    sent = queued_messages(redis_server)
    assert sent >= 1
    real = frames_module.render_tile_into
    calls = []

    def failing(plan, rect, out, ox=0, oy=0):
        calls.append(rect)
        if len(calls) == 6:
            raise RuntimeError("the renderer broke")
        return real(plan, rect, out, ox, oy)

    monkeypatch.setattr(frames_module, "render_tile_into", failing)
    monkeypatch.setattr(farm, "COMMIT_INTERVAL_S", 1e9)  # one commit, at the end or on the error
    with pytest.raises(RuntimeError, match="renderer broke"):
        farm.run_tiles(settings, job_id, 0, list(range(16)), "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert [i for i, t in sorted(tiles.items()) if t.status == "done"] == [0, 1, 2, 3, 4]
        assert all(t.status == "queued" and t.worker is None for i, t in tiles.items() if i >= 5)
        assert tiles[5].attempts == 1 and s.query(Frame).filter(Frame.job_id == job_id).one().tiles_done == 5
        assert s.get(Job, job_id).status == "running"
    assert queued_messages(redis_server) == sent + 1  # the rest was sent again
    # The same tile fails again: with max_tile_attempts=2 the job fails, saying which tile.
    # (this run starts at tile 5: tiles 5..9 render, the sixth call, tile 10, breaks)
    calls.clear()
    with pytest.raises(RuntimeError):
        farm.run_tiles(settings, job_id, 0, list(range(5, 16)), "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert tiles[10].attempts == 2 and tiles[10].status == "failed"
        assert job.status == "failed" and job.error == "tile 0/10 failed 2 times"
    # Nothing more runs for a failed job, and what was rendered is kept.
    monkeypatch.setattr(frames_module, "render_tile_into", real)
    assert farm.run_tiles(settings, job_id, 0, list(range(11, 16)), "w-test") == "failed"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.query(Frame).filter(Frame.job_id == job_id).one().tiles_done == 10
    # Retry: the failed tile gets its attempts back and the rest is sent again; the frame then
    # equals the local render, the ten tiles done before kept as they were.
    sent = queued_messages(redis_server)
    assert farm.set_job_status(settings, job_id, "retry") == "running"
    assert queued_messages(redis_server) > sent
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert tiles[10].status == "queued" and tiles[10].attempts == 0 and s.get(Job, job_id).error is None
        assert [i for i, t in sorted(tiles.items()) if t.status == "done"] == list(range(10))
    assert farm.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
    from argand.render import FrameParams, render_frame
    from argand.render.output import read_exr

    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(load_scene("steiner"), FrameParams(width=64, height=64), tile=16, workers=1)
    assert np.array_equal(px[..., names.index("Z")], local.aovs["Z"]) and np.array_equal(px[..., names.index("A")], local.rgba[..., 3])


def test_a_whole_frame_run_that_commits_on_the_way_assembles_the_same_frame(farm_parts, monkeypatch):
    """A run holding a whole frame that takes longer than the commit
    interval (a large frame) writes chunk files for the progress it reports
    on the way; the frame it assembles still equals the local render, bit
    for bit, and its tile files are gone after."""
    from argand.api.db import Frame, Job, Tile, session_scope
    from argand.render import FrameParams, render_frame
    from argand.render.output import EXR_CHANNELS, exr_pixels, read_exr
    from argand.scene import load_scene
    from argand.worker import farm

    settings, _ = farm_parts
    job_id = farm.create_job(settings, "steiner", load_scene("steiner").to_dict(), 0.0, [0.3], 48, 40, 16, 5)
    chunks = []
    real_complete = farm._complete
    monkeypatch.setattr(farm, "_complete", lambda *a, **k: (chunks.append(len(a[4])), real_complete(*a, **k))[1])
    real_assemble, buffers = farm.assemble_frame, []
    monkeypatch.setattr(farm, "assemble_frame", lambda *a, **k: (buffers.append(k.get("frame_px")), real_assemble(*a, **k))[1])
    monkeypatch.setattr(farm, "COMMIT_INTERVAL_S", 0.0)  # commit after every tile
    assert farm.run_tiles(settings, job_id, 0, list(range(9)), "w-test") == "rendered"  # 3 x 3 tiles
    assert chunks == [1] * 9  # one commit per tile, the last one included
    assert len(buffers) == 1 and buffers[0] is not None  # assembled from the run's own buffer, not copied again
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert s.query(Frame).filter(Frame.job_id == job_id).one().status == "done"
        assert {t.status for t in s.query(Tile).filter(Tile.job_id == job_id)} == {"done"}
    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    want = exr_pixels(render_frame(load_scene("steiner"), FrameParams(delta=0.3, width=48, height=40), tile=16, workers=1))
    assert np.array_equal(px[..., [names.index(n) for n in EXR_CHANNELS]].view(np.uint32), want.view(np.uint32))
    assert not (settings.data_path / "store" / "jobs" / job_id / "tiles").exists() or not any(
        (settings.data_path / "store" / "jobs" / job_id / "tiles").rglob("*.chunk"))


def test_a_pause_stops_a_run_between_tiles_and_resume_sends_the_rest(farm_parts, monkeypatch):
    import time

    from argand.api.db import Frame, Job, Tile, session_scope
    from argand.render import frames as frames_module
    from argand.scene import load_scene
    from argand.worker import farm

    settings, redis_server = farm_parts
    job_id = farm.create_job(settings, "whitney", load_scene("whitney").to_dict(), 0.0, [0.0], 64, 64, 16, 5)
    sent = queued_messages(redis_server)
    real = frames_module.render_tile_into
    calls = []

    def pausing(plan, rect, out, ox=0, oy=0):
        calls.append(rect)
        if len(calls) == 3:  # someone pauses the job while the third tile renders
            farm.set_job_status(settings, job_id, "pause")
            time.sleep(2 * farm.STOP_CHECK_S)
        return real(plan, rect, out, ox, oy)

    monkeypatch.setattr(frames_module, "render_tile_into", pausing)
    assert farm.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "paused"
    assert len(calls) == 3  # not one tile more
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert [i for i, t in sorted(tiles.items()) if t.status == "done"] == [0, 1, 2]
        assert all(t.status == "queued" and t.worker is None for i, t in tiles.items() if i >= 3)
        assert s.query(Frame).filter(Frame.job_id == job_id).one().status == "rendering"
    assert queued_messages(redis_server) == sent  # a pause sends nothing
    assert farm.set_job_status(settings, job_id, "resume") == "running"
    assert queued_messages(redis_server) > sent
    monkeypatch.setattr(frames_module, "render_tile_into", real)
    assert farm.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        frame = s.query(Frame).filter(Frame.job_id == job_id).one()
        assert frame.status == "done" and frame.tiles_done == 16
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
    # The frame was assembled from the first run's chunk file and the second run's memory.
    from argand.render import FrameParams, render_frame
    from argand.render.output import read_exr

    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(load_scene("whitney"), FrameParams(width=64, height=64), workers=1)
    assert np.array_equal(px[..., names.index("A")], local.rgba[..., 3])
    assert np.array_equal(px[..., names.index("status")], local.aovs["status"].astype(np.float32))


def test_the_reaper_finishes_what_a_worker_dying_at_the_wrong_moment_left(farm_parts, monkeypatch):
    """A worker killed right after its last completion (before assembling),
    or right after the last frame (before the animation): the reaper notices
    in two rounds and finishes the frame, then the job."""
    from argand.api.db import Frame, Job, session_scope
    from argand.scene import load_scene
    from argand.worker import farm

    settings, _ = farm_parts
    job_id = farm.create_job(settings, "plucker", load_scene("plucker").to_dict(), 0.0, [0.0, 0.1], 32, 32, 16, 5)
    real_assemble, real_finish = farm.maybe_assemble, farm._finish_job_if_last
    monkeypatch.setattr(farm, "maybe_assemble", lambda *a, **k: False)  # "dies" before assembling
    assert farm.run_tiles(settings, job_id, 0, [0, 1], "w-test") == "rendered"
    assert farm.run_tiles(settings, job_id, 0, [2, 3], "w-test") == "rendered"
    monkeypatch.setattr(farm, "maybe_assemble", real_assemble)
    monkeypatch.setattr(farm, "_finish_job_if_last", lambda *a, **k: None)  # "dies" before the animation
    assert farm.run_tiles(settings, job_id, 1, [0, 1, 2, 3], "w-test") == "rendered"  # whole frame: assembled
    monkeypatch.setattr(farm, "_finish_job_if_last", real_finish)

    def states():
        with session_scope(settings.sqlalchemy_url) as s:
            return s.get(Job, job_id).status, [f.status for f in s.query(Frame).filter(Frame.job_id == job_id).order_by(Frame.index)]

    assert states() == ("running", ["rendering", "done"])
    farm.reap(settings)
    assert states() == ("running", ["rendering", "done"])  # one round: it may be a live worker's moment
    farm.reap(settings)
    assert states() == ("done", ["done", "done"])
    assert (settings.data_path / "store" / "jobs" / job_id / "animation.gif").exists()
    assert (settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr").exists()

    # The same for a job whose last frame was assembled but not finished.
    job2 = farm.create_job(settings, "plucker", load_scene("plucker").to_dict(), 0.0, [0.0], 32, 32, 16, 5)
    monkeypatch.setattr(farm, "_finish_job_if_last", lambda *a, **k: None)
    farm.run_tiles(settings, job2, 0, [0, 1, 2, 3], "w-test")
    monkeypatch.setattr(farm, "_finish_job_if_last", real_finish)
    farm.reap(settings)
    farm.reap(settings)
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job2).status == "done"


def test_work_left_by_an_earlier_version_is_finished(farm_parts):
    """A job upgraded in the middle: one tile done by the earlier version
    (its own .npz, one array per AOV, no chunk), one message of the older
    one-tile shape, the rest as runs. The frame equals the local render."""
    import io

    from sqlalchemy import update

    from argand.api.db import Frame, Job, Tile, engine_for, session_scope
    from argand.render import FrameParams, TileRect, render_frame, render_tile
    from argand.render.output import read_exr
    from argand.scene import load_scene
    from argand.worker import farm

    settings, _ = farm_parts
    scene = load_scene("mitchell")
    job_id = farm.create_job(settings, "mitchell", scene.to_dict(), 0.0, [0.1], 32, 32, 16, 5)
    old = render_tile(scene, FrameParams(delta=0.1, width=32, height=32), TileRect(0, 0, 16, 16))
    buf = io.BytesIO()  # the earlier version's tile file
    np.savez(buf, rgba=old.rgba, **old.aovs, meta=np.array([old.escalations, old.root_calls], np.int64))
    folder = settings.data_path / "store" / "jobs" / job_id / "tiles" / "0000"
    folder.mkdir(parents=True)
    (folder / "00000.npz").write_bytes(buf.getvalue())
    with engine_for(settings.sqlalchemy_url).begin() as c:
        c.execute(update(Tile).where(Tile.job_id == job_id, Tile.tile_index == 0).values(status="done", renders=1))
        c.execute(update(Frame).where(Frame.job_id == job_id).values(tiles_done=1, status="rendering"))
    assert farm.run_tile(settings, job_id, 0, 1, "w-old") == "rendered"  # the older message shape
    assert farm.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-new") == "rendered"  # 0 and 1 are skipped
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        chunks = {t.tile_index: t.chunk for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert chunks[0] is None and None not in (chunks[1], chunks[2], chunks[3])
        figures = s.query(Frame).filter(Frame.job_id == job_id).one().figures
    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(scene, FrameParams(delta=0.1, width=32, height=32), workers=1)
    for i, c in enumerate("RGBA"):
        assert np.array_equal(px[..., names.index(c)], local.rgba[..., i])
    for aov in ("Z", "arg", "re", "im", "count", "status"):
        assert np.array_equal(px[..., names.index(aov)], local.aovs[aov].astype(np.float32))
    for key in ("certified_share", "status_shares", "hit_share", "escalations", "root_calls"):
        assert figures[key] == local.figures[key], key


def test_a_jobs_sweep_is_argand_renders_sweep_to_the_last_bit():
    """The same sweep over HTTP and on the command line gives the same
    deltas, so a farm's frame and `argand render`'s are the same frame
    (an earlier formula differed in the last bit for 13 of 36 frames)."""
    from argand.api.main import DeltaRange
    from argand.render import delta_sweep, parse_sweep
    from argand.worker.farm import frames_of

    for count in (1, 2, 5, 12, 24, 36, 48, 100):
        spec = DeltaRange(start="pi/36", stop="pi/9", count=count).model_dump()
        assert frames_of(spec) == delta_sweep(*parse_sweep(f"pi/36:pi/9:{count}")), count
