"""A worker that comes back after the farm went on without it (frozen by
SIGSTOP, or cut off past the heartbeat timeout), and a job deleted under a
running worker: neither may leave files in the store, nor raise. The
task's body is called directly on a real Redis and SQLite (test_work.py's
farm_parts); the freeze and the deletion happen between two tiles."""

from __future__ import annotations

import time

import numpy as np

from argand.media.atomic import is_temporary
from argand.farm import control, tile_work
from argand.farm.database import session_scope
from argand.farm.models import Job, Tile
from argand.farm.reaper import Reaper
from argand.farm.workers import declare_dead, heartbeat
from argand.media.frame_files import read_exr
from argand.render import FrameParams, render_frame
from argand.scene import load_scene
from tests.farm.test_work import farm_parts, submit  # noqa: F401 (a fixture)


def files_of(settings, job_id: str) -> list[str]:
    folder = settings.store_path / "jobs" / job_id
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def freeze_on_the_third_tile(monkeypatch, settings, job_id: str, tiles: list[int], wait: float = 0.0) -> list:
    """Worker "stale" (heartbeat sent) freezes at its third tile: its
    heartbeats stop, the reaper gives its tiles to another worker, "fresh",
    which renders ``tiles`` of frame 0 (and their window); after ``wait``
    seconds, SIGCONT. Returns the stale worker's renders (their tile
    rectangles), filled as they come."""
    real = tile_work.render_tile_bands_into
    calls = []

    def freeze(plans, rect, outs, record=None):
        calls.append(rect)
        if len(calls) == 3:
            monkeypatch.setattr(tile_work, "render_tile_bands_into", real)
            declare_dead(settings, "stale")
            Reaper(settings).round()
            assert tile_work.run_tiles(settings, job_id, 0, tiles, "fresh") == "rendered"
            time.sleep(wait)
            monkeypatch.setattr(tile_work, "render_tile_bands_into", freeze)
        return real(plans, rect, outs, record)

    heartbeat(settings, "stale", 1)
    monkeypatch.setattr(tile_work, "render_tile_bands_into", freeze)
    return calls


def test_a_worker_frozen_past_reassignment_writes_nothing_into_the_finished_job(farm_parts, monkeypatch):
    settings, _redis = farm_parts
    job_id = submit(settings, "steiner", [0.0], 64, 64, 16)
    calls = freeze_on_the_third_tile(monkeypatch, settings, job_id, list(range(16)), 2 * tile_work.STOP_CHECK_S)
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 1e9)  # the stale worker holds its tiles uncommitted
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "stale") == "done"
    assert len(calls) == 3  # it stopped at its next check: the job is done
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        tiles = s.query(Tile).filter(Tile.job_id == job_id).all()
        assert {(t.status, t.worker, t.renders) for t in tiles} == {("done", "fresh", 1)}
    left = files_of(settings, job_id)
    assert not [f for f in left if f.startswith("tiles") or f.endswith(".chunk") or is_temporary(f.rsplit("/", 1)[-1])], left
    names, px = read_exr(settings.store_path / "jobs" / job_id / "frame_0000.exr")
    local = render_frame(load_scene("steiner"), FrameParams(width=64, height=64), tile=16, workers=1)
    assert np.array_equal(px[..., names.index("Z")], local.aovs["Z"])


def test_deleting_a_running_job_leaves_nothing_in_the_store_and_the_worker_stops_quietly(farm_parts, monkeypatch):
    settings, _redis = farm_parts
    job_id = submit(settings, "steiner", [0.0, 0.1], 64, 64, 16)
    assert tile_work.run_tiles(settings, job_id, 1, list(range(16)), "w") == "rendered"  # frame 1's files exist
    real = tile_work.render_tile_bands_into
    calls = []

    def delete_on_the_third_tile(plans, rect, outs, record=None):
        calls.append(rect)
        if len(calls) == 3:
            control.delete_job(settings, job_id)  # what DELETE /api/jobs/{id} does
            time.sleep(2 * tile_work.STOP_CHECK_S)
        return real(plans, rect, outs, record)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", delete_on_the_third_tile)
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 1e9)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(16)), "w") == "gone"
    assert files_of(settings, job_id) == [] and not (settings.store_path / "jobs" / job_id).exists()


