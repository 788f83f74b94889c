"""The farm's work model in pieces (argand.farm): how tiles become messages,
the tile store's files, the schema's migrations, and the task's body called
directly on a real Redis and SQLite. (The whole farm, with real processes,
is in test_farm.py.)"""

from __future__ import annotations

import numpy as np
import pytest
from sqlalchemy import inspect

from argand.farm import assembly, control, tile_work
from argand.farm.database import session_scope
from argand.farm.models import Frame, Job, Tile
from argand.farm.planning import batch_runs, plan_runs, preview_order, tile_rects
from argand.farm.reaper import Reaper
from argand.farm.store import FrameStore, pack_arrays, unpack_arrays
from argand.farm.submission import JobSpec, create_job
from argand.frames.frame_set import frame_grid
from argand.scene import load_scene


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


@pytest.mark.parametrize("seed", range(12))
def test_windowed_runs_cover_every_queued_tile_through_one_leader(seed):
    """With frames that keep only their figures, a run carries its tiles of
    a window of frames (claim_siblings: the next window - 1 frames). Every
    queued (frame, tile) must be reached by exactly one message: the one of
    the first frame of its window where that tile is queued (whatever is
    done already: a requeue after a crash, a census), and a whole job's
    first frames are split so that every worker gets four runs or more."""
    import random

    rng = random.Random(seed)
    width, height, tile = rng.choice([(96, 80, 16), (512, 512, 64), (200, 120, 40)])
    rects = tile_rects(width, height, tile)
    frames, window, workers = rng.randint(1, 40), rng.choice([2, 8, 32]), rng.randint(1, 3)
    whole = seed % 3 == 0
    by_frame = {f: [t for t in range(len(rects)) if whole or rng.random() < 0.5] for f in range(frames)}
    runs = plan_runs(by_frame, frames, rects, 512 * 512, workers, window=window)
    reached = {}
    for f, run in runs:
        assert run == sorted(run)
        for t in run:
            start = f - f % window
            assert t in by_frame[f] and all(t not in by_frame[g] for g in range(start, f)), (f, t)
            for g in range(f, min(frames, f - f % window + window, f + window)):
                if t in by_frame[g]:
                    assert (g, t) not in reached, (g, t)
                    reached[(g, t)] = f
    assert sorted(reached) == sorted((f, t) for f in range(frames) for t in by_frame[f])
    if whole:
        assert len(runs) >= min(4 * workers, len(rects) * -(-frames // window))


def test_batch_runs_keeps_tile_order():
    rects = tile_rects(80, 8, 8)
    assert batch_runs(list(range(10)), rects, 160) == [[0, 1, 2], [3, 4, 5], [6, 7, 8], [9]]
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

    store = FrameStore(tmp_path / "store")
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



def test_a_window_chunk_of_like_tiles_is_stacked_and_reads_back_the_same(tmp_path):
    """A window's figures-only tiles (every tile's meta and levels of one
    shape) are stored stacked, a handful of arrays for the whole window,
    and each frame reads back exactly its tiles' values, as many frames,
    tiles and values as a window holds; arrays of another shape keep the
    per-tile form."""
    from argand.farm.store import unpack_arrays

    rng = np.random.default_rng(7)
    frames, tiles_of = (0, 3, 31), (0, 5, 63, 64)
    tiles = {(f, t): {"meta": rng.integers(0, 2**40, 9).astype(np.int64),
                      "levels": rng.integers(0, 4096, 8).astype(np.int64)} for f in frames for t in tiles_of}
    store = FrameStore(tmp_path / "store")
    store.write_window_chunk("job", "w-00000-stk", tiles)
    raw = unpack_arrays((tmp_path / "store/jobs/job/tiles/window/w-00000-stk.chunk").read_bytes())
    assert len(raw) == 3, sorted(raw)  # the rows, the metas, the levels
    fresh = FrameStore(tmp_path / "store")  # (another process: nothing cached)
    for f in (*frames, 7):
        got = fresh.read_chunk("job", f, "w-00000-stk")
        assert set(got) == (set(tiles_of) if f in frames else set())
        for t, d in got.items():
            assert set(d) == {"meta", "levels"}
            for k in d:
                assert d[k].dtype == np.int64 and np.array_equal(d[k], tiles[(f, t)][k]), (f, t, k)


def test_a_window_of_runs_is_stacked_as_the_tiles_dicts_would_be(tmp_path):
    """_commit_all stacks a window's figures straight from its runs
    (_window_figures, FrameStore.write_window_stacked): the file holds the
    same bytes as write_window_chunk of each tile's _tile_arrays, for runs
    of any frames, tiles and figures; a stacked window with rows that do
    not match its columns, or a name that is not a window's, is refused."""
    from argand.farm.tile_work import TileRun, _tile_arrays, _window_figures

    rng = np.random.default_rng(11)
    runs = []
    for f in (0, 4, 23):
        run = TileRun(settings=None, job_id="job", frame_index=f, worker="w", claimed=[])
        for t in rng.choice(64, size=5, replace=False).tolist():
            stats = rng.integers(0, 4096, 5).astype(np.int64)
            run.local[t] = (None, int(rng.integers(0, 100)), int(rng.integers(0, 2**33)), stats,
                            rng.integers(0, 4096, 8).astype(np.int64))
            run.pending[t] = 0.01
        runs.append(run)
    store = FrameStore(tmp_path / "store")
    store.write_window_chunk("job", "w-00000-old", {(r.frame_index, i): _tile_arrays(r.local[i])
                                                    for r in runs for i in r.pending})
    store.write_window_stacked("job", "w-00000-new", *_window_figures(runs))
    folder = tmp_path / "store/jobs/job/tiles/window"
    assert (folder / "w-00000-new.chunk").read_bytes() == (folder / "w-00000-old.chunk").read_bytes()
    keys, columns = _window_figures(runs)
    with pytest.raises(ValueError, match="one row per tile"):
        store.write_window_stacked("job", "w-00000-bad", keys[:-1], columns)
    with pytest.raises(ValueError, match="w-"):
        store.write_window_stacked("job", "00000-bad", keys, columns)


def test_a_window_chunk_holds_its_frames_tiles_and_gives_each_frame_its_own(tmp_path):
    """Figures-only tiles of a window's frames (files on request) go into one
    file; each frame reads back exactly its tiles, and a chunk nobody won is
    removed with the folders it leaves empty."""
    store = FrameStore(tmp_path / "store")
    tiles = {(f, t): {"meta": np.array([f, t, 7], np.int64), "levels": np.arange(t + 1, dtype=np.int64)}
             for f in (0, 1, 12) for t in (3, 4, 10)}
    store.write_window_chunk("job", "w-00003-abc", tiles)
    assert [p.relative_to(tmp_path / "store/jobs/job").as_posix() for p in (tmp_path / "store/jobs/job").rglob("*")
            if p.is_file()] == ["tiles/window/w-00003-abc.chunk"]
    for f in (0, 1, 12):
        got = store.read_chunk("job", f, "w-00003-abc")
        assert set(got) == {3, 4, 10}
        for t in (3, 4, 10):
            assert list(got[t]["meta"]) == [f, t, 7] and list(got[t]["levels"]) == list(range(t + 1))
    assert store.read_chunk("job", 5, "w-00003-abc") == {}  # (a frame not in the window)
    with pytest.raises(ValueError, match="w-"):
        store.write_window_chunk("job", "00003-abc", tiles)
    store.discard_chunk("job", 0, "w-00003-abc")
    assert not (tmp_path / "store/jobs/job").exists()


def test_the_migrations_make_the_models_schema_and_a_second_upgrade_changes_nothing(tmp_path):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from argand.farm.database import engine_for, upgrade
    from argand.farm.models import Base

    url = f"sqlite:///{tmp_path / 'new.db'}"
    upgrade(url)
    eng = engine_for(url)
    with eng.connect() as c:
        assert compare_metadata(MigrationContext.configure(c), Base.metadata) == []
        assert c.exec_driver_sql("select version_num from alembic_version").scalar() == "0004"
    assert "ix_tiles_key" in {i["name"] for i in inspect(eng).get_indexes("tiles")}
    upgrade(url)  # a second time: nothing to do, nothing fails
    with eng.connect() as c:
        assert compare_metadata(MigrationContext.configure(c), Base.metadata) == []


def test_the_grid_migration_keeps_earlier_jobs_frames_as_row_zero(tmp_path):
    """Frames stored before (σ, δ) jobs become row 0 with their index as
    column, and none is lost (dropping the jobs' sigma in place, not by a
    table copy, which with foreign keys on would delete every frame)."""
    from argand.farm.database import engine_for, upgrade

    url = f"sqlite:///{tmp_path / 'old.db'}"
    upgrade(url, "0001")
    eng = engine_for(url)
    with eng.begin() as c:
        c.exec_driver_sql("insert into jobs (id, status, scene_name, scene, sigma, width, height, tile, method, priority,"
                          " created) values ('j', 'done', 'whitney', '{}', 0.25, 8, 8, 8, 'auto', 5, 0)")
        for i in range(3):
            c.exec_driver_sql("insert into frames (job_id, \"index\", sigma, delta, status, tiles_total, tiles_done)"
                              f" values ('j', {i}, 0.25, {0.1 * i}, 'done', 1, 1)")
        c.exec_driver_sql("insert into tiles (job_id, frame_index, tile_index, status, attempts, renders)"
                          " values ('j', 0, 0, 'done', 1, 1)")
    upgrade(url)
    with eng.connect() as c:
        rows = c.exec_driver_sql('select "index", sigma, sigma_index, delta_index from frames order by "index"').all()
        assert [tuple(r) for r in rows] == [(0, 0.25, 0, 0), (1, 0.25, 0, 1), (2, 0.25, 0, 2)]
        assert c.exec_driver_sql("select count(*) from tiles").scalar() == 1
        assert "sigma" not in {col["name"] for col in inspect(eng).get_columns("jobs")}
        # A job stored before jobs kept their engine options reads back as the defaults.
        from argand.render.options import EngineOptions

        assert c.exec_driver_sql("select engine from jobs where id = 'j'").scalar() is None
        assert EngineOptions.from_stored(None) == EngineOptions()


@pytest.fixture
def farm_parts(tmp_path, monkeypatch):
    """A real embedded Redis and a SQLite file, no worker: the tests call the
    task's body directly."""
    from argand.farm.database import upgrade
    from argand.farm.settings import Settings
    from argand.serve.embedded_redis import EmbeddedRedis

    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    # One frame a run: these tests follow a frame's tiles run by run (tests/farm/test_siblings.py
    # runs the same tiles of several frames at once, as the farm does by default).
    settings = Settings(data_dir=tmp_path / "data", redis_url=redis_server.url, max_tile_attempts=2, bands_per_run=1,
                        exr_on_request=False, files_on_request=False)
    upgrade(settings.sqlalchemy_url)
    yield settings, redis_server
    redis_server.stop()


def submit(settings, scene: str, deltas: list[float], width: int, height: int, tile: int) -> str:
    return create_job(settings, JobSpec(scene, load_scene(scene), frame_grid([0.0], deltas), width, height, tile))


def queued_messages(redis_server) -> int:
    import redis

    client = redis.Redis(unix_socket_path=str(redis_server.socket_path))
    return sum(client.llen(k) for k in client.keys("argand*") if client.type(k) == b"list")


def test_an_error_mid_run_keeps_what_is_done_and_gives_the_rest_back(farm_parts, monkeypatch):

    settings, redis_server = farm_parts
    job_id = submit(settings, "steiner", [0.0], 64, 64, 16)
    sent = queued_messages(redis_server)
    assert sent >= 1
    real = tile_work.render_tile_bands_into
    calls = []

    def failing(plans, rect, outs, record=None):
        calls.append(rect)
        if len(calls) == 6:
            raise RuntimeError("the renderer broke")
        return real(plans, rect, outs, record)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", failing)
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 1e9)  # one commit, at the end or on the error
    with pytest.raises(RuntimeError, match="renderer broke"):
        tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test")
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
        tile_work.run_tiles(settings, job_id, 0, list(range(5, 16)), "w-test")
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert tiles[10].attempts == 2 and tiles[10].status == "failed"
        assert job.status == "failed" and job.error == "tile 0/10 failed 2 times (RuntimeError: the renderer broke)"
    # Nothing more runs for a failed job, and what was rendered is kept.
    monkeypatch.setattr(tile_work, "render_tile_bands_into", real)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(11, 16)), "w-test") == "failed"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.query(Frame).filter(Frame.job_id == job_id).one().tiles_done == 10
    # Retry: the failed tile gets its attempts back and the rest is sent again; the frame then
    # equals the local render, the ten tiles done before kept as they were.
    sent = queued_messages(redis_server)
    assert control.set_job_status(settings, job_id, "retry") == "running"
    assert queued_messages(redis_server) > sent
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert tiles[10].status == "queued" and tiles[10].attempts == 0 and s.get(Job, job_id).error is None
        assert [i for i, t in sorted(tiles.items()) if t.status == "done"] == list(range(10))
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import read_exr

    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(load_scene("steiner"), FrameParams(width=64, height=64), tile=16, workers=1)
    assert np.array_equal(px[..., names.index("Z")], local.aovs["Z"]) and np.array_equal(px[..., names.index("A")], local.rgba[..., 3])


