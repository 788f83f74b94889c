"""A run renders its tiles of every frame it can claim at once (the same
tiles of the job's next frames, bands_per_run in all): one pass of
render_tile_bands a tile, the primary roots solved once. What must hold:
every frame equals the frame rendered alone, bit for bit; every tile is
rendered and counted once (the other frames' messages find their tiles
taken or done); a pause, an error or a time limit gives back every frame's
unrendered tiles. Real SQLite, a real embedded Redis; the task's body
called directly (tile_work.run_tiles), as a worker calls it."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from argand.farm import control, tile_work
from argand.farm.database import session_scope
from argand.farm.models import Frame, Job, Tile
from argand.media.frame_files import read_exr
from argand.render import FrameParams, render_frame
from argand.scene import load_scene
from tests.farm.test_work import farm_parts, queued_messages, submit  # noqa: F401  (the fixture)

DELTAS = [0.0, math.pi / 36, math.pi / 18, math.pi / 9, math.pi / 6, math.pi / 4]


def _tiles(settings, job_id):
    with session_scope(settings.sqlalchemy_url) as s:
        return {(t.frame_index, t.tile_index): (t.status, t.renders, t.worker)
                for t in s.query(Tile).filter(Tile.job_id == job_id)}


def _frames_equal_local(settings, job_id, scene: str, deltas, size: int, tile: int) -> None:
    """Every frame's pixels (the assembler's EXR, or with files_on_request
    the one decided from the root field on request) and figures are the
    local render's."""
    from argand.farm import derived
    from argand.render.frames import frame_figures

    for index, delta in enumerate(deltas):
        local = render_frame(load_scene(scene), FrameParams(delta=delta, width=size, height=size), tile=tile, workers=1)
        if settings.files_on_request:
            path = derived.frame_file(settings, job_id, index, "exr")
            with session_scope(settings.sqlalchemy_url) as s:
                figures = s.query(Frame).filter(Frame.job_id == job_id, Frame.index == index).one().figures
            want = frame_figures(local)
            for key in ("status_shares", "escalation_levels", "hit_share", "escalations", "root_calls"):
                assert figures[key] == want[key], (index, key)
        else:
            path = settings.store_path / "jobs" / job_id / f"frame_{index:04d}.exr"
        names, px = read_exr(path)
        for name in names:
            want = local.rgba[..., "RGBA".index(name)] if name in "RGBA" else local.aovs[name].astype(np.float32)
            assert px[..., names.index(name)].tobytes() == want.tobytes(), (index, name)


@pytest.mark.parametrize("files_on_request", [False, True])
@pytest.mark.parametrize("scene", ["whitney", "barth-sextic"])
def test_one_run_renders_the_same_tiles_of_the_next_frames(farm_parts, scene, files_on_request):  # noqa: F811
    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"bands_per_run": 4, "files_on_request": files_on_request})
    job_id = submit(settings, scene, DELTAS, 48, 48, 16)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(9)), "w1") == "rendered"
    tiles = _tiles(settings, job_id)
    assert {k for k, v in tiles.items() if v[0] == "done"} == {(f, i) for f in range(4) for i in range(9)}
    # The messages of frames 1-3 find nothing to do; frames 4 and 5 come with frame 4's message.
    assert [tile_work.run_tiles(settings, job_id, f, list(range(9)), "w2") for f in (1, 2, 3)] == ["taken or done"] * 3
    assert tile_work.run_tiles(settings, job_id, 4, list(range(9)), "w2") == "rendered"
    assert tile_work.run_tiles(settings, job_id, 5, list(range(9)), "w2") == "taken or done"
    tiles = _tiles(settings, job_id)
    assert {v[:2] for v in tiles.values()} == {("done", 1)}
    assert {v[2] for k, v in tiles.items() if k[0] < 4} == {"w1"} and {v[2] for k, v in tiles.items() if k[0] >= 4} == {"w2"}
    with session_scope(settings.sqlalchemy_url) as s:
        assert s.get(Job, job_id).status == "done"
        assert [f.tiles_done for f in s.query(Frame).filter(Frame.job_id == job_id).order_by(Frame.index)] == [9] * 6
    _frames_equal_local(settings, job_id, scene, DELTAS, 48, 16)


@pytest.mark.parametrize("files_on_request", [False, True])
def test_partial_runs_and_a_tile_taken_by_another_worker(farm_parts, files_on_request):  # noqa: F811
    settings, _redis = farm_parts
    settings = settings.model_copy(update={"bands_per_run": 8, "files_on_request": files_on_request})
    job_id = submit(settings, "steiner", DELTAS[:4], 48, 48, 16)
    # Another worker holds frame 2's tile 4: the sibling claim skips it.
    assert tile_work.run_tiles(settings, job_id, 2, [4], "other") == "rendered"
    assert tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3, 4], "w1") == "rendered"
    tiles = _tiles(settings, job_id)
    assert tiles[(2, 4)] == ("done", 1, "other")
    assert all(tiles[(f, i)][:2] == ("done", 1) for f in range(4) for i in range(5))
    assert all(tiles[(f, i)][0] == "queued" for f in range(4) for i in range(5, 9))
    for f in range(4):
        tile_work.run_tiles(settings, job_id, f, list(range(5, 9)), "w2")
    assert {v[:2] for v in _tiles(settings, job_id).values()} == {("done", 1)}
    _frames_equal_local(settings, job_id, "steiner", DELTAS[:4], 48, 16)