def test_a_job_deleted_between_the_claim_and_the_frames_plan_is_gone_not_an_error(farm_parts):
    settings, _redis = farm_parts
    job_id = submit(settings, "steiner", [0.0], 64, 64, 16)
    why, claimed = tile_work.claim(settings, job_id, 0, list(range(16)), "w", None)
    assert why is None and claimed == list(range(16))
    control.delete_job(settings, job_id)
    assert tile_work._run_claimed(settings, job_id, 0, "w", claimed, time.monotonic()) == "gone"
    assert not (settings.store_path / "jobs" / job_id).exists()


def test_a_worker_whose_consumer_stalled_while_messages_wait_stops_itself(farm_parts, monkeypatch):  # noqa: F811
    """Celery's Redis consumer can stay idle for good after a cut connection;
    the worker notices (messages wait, it took none for STALL_S) and ends
    itself so that its supervisor starts it again. A busy worker, or an
    idle one with nothing waiting, is left alone."""
    import threading

    from argand.farm.queue import broker_client
    from argand.worker import stall_check

    settings, _redis = farm_parts
    monkeypatch.setattr(stall_check, "CHECK_S", 0.05)
    monkeypatch.setattr(stall_check, "STALL_S", 0.5)
    monkeypatch.setattr(stall_check, "END_WAIT_S", 0.0)
    monkeypatch.setattr(stall_check.os, "_exit", lambda code: None)

    def ended_within(seconds: float) -> bool:
        ended = threading.Event()
        check = stall_check.StallCheck(settings, "w", end=ended.set)
        check.start()
        try:
            return ended.wait(seconds)
        finally:
            check.stop.set()
            check.join(5)

    stall_check.TASKS.update(running=False, at=time.monotonic())
    assert not ended_within(1.0)  # idle, and nothing waits
    client = broker_client(settings)
    client.rpush("argand", b"{}")
    stall_check.TASKS.update(running=True, at=time.monotonic() - 60)
    assert not ended_within(1.0)  # a message waits, but the worker is busy
    stall_check.TASKS.update(running=False, at=time.monotonic())
    assert ended_within(3.0)  # idle while a message waits


def test_a_window_run_whose_tiles_went_to_another_worker_writes_and_counts_none_of_them(farm_parts, monkeypatch):
    """A run of a window of frames (figures only, one chunk for the window)
    frozen while the reaper gives its tiles away: the other worker renders
    and commits them; the stale run, back, marks none of them done, writes no
    chunk, and every frame's figures are the local render's, each tile
    counted once."""
    from argand.farm.models import Frame
    from argand.render.frames import frame_figures

    settings, _redis = farm_parts
    settings = settings.model_copy(update={"bands_per_run": 4, "files_on_request": True})
    deltas = [0.0, 0.2, 0.5, 0.9]
    job_id = submit(settings, "whitney", deltas, 64, 64, 16)
    calls = freeze_on_the_third_tile(monkeypatch, settings, job_id, list(range(8)))
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 1e9)  # the stale run holds its tiles uncommitted
    tile_work.run_tiles(settings, job_id, 0, list(range(8)), "stale")
    assert len(calls) == 8  # (the job went on: the stale run rendered its tiles, and lost them)
    with session_scope(settings.sqlalchemy_url) as s:
        tiles = s.query(Tile).filter(Tile.job_id == job_id, Tile.tile_index < 8).all()
        assert len(tiles) == 32 and {(t.status, t.worker, t.renders) for t in tiles} == {("done", "fresh", 1)}
        assert not s.query(Tile).filter(Tile.job_id == job_id, Tile.worker == "stale").count()
        mine = {t.chunk for t in tiles}
    chunks = [f for f in files_of(settings, job_id) if f.endswith(".chunk")]
    assert {c.rsplit("/", 1)[-1][:-len(".chunk")] for c in chunks} == mine, (chunks, mine)  # none of the stale run's
    assert tile_work.run_tiles(settings, job_id, 0, list(range(8, 16)), "fresh") == "rendered"
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        figures = {f.index: f.figures for f in s.query(Frame).filter(Frame.job_id == job_id)}
        assert {(t.status, t.renders) for t in s.query(Tile).filter(Tile.job_id == job_id)} == {("done", 1)}
    for i, delta in enumerate(deltas):
        want = frame_figures(render_frame(load_scene("whitney"), FrameParams(delta=delta, width=64, height=64), tile=16,
                                          workers=1))
        for key in ("status_shares", "hit_share", "escalations", "escalation_levels", "root_calls"):
            assert figures[i][key] == want[key], (i, key)