def test_a_whole_frame_run_that_commits_on_the_way_assembles_the_same_frame(farm_parts, monkeypatch):
    """A run holding a whole frame that takes longer than the commit
    interval (a large frame) writes chunk files for the progress it reports
    on the way; the frame it assembles still equals the local render, bit
    for bit, and its tile files are gone after."""
    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import EXR_CHANNELS, exr_pixels, read_exr

    settings, _ = farm_parts
    job_id = submit(settings, "steiner", [0.3], 48, 40, 16)
    chunks = []
    real_complete = tile_work._complete
    monkeypatch.setattr(tile_work, "_complete", lambda run: (chunks.append(len(run.pending)), real_complete(run))[1])
    real_assemble, buffers = assembly.assemble_frame, []
    monkeypatch.setattr(assembly, "assemble_frame", lambda *a, **k: (buffers.append(k.get("frame_px")), real_assemble(*a, **k))[1])
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 0.0)  # commit after every tile
    assert tile_work.run_tiles(settings, job_id, 0, list(range(9)), "w-test") == "rendered"  # 3 x 3 tiles
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


    settings, redis_server = farm_parts
    job_id = submit(settings, "whitney", [0.0], 64, 64, 16)
    sent = queued_messages(redis_server)
    real = tile_work.render_tile_bands_into
    calls = []

    def pausing(plans, rect, outs, record=None):
        calls.append(rect)
        if len(calls) == 3:  # someone pauses the job while the third tile renders
            control.set_job_status(settings, job_id, "pause")
            time.sleep(2 * tile_work.STOP_CHECK_S)
        return real(plans, rect, outs, record)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", pausing)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "paused"
    assert len(calls) == 3  # not one tile more
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = {t.tile_index: t for t in s.query(Tile).filter(Tile.job_id == job_id)}
        assert [i for i, t in sorted(tiles.items()) if t.status == "done"] == [0, 1, 2]
        assert all(t.status == "queued" and t.worker is None for i, t in tiles.items() if i >= 3)
        assert s.query(Frame).filter(Frame.job_id == job_id).one().status == "rendering"
    assert queued_messages(redis_server) == sent  # a pause sends nothing
    assert control.set_job_status(settings, job_id, "resume") == "running"
    assert queued_messages(redis_server) > sent
    monkeypatch.setattr(tile_work, "render_tile_bands_into", real)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w-test") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        frame = s.query(Frame).filter(Frame.job_id == job_id).one()
        assert frame.status == "done" and frame.tiles_done == 16
        assert {t.renders for t in s.query(Tile).filter(Tile.job_id == job_id)} == {1}
    # The frame was assembled from the first run's chunk file and the second run's memory.
    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import read_exr

    names, px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(load_scene("whitney"), FrameParams(width=64, height=64), workers=1)
    assert np.array_equal(px[..., names.index("A")], local.rgba[..., 3])
    assert np.array_equal(px[..., names.index("status")], local.aovs["status"].astype(np.float32))