def test_an_error_or_a_pause_gives_back_every_frames_unrendered_tiles(farm_parts, monkeypatch):  # noqa: F811
    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"bands_per_run": 3})
    job_id = submit(settings, "bicube", DELTAS[:3], 48, 48, 16)
    real = tile_work.render_tile_bands_into
    calls = []

    def failing(plans, rect, outs, record=None):
        calls.append(len(plans))
        if len(calls) == 4:
            raise RuntimeError("the renderer broke")
        return real(plans, rect, outs, record)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", failing)
    monkeypatch.setattr(tile_work, "COMMIT_INTERVAL_S", 1e9)  # one commit, on the error
    with pytest.raises(RuntimeError, match="renderer broke"):
        tile_work.run_tiles(settings, job_id, 0, list(range(9)), "w1")
    assert calls == [3, 3, 3, 3]  # each pass rendered the three frames' tile
    tiles = _tiles(settings, job_id)
    assert {k for k, v in tiles.items() if v[0] == "done"} == {(f, i) for f in range(3) for i in range(3)}
    assert all(v[0] == "queued" and v[2] is None for k, v in tiles.items() if k[1] >= 3)  # every frame's rest, back
    # A pause during the next run: what it did not render goes back, on every frame.
    monkeypatch.setattr(tile_work, "render_tile_bands_into", real)

    def pausing(plans, rect, outs, record=None):
        if rect.x0 == 0 and rect.y0 == 16:  # the fourth tile
            control.set_job_status(settings, job_id, "pause")
            time.sleep(2 * tile_work.STOP_CHECK_S)
        return real(plans, rect, outs, record)

    monkeypatch.setattr(tile_work, "render_tile_bands_into", pausing)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(3, 9)), "w1") == "paused"
    tiles = _tiles(settings, job_id)
    assert {k for k, v in tiles.items() if v[0] == "done"} == {(f, i) for f in range(3) for i in range(4)}
    assert all(v[0] == "queued" and v[2] is None for k, v in tiles.items() if k[1] >= 4)
    monkeypatch.setattr(tile_work, "render_tile_bands_into", real)
    assert control.set_job_status(settings, job_id, "resume") == "running"
    assert tile_work.run_tiles(settings, job_id, 0, list(range(9)), "w2") == "rendered"
    assert {v[:2] for v in _tiles(settings, job_id).values()} == {("done", 1)}
    _frames_equal_local(settings, job_id, "bicube", DELTAS[:3], 48, 16)


def test_a_window_chunk_the_store_refuses_marks_no_tile_done_and_leaves_no_file(farm_parts, monkeypatch):  # noqa: F811
    """A store that refuses the window's chunk (a full disk): no tile is
    marked done, so none points at a chunk that is not there, the job fails
    saying the store cannot be written, no tile stays running or counted,
    and a retry once the store takes writes again finishes it, every frame
    the local render's."""
    import errno

    from argand.farm.store import FrameStore

    settings, redis_server = farm_parts
    settings = settings.model_copy(update={"bands_per_run": 4, "files_on_request": True})
    job_id = submit(settings, "whitney", DELTAS, 48, 48, 16)
    real = FrameStore.write_atomic

    def full(self, path, data):
        if str(path).endswith(".chunk"):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(self, path, data)

    monkeypatch.setattr(FrameStore, "write_atomic", full)
    with pytest.raises(OSError):  # (part of each frame: a whole one commits with its assembly, no chunk)
        tile_work.run_tiles(settings, job_id, 0, list(range(5)), "w1")
    tiles = _tiles(settings, job_id)
    assert {v[:2] for v in tiles.values()} == {("queued", 0)}, tiles
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        assert job.status == "failed" and job.error.startswith("the store cannot be written ("), job.error
        assert [f.tiles_done for f in s.query(Frame).filter(Frame.job_id == job_id)] == [0] * len(DELTAS)
    assert not list((settings.store_path / "jobs").rglob("*.chunk"))
    monkeypatch.setattr(FrameStore, "write_atomic", real)
    assert control.set_job_status(settings, job_id, "retry") in ("queued", "running")
    for f in (0, 4):
        assert tile_work.run_tiles(settings, job_id, f, list(range(9)), "w2") == "rendered"
    assert {v[:2] for v in _tiles(settings, job_id).values()} == {("done", 1)}
    _frames_equal_local(settings, job_id, "whitney", DELTAS, 48, 16)