def test_the_reaper_finishes_what_a_worker_dying_at_the_wrong_moment_left(farm_parts, monkeypatch):
    """A worker killed right after its last completion (before assembling),
    or right after the last frame (before the animation): the reaper notices
    in two rounds and finishes the frame, then the job."""

    settings, _ = farm_parts
    reaper = Reaper(settings)
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    real_assemble, real_finish = assembly.maybe_assemble, assembly.finish_job_if_last
    monkeypatch.setattr(assembly, "maybe_assemble", lambda *a, **k: False)  # "dies" before assembling
    assert tile_work.run_tiles(settings, job_id, 0, [0, 1], "w-test") == "rendered"
    assert tile_work.run_tiles(settings, job_id, 0, [2, 3], "w-test") == "rendered"
    monkeypatch.setattr(assembly, "maybe_assemble", real_assemble)
    monkeypatch.setattr(assembly, "finish_job_if_last", lambda *a, **k: None)  # "dies" before the animation
    assert tile_work.run_tiles(settings, job_id, 1, [0, 1, 2, 3], "w-test") == "rendered"  # whole frame: assembled
    monkeypatch.setattr(assembly, "finish_job_if_last", real_finish)

    def states():
        with session_scope(settings.sqlalchemy_url) as s:
            return s.get(Job, job_id).status, [f.status for f in s.query(Frame).filter(Frame.job_id == job_id).order_by(Frame.index)]

    assert states() == ("running", ["rendering", "done"])
    reaper.round()
    assert states() == ("running", ["rendering", "done"])  # one round: it may be a live worker's moment
    reaper.round()
    assert states() == ("done", ["done", "done"])
    assert (settings.data_path / "store" / "jobs" / job_id / "animation.gif").exists()
    assert (settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr").exists()

    # The same for a job whose last frame was assembled but not finished.
    job2 = submit(settings, "plucker", [0.0], 32, 32, 16)
    monkeypatch.setattr(assembly, "finish_job_if_last", lambda *a, **k: None)
    tile_work.run_tiles(settings, job2, 0, [0, 1, 2, 3], "w-test")
    monkeypatch.setattr(assembly, "finish_job_if_last", real_finish)
    reaper.round()
    reaper.round()
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job2).status == "done"


def test_a_jobs_sweep_is_argand_renders_sweep_to_the_last_bit():
    """The same sweep over HTTP and on the command line gives the same
    deltas, so a farm's frame and `argand render`'s are the same frame
    (an earlier formula differed in the last bit for 13 of 36 frames)."""
    from argand.api.schemas import JobRequest
    from argand.farm.submission import job_frames
    from argand.render import delta_sweep, parse_sweep

    for count in (1, 2, 5, 12, 24, 36, 48, 100):
        req = JobRequest(scene="steiner", deltas={"start": "pi/36", "stop": "pi/9", "count": count})
        assert list(job_frames(**req.axes()).deltas) == delta_sweep(*parse_sweep(f"pi/36:pi/9:{count}")), count


def test_one_worker_at_a_time_holds_the_reapers_lease(farm_parts, monkeypatch):
    import time

    from argand.farm.queue import broker_client
    from argand.worker import heartbeat

    settings, _ = farm_parts
    client = broker_client(settings)
    monkeypatch.setattr(heartbeat, "REAPER_LEASE_S", 0.3)
    assert heartbeat.holds_lease(client, "w1") and not heartbeat.holds_lease(client, "w2")
    assert heartbeat.holds_lease(client, "w1")  # renewed by its holder
    time.sleep(0.2)
    assert heartbeat.holds_lease(client, "w1") and not heartbeat.holds_lease(client, "w2")
    time.sleep(0.4)  # w1 stopped renewing (it died): w2 takes over
    assert heartbeat.holds_lease(client, "w2") and not heartbeat.holds_lease(client, "w1")


def test_a_reaper_that_cannot_reach_the_database_hands_the_lease_on(farm_parts):
    """A worker cut off from the database but not from Redis (its rounds
    fail) gives the reaper's lease up at once and stands down, so a worker
    that reaches the database reaps: the database here is a PostgreSQL
    address on loopback where nothing listens (a real refused connection)."""
    import socket

    from argand.farm.queue import broker_client
    from argand.farm.reaper import Reaper
    from argand.worker import heartbeat

    settings, _ = farm_parts
    client = broker_client(settings)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    cut_off = settings.model_copy(update={"database_url": f"postgresql+psycopg://argand@127.0.0.1:{port}/argand"})
    w1 = heartbeat.Heartbeat(cut_off, "w1")
    with pytest.raises(Exception):
        w1.reap_once(client, Reaper(cut_off))
    assert client.get(heartbeat.REAPER_KEY) is None  # given up at once, not left to expire
    w1.reap_once(client, Reaper(cut_off))  # standing down: takes no lease, runs no round
    assert client.get(heartbeat.REAPER_KEY) is None
    w2 = heartbeat.Heartbeat(settings, "w2")
    w2.reap_once(client, Reaper(settings))
    assert client.get(heartbeat.REAPER_KEY) == b"w2"
    w1.reap_once(client, Reaper(cut_off))
    assert client.get(heartbeat.REAPER_KEY) == b"w2"
    heartbeat.release_lease(client, "w1")  # another's lease stays theirs
    assert client.get(heartbeat.REAPER_KEY) == b"w2"


def test_a_job_stays_typed_from_the_request_to_the_store(farm_parts):
    """A submission carries the validated scene and the FrameSet, not dicts:
    anything else is refused before a row is written, and the store keeps
    the scene as the model's JSON, which reads back to the same model."""
    from argand.scene import scene_from_dict

    settings, _ = farm_parts
    with pytest.raises(TypeError, match="JobSpec.scene must be a validated argand.scene.Scene"):
        JobSpec("steiner", load_scene("steiner").to_dict(), frame_grid([0.0], [0.1]), 16, 16, 16)
    with pytest.raises(TypeError, match="JobSpec.frames must be a FrameSet"):
        JobSpec("steiner", load_scene("steiner"), [(0.0, 0.1)], 16, 16, 16)
    scene = load_scene("steiner").model_copy(update={"samples": 4})
    job_id = create_job(settings, JobSpec("steiner", scene, frame_grid([0.0], [0.1]), 16, 16, 16), send=False)
    with session_scope(settings.sqlalchemy_url) as s:
        stored = s.get(Job, job_id).scene
    assert stored == scene.to_dict() and stored["samples"] == 4 and scene_from_dict(stored) == scene


def test_the_end_of_a_job_removes_what_killed_writers_left(tmp_path):
    """clean_finished_job: the tile folder, and a frame file's temporary older
    than STALE_TEMPORARY_S (a writer killed mid-write); a fresh temporary (a
    writer still at work) and every finished file stay."""
    import os
    import time

    from argand.farm.store import STALE_TEMPORARY_S
    from argand.media.atomic import is_temporary

    store = FrameStore(tmp_path / "store")
    layout = store.job("j1")
    layout.folder.mkdir(parents=True)
    (layout.folder / "tiles" / "0").mkdir(parents=True)
    (layout.folder / "tiles" / "0" / "w1.chunk").write_bytes(b"x")
    done = layout.frame(6, "png")
    done.write_bytes(b"png")
    stale = layout.folder / "frame_0006.png.287b57804935.tmp.png"
    fresh = layout.folder / "frame_0007.png.0123456789ab.tmp.png"
    assert is_temporary(stale.name) and is_temporary(fresh.name)
    stale.write_bytes(b"half")
    fresh.write_bytes(b"half")
    old = time.time() - 2 * STALE_TEMPORARY_S
    os.utime(stale, (old, old))
    store.clean_finished_job("j1")
    assert not (layout.folder / "tiles").exists()
    assert not stale.exists()
    assert fresh.exists() and done.read_bytes() == b"png"
