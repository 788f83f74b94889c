"""The farm's work model as plain functions (tasks and routes stay thin):
job -> frames (one per (sigma, delta)) -> tiles.

* The database is the source of truth; a tile is rendered by whichever
  worker claims its row (compare-and-set), written atomically to the store,
  and counted once (a compare-and-set on its row, and the frame's counter in
  the same transaction). A redelivered tile that is done is a no-op.
* A message carries a run of tiles of one frame (``batch_pixels`` at most):
  the tile is the unit of state, storage and redo, the message the unit of
  dispatch. Completions are committed every ``COMMIT_INTERVAL_S`` within a
  run, so progress is smooth and a crash loses at most that much work.
* The tile that completes a frame assembles it (EXR with all AOVs, PNG,
  thumbnail, and the frame's GIF fragment); the frame that completes the job
  splices the animation from the fragments. Assembly is idempotent.
* Tiles of cancelled or paused jobs are not rendered (checked at least every
  ``STOP_CHECK_S`` between tiles). A reaper re-enqueues tiles whose worker
  stopped sending heartbeats.
"""

from __future__ import annotations

import socket
import time
import uuid
from typing import Any

import numpy as np
from sqlalchemy import func, insert, select, update

from argand.api.db import Frame, Job, Tile, Worker, engine_for, session_scope
from argand.api.settings import Settings
from argand.worker.store import FrameStore

TASK_NAME = "argand.render_tiles"
#: Messages of one tile each, from an earlier version (still understood).
LEGACY_TASK_NAME = "argand.render_tile"
STOPPED = ("canceled", "paused", "failed")
#: Within a run of tiles: how often to look for a cancel or pause, and how
#: often to commit the tiles finished so far.
STOP_CHECK_S = 0.05
COMMIT_INTERVAL_S = 0.5

_stores: dict[str, FrameStore] = {}


def store_for(settings: Settings) -> FrameStore:
    root = str(settings.data_path / "store")
    if root not in _stores:
        _stores[root] = FrameStore(root)
    return _stores[root]


# ---------------------------------------------------------------------------
# Submission
# ---------------------------------------------------------------------------


def preview_order(n_frames: int, stride: int = 4) -> list[int]:
    """Every stride-th frame first, then the gaps: a coarse preview of the
    whole animation appears early."""
    order: list[int] = []
    for start in range(stride):
        order += list(range(start, n_frames, stride))
    return order


def tile_rects(width: int, height: int, tile: int) -> list[tuple[int, int, int, int]]:
    """The renderer's tiles (argand.render.frames.tiles, whose order gives
    the tile indices) as (x0, y0, x1, y1)."""
    from argand.render.frames import tiles

    return [(r.x0, r.y0, r.x1, r.y1) for r in tiles(width, height, tile)]


def create_job(settings: Settings, scene_name: str, scene: dict, sigma: float, deltas: list[float], width: int,
               height: int, tile: int, priority: int, method: str = "auto") -> str:
    """Stores the job, its frames and tiles, and sends its messages. The
    first frames' tiles are stored and sent first, so workers start while
    the rest is written."""
    job_id = uuid.uuid4().hex[:12]
    rects = tile_rects(width, height, tile)
    n_frames = len(deltas)
    workers = max(1, alive_workers(settings))
    runs = plan_runs({f: list(range(len(rects))) for f in range(n_frames)}, n_frames, rects, settings.batch_pixels, workers)
    early = set(preview_order(n_frames)[:2 * workers])
    split = next((k for k, (f, _) in enumerate(runs) if f not in early), len(runs))

    def tiles_of(frames):
        return [dict(job_id=job_id, frame_index=i, tile_index=t, status="queued", attempts=0, renders=0)
                for i in sorted(frames) for t in range(len(rects))]

    eng = engine_for(settings.sqlalchemy_url)
    with eng.begin() as c:
        c.execute(insert(Job).values(id=job_id, status="queued", scene_name=scene_name, scene=scene, sigma=sigma,
                                     width=width, height=height, tile=tile, method=method, priority=priority,
                                     created=time.time()))
        c.execute(insert(Frame), [dict(job_id=job_id, index=i, sigma=sigma, delta=d, status="queued",
                                       tiles_total=len(rects), tiles_done=0) for i, d in enumerate(deltas)])
        c.execute(insert(Tile), tiles_of(early))
    _send(settings, job_id, runs[:split], priority)
    rest = set(range(n_frames)) - early
    if rest:
        with eng.begin() as c:
            c.execute(insert(Tile), tiles_of(rest))
        _send(settings, job_id, runs[split:], priority)
    return job_id


def alive_workers(settings: Settings) -> int:
    with engine_for(settings.sqlalchemy_url).connect() as c:
        return int(c.execute(select(func.count()).select_from(Worker).where(
            Worker.heartbeat > time.time() - settings.heartbeat_timeout_s)).scalar() or 0)


def batch_runs(tiles: list[int], rects: list[tuple[int, int, int, int]], target_pixels: int) -> list[list[int]]:
    """Splits a frame's tile indices (in order) into runs of about
    ``target_pixels`` pixels (one tile at least)."""
    runs: list[list[int]] = []
    run: list[int] = []
    pixels = 0
    for t in tiles:
        x0, y0, x1, y1 = rects[t]
        run.append(t)
        pixels += (x1 - x0) * (y1 - y0)
        if pixels >= target_pixels:
            runs.append(run)
            run, pixels = [], 0
    if run:
        runs.append(run)
    return runs


def plan_runs(by_frame: dict[int, list[int]], n_frames: int, rects: list[tuple[int, int, int, int]], batch_pixels: int,
              workers: int) -> list[tuple[int, list[int]]]:
    """The messages, in sending order, as (frame, tiles): frames in preview
    order, runs of at most ``batch_pixels``, small enough that every worker
    gets four or more. (Cutting the last runs smaller, so that the workers
    finish together, was measured: the tiles' trip through the store costs
    what the balance saves, 36 frames of 512x512 on two workers.)"""
    pixels = sum((rects[t][2] - rects[t][0]) * (rects[t][3] - rects[t][1]) for ts in by_frame.values() for t in ts)
    target = max(1, min(batch_pixels, pixels // (4 * workers)))
    return [(f, run) for f in preview_order(n_frames) for run in batch_runs(by_frame.get(f, []), rects, target)]


def _send(settings: Settings, job_id: str, runs: list[tuple[int, list[int]]], priority: int) -> None:
    from argand.worker.app import get_app

    app = get_app(settings)
    level = max(0, min(9, 9 - priority))
    for f, run in runs:
        app.send_task(TASK_NAME, args=[job_id, f, run], priority=level)


def dispatch_job(settings: Settings, job_id: str, only_status: tuple[str, ...] = ("queued",),
                 priority: int | None = None) -> int:
    """Sends messages for every tile of the job in one of the given states
    (see plan_runs), at the job's priority unless ``priority`` is given.
    Returns the number of tiles sent."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.priority, Job.width, Job.height, Job.tile).where(Job.id == job_id)).first()
        if job is None:
            return 0
        n_frames = c.execute(select(func.count()).select_from(Frame).where(Frame.job_id == job_id)).scalar()
        rows = c.execute(select(Tile.frame_index, Tile.tile_index).where(
            Tile.job_id == job_id, Tile.status.in_(only_status)).order_by(Tile.frame_index, Tile.tile_index)).all()
    by_frame: dict[int, list[int]] = {}
    for f, t in rows:
        by_frame.setdefault(f, []).append(t)
    runs = plan_runs(by_frame, n_frames, tile_rects(job.width, job.height, job.tile), settings.batch_pixels,
                     max(1, alive_workers(settings)))
    _send(settings, job_id, runs, job.priority if priority is None else priority)
    return len(rows)


# ---------------------------------------------------------------------------
# The task's body: a run of tiles
# ---------------------------------------------------------------------------

_plan_cache: dict[tuple[str, int], Any] = {}
_marked: set[tuple[str, int]] = set()  # (job, frame) this process already marked as rendering
#: What this worker process is doing; its heartbeat thread reports it (so a
#: tile costs no extra database writes for bookkeeping).
ACTIVITY: dict[str, Any] = {"tile": None, "done": 0}


_job_cache: dict[str, Any] = {}


def _frame_plan(url: str, job_id: str, frame_index: int):
    """The frame's C++ plan and tile rectangles, built once per worker
    process and frame (the job's scene is converted once per job)."""
    from argand.render.convert import to_core_scene
    from argand.render.frames import FrameParams, plan
    from argand.scene import scene_from_dict

    key = (job_id, frame_index)
    if key not in _plan_cache:
        if len(_plan_cache) > 16:
            _plan_cache.clear()
        with engine_for(url).connect() as c:
            if job_id not in _job_cache:
                if len(_job_cache) > 8:
                    _job_cache.clear()
                job = c.execute(select(Job.scene, Job.width, Job.height, Job.tile, Job.method).where(Job.id == job_id)).one()
                _job_cache[job_id] = (to_core_scene(scene_from_dict(job.scene)), job.width, job.height, job.tile, job.method)
            sigma, delta, tiles_total = c.execute(select(Frame.sigma, Frame.delta, Frame.tiles_total).where(
                Frame.job_id == job_id, Frame.index == frame_index)).one()
        core_scene, w, h, tile, method = _job_cache[job_id]
        params = FrameParams(sigma=sigma, delta=delta, width=w, height=h, method=method)
        _plan_cache[key] = (plan(core_scene, params), tile_rects(w, h, tile), tiles_total)
    return _plan_cache[key]


def _tile_key(job_id: str, frame_index: int):
    return (Tile.job_id == job_id, Tile.frame_index == frame_index)


def _complete(settings: Settings, job_id: str, frame_index: int, worker_name: str, seconds: dict[int, float],
              local: dict[int, Any]) -> tuple[int, int]:
    """Writes the rendered tiles to the store (one chunk file), then marks
    them done (only those this worker still holds: a tile the reaper gave
    to another worker is theirs to count) and adds them to the frame's
    counter, in one transaction. Returns (frame's tiles done, frame's tiles
    in all)."""
    chunk = f"{min(seconds):05d}-{uuid.uuid4().hex[:10]}"
    store_for(settings).write_chunk(job_id, frame_index, chunk, {i: _tile_arrays(local[i]) for i in seconds})
    with engine_for(settings.sqlalchemy_url).begin() as c:
        won = _mark_done(c, job_id, frame_index, worker_name, seconds, chunk)
        q = update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index)
        done, total = c.execute(q.values(tiles_done=Frame.tiles_done + len(won))
                                .returning(Frame.tiles_done, Frame.tiles_total)).one()
    ACTIVITY["done"] += len(won)
    return done, total


def _mark_done(c, job_id: str, frame_index: int, worker_name: str, seconds: dict[int, float], chunk: str) -> list[int]:
    """In the caller's transaction: the tiles of ``seconds`` that this worker
    still holds become done, stored in ``chunk``. Returns them. A tile's
    recorded render time is its run's mean (one value for the statement, so
    it compiles once however many tiles; the frame's sum is the same)."""
    return c.execute(
        update(Tile)
        .where(*_tile_key(job_id, frame_index), Tile.tile_index.in_(list(seconds)), Tile.status == "running",
               Tile.worker == worker_name)
        .values(status="done", seconds=sum(seconds.values()) / len(seconds), renders=Tile.renders + 1, chunk=chunk)
        .returning(Tile.tile_index)
    ).scalars().all()


def _tile_arrays(t: tuple[np.ndarray, int, int, np.ndarray]) -> dict[str, np.ndarray]:
    """A tile as stored: its pixels, and meta = [escalations, root calls,
    pixels per status 0..3, hits]."""
    block, esc, calls, stats = t
    return {"px": np.ascontiguousarray(block), "meta": np.array([esc, calls, *stats], dtype=np.int64)}


def _release(settings: Settings, job_id: str, frame_index: int, worker_name: str, tiles: list[int],
             resend: bool) -> None:
    """Gives tiles this worker claimed but did not finish back to the queue
    (a pause, a cancel, a time limit or an error), and sends them again if
    the job goes on."""
    if not tiles:
        return
    with engine_for(settings.sqlalchemy_url).begin() as c:
        mine = (*_tile_key(job_id, frame_index), Tile.tile_index.in_(tiles), Tile.status == "running", Tile.worker == worker_name)
        if resend:  # after an error: a tile that failed too often fails its job
            failed = c.execute(update(Tile).where(*mine, Tile.attempts >= settings.max_tile_attempts)
                               .values(status="failed").returning(Tile.tile_index)).scalars().all()
            if failed:
                c.execute(update(Job).where(Job.id == job_id).values(
                    status="failed", error=f"tile {frame_index}/{failed[0]} failed {settings.max_tile_attempts} times"))
                resend = False
        c.execute(update(Tile).where(*mine).values(status="queued", worker=None))
    if resend:
        from argand.worker.app import get_app

        get_app(settings).send_task(TASK_NAME, args=[job_id, frame_index, tiles], priority=0)


def run_tiles(settings: Settings, job_id: str, frame_index: int, tile_indices: list[int], worker_name: str) -> str:
    """Renders a run of tiles of one frame, skipping those done or held by
    another worker, and stopping between tiles when the job is cancelled or
    paused. Returns what happened (for logs and tests)."""
    from argand.render.frames import INTERLEAVED_CHANNELS, TileRect, render_tile_into

    url = settings.sqlalchemy_url
    eng = engine_for(url)
    now = time.time()
    with eng.begin() as c:
        status = c.execute(select(Job.status).where(Job.id == job_id)).scalar()
        if status is None:
            return "gone"
        if status in STOPPED:
            return status
        claimed = sorted(c.execute(
            update(Tile)
            .where(*_tile_key(job_id, frame_index), Tile.tile_index.in_(tile_indices), Tile.status == "queued")
            .values(status="running", worker=worker_name, started=now, attempts=Tile.attempts + 1)
            .returning(Tile.tile_index)
        ).scalars().all())
        if not claimed:
            return "taken or done"
        if (job_id, frame_index) not in _marked:
            c.execute(update(Job).where(Job.id == job_id, Job.status == "queued").values(status="running", started=now))
            c.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index, Frame.status == "queued")
                      .values(status="rendering"))
            _marked.add((job_id, frame_index))
    fplan, rects, total = _frame_plan(url, job_id, frame_index)
    # A run that holds the whole frame renders straight into the frame's
    # buffer (the EXR's layout); otherwise each tile gets a block of its own.
    whole = len(claimed) == total
    frame_px = np.empty((fplan.height, fplan.width, len(INTERLEAVED_CHANNELS)), np.float32) if whole else None
    local: dict[int, Any] = {}  # tile -> (pixels, escalations, root calls, stats): for this process's own assembly
    pending: dict[int, float] = {}
    done = 0
    last_check = last_commit = time.monotonic()
    stopped = None
    try:
        for i in claimed:
            if time.monotonic() - last_check > STOP_CHECK_S:
                with eng.connect() as c:
                    status = c.execute(select(Job.status).where(Job.id == job_id)).scalar()
                last_check = time.monotonic()
                if status is None or status in STOPPED:
                    stopped = status or "gone"
                    break
            ACTIVITY["tile"] = f"{job_id}/{frame_index}/{i}"
            x0, y0, x1, y1 = rects[i]
            if frame_px is not None:
                block, ox, oy = frame_px, x0, y0
            else:
                block, ox, oy = np.empty((y1 - y0, x1 - x0, len(INTERLEAVED_CHANNELS)), np.float32), 0, 0
            start = time.perf_counter()
            esc, calls, stats = render_tile_into(fplan, TileRect(x0, y0, x1, y1), block, ox, oy)
            pending[i] = time.perf_counter() - start
            local[i] = (block[y0:y1, x0:x1] if frame_px is not None else block, esc, calls, stats)
            if time.monotonic() - last_commit > COMMIT_INTERVAL_S:
                done, total = _complete(settings, job_id, frame_index, worker_name, pending, local)
                pending, last_commit = {}, time.monotonic()
    except BaseException:
        # A time limit or an error: keep what is written, give back the rest.
        if pending:
            done, total = _complete(settings, job_id, frame_index, worker_name, pending, local)
        _release(settings, job_id, frame_index, worker_name, [t for t in claimed if t not in local], resend=True)
        ACTIVITY["tile"] = None
        raise
    if pending and not stopped and len(local) == len(pending) == total:
        # The run rendered the whole frame: assemble from memory, then count
        # the tiles and the frame done in one transaction (no tile files).
        ACTIVITY["tile"] = None
        if _finish_whole_frame(settings, job_id, frame_index, worker_name, pending, local, frame_px):
            return "rendered"
    if pending:
        done, total = _complete(settings, job_id, frame_index, worker_name, pending, local)
    ACTIVITY["tile"] = None
    if stopped:
        _release(settings, job_id, frame_index, worker_name, [t for t in claimed if t not in local], resend=False)
        return stopped
    if done >= total:  # a whole frame with commits on the way still assembles from its own buffer
        maybe_assemble(settings, job_id, frame_index, worker_name, local,
                       frame_px if frame_px is not None and len(local) == total else None)
    return "rendered"


class _Lost(Exception):
    """Some tile of the run is no longer this worker's (the reaper gave it away)."""


def _finish_whole_frame(settings: Settings, job_id: str, frame_index: int, worker_name: str,
                        seconds: dict[int, float], local: dict[int, Any], frame_px: np.ndarray) -> bool:
    """Assembles a frame this worker rendered alone, then marks its tiles and
    the frame done in one transaction: a crash before the commit leaves the
    tiles claimed by a dead worker, and the reaper has them rendered again;
    a crash after it leaves a finished frame. Returns False (nothing
    committed; the caller goes the usual way) if any tile was taken away."""
    figures = assemble_frame(settings, job_id, frame_index, local, seconds=sum(seconds.values()), commit=False,
                             frame_px=frame_px)
    try:
        with engine_for(settings.sqlalchemy_url).begin() as c:
            won = _mark_done(c, job_id, frame_index, worker_name, seconds, "frame")
            if len(won) < len(seconds):
                raise _Lost
            n = c.execute(update(Frame).where(
                Frame.job_id == job_id, Frame.index == frame_index, Frame.status.in_(("queued", "rendering"))
            ).values(tiles_done=len(won), status="done", assembler=worker_name, figures=figures,
                     finished=time.time())).rowcount
            if n != 1:
                raise _Lost
    except _Lost:
        return False
    ACTIVITY["done"] += len(won)
    _finish_job_if_last(settings, job_id)
    return True


def run_tile(settings: Settings, job_id: str, frame_index: int, tile_index: int, worker_name: str) -> str:
    """One tile (the older message shape)."""
    return run_tiles(settings, job_id, frame_index, [tile_index], worker_name)


# ---------------------------------------------------------------------------
# Assembly
# ---------------------------------------------------------------------------


def maybe_assemble(settings: Settings, job_id: str, frame_index: int, assembler: str = "api",
                   local: dict[int, Any] | None = None, frame_px: np.ndarray | None = None) -> bool:
    """Assembles the frame if all its tiles are done and nobody else is at
    it (compare-and-set on the frame's state); the last frame also makes the
    animation and finishes the job. ``frame_px``: the whole frame, rendered
    in place by this process (every tile in ``local``)."""
    url = settings.sqlalchemy_url
    with engine_for(url).begin() as c:
        won = c.execute(update(Frame).where(
            Frame.job_id == job_id, Frame.index == frame_index, Frame.status.in_(("queued", "rendering")),
            Frame.tiles_done >= Frame.tiles_total,
        ).values(status="assembling", assembler=assembler, assembling_since=time.time())).rowcount
    if not won:
        return False
    assemble_frame(settings, job_id, frame_index, local, frame_px=frame_px)
    _finish_job_if_last(settings, job_id)
    return True


def _finish_job_if_last(settings: Settings, job_id: str) -> None:
    """When every frame is done: the animation, then the job is done."""
    url = settings.sqlalchemy_url
    with engine_for(url).connect() as c:
        remaining = c.execute(select(func.count()).select_from(Frame).where(
            Frame.job_id == job_id, Frame.status != "done")).scalar()
        status = c.execute(select(Job.status).where(Job.id == job_id)).scalar()
    if remaining == 0 and status not in ("canceled", None):
        build_animation(settings, job_id)
        with engine_for(url).begin() as c:
            c.execute(update(Job).where(Job.id == job_id, Job.status != "canceled").values(status="done", finished=time.time()))


def _legacy_tile(store: FrameStore, job_id: str, frame_index: int, tile: int) -> dict[str, np.ndarray]:
    """A tile written by an earlier version (one .npz per tile, one array per
    AOV), in the interleaved layout."""
    import io

    from argand.render.frames import interleave

    with np.load(io.BytesIO(store.read_bytes(f"{store.tile_dir(job_id, frame_index)}/{tile:05d}.npz"))) as z:
        counts = np.bincount(z["status"].astype(np.intp).ravel(), minlength=4)[:4]
        meta = np.array([*z["meta"][:2], *counts, int(np.count_nonzero(z["rgba"][..., 3] > 0))], np.int64)
        return {"px": interleave(z["rgba"], z), "meta": meta}


def assemble_frame(settings: Settings, job_id: str, frame_index: int, local: dict[int, Any] | None = None,
                   seconds: float | None = None, commit: bool = True, frame_px: np.ndarray | None = None) -> dict:
    """Tiles -> frame_NNNN.exr/.png/.json, thumbnail and GIF fragment
    (idempotent). Tiles this process rendered are taken from memory, the
    others from the store; the EXR's interleaved buffer is filled directly.
    With ``commit`` the frame is marked done and its tile files dropped.
    Returns the frame's figures."""
    from pathlib import Path

    from argand.render import gif
    from argand.render.frames import AOV_CHANNELS, INTERLEAVED_CHANNELS, FrameParams, FrameResult, frame_figures
    from argand.render.output import to_srgb8, write_frame, write_png

    t_start = time.perf_counter()
    store = store_for(settings)
    local = local or {}
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.width, Job.height, Job.tile, Job.method).where(Job.id == job_id)).one()
        sigma, delta = c.execute(select(Frame.sigma, Frame.delta).where(Frame.job_id == job_id, Frame.index == frame_index)).one()
        if seconds is None:
            seconds = c.execute(select(func.sum(Tile.seconds)).where(*_tile_key(job_id, frame_index))).scalar() or 0.0
        chunks = {} if len(local) == len(tile_rects(job.width, job.height, job.tile)) else dict(c.execute(
            select(Tile.tile_index, Tile.chunk).where(*_tile_key(job_id, frame_index))).all())
    stored: dict[int, dict[str, np.ndarray]] = {}
    for name in {chunks[i] for i in chunks if i not in local and chunks[i]}:
        stored.update(store.read_chunk(job_id, frame_index, name))
    w, h = job.width, job.height
    px = frame_px if frame_px is not None else np.empty((h, w, len(INTERLEAVED_CHANNELS)), np.float32)
    escalations = calls = 0
    stats = np.zeros(5, np.int64)
    for i, (x0, y0, x1, y1) in enumerate(tile_rects(w, h, job.tile)):
        if i in local:
            block, esc, n, st = local[i]
        else:  # another worker's tile (or one file per tile, from an earlier version)
            d = stored.get(i) or _legacy_tile(store, job_id, frame_index, i)
            block, (esc, n), st = d["px"], d["meta"][:2], d["meta"][2:7]
        if frame_px is None:
            px[y0:y1, x0:x1] = block
        escalations += int(esc)
        calls += int(n)
        stats += st
    params = FrameParams(sigma=sigma, delta=delta, width=w, height=h, method=job.method)
    result = FrameResult(params, px[..., :4], {name: px[..., 4 + k] for k, name in enumerate(AOV_CHANNELS)},
                         seconds, escalations, calls, stats=stats)
    result.figures = frame_figures(result)
    out = Path(store.job_dir(job_id))
    t_encode = time.perf_counter()
    srgb = to_srgb8(result.rgba)
    write_frame(result, out, frame_index, exr=px, srgb8=srgb, compression=settings.exr_compression)
    step = max(1, max(w, h) // 160)
    write_png(np.ascontiguousarray(srgb[::step, ::step]), out / f"thumb_{frame_index:04d}.png")
    store.write_bytes_atomic(store.path("jobs", job_id, "gif", f"{frame_index:04d}.gif"), gif.encode_frame(srgb))
    t_end = time.perf_counter()
    # Where the assembler's time went (argand bench farm reports it).
    figures = dict(result.figures, assembly_s=t_end - t_start, encode_s=t_end - t_encode)
    if commit:
        with engine_for(settings.sqlalchemy_url).begin() as c:
            c.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index)
                      .values(status="done", figures=figures, finished=time.time()))
        store.remove_tiles(job_id, frame_index)
    return figures


def build_animation(settings: Settings, job_id: str, fps: float = 8.0) -> None:
    """animation.gif, spliced from the frames' GIF fragments (no frame is
    encoded again; a fragment that is missing, from a frame assembled by an
    older version, is made from the frame's PNG)."""
    from pathlib import Path

    import OpenImageIO as oiio

    from argand.render import gif

    store = store_for(settings)
    out = Path(store.job_dir(job_id))
    with engine_for(settings.sqlalchemy_url).connect() as c:
        n = c.execute(select(func.count()).select_from(Frame).where(Frame.job_id == job_id)).scalar()
    fragments = []
    for i in range(n):
        key = store.path("jobs", job_id, "gif", f"{i:04d}.gif")
        if store.exists(key):
            fragments.append(store.read_bytes(key))
        else:
            rgb = oiio.ImageBuf(str(out / f"frame_{i:04d}.png")).get_pixels(oiio.UINT8)
            fragments.append(gif.encode_frame(rgb[..., :3]))
    store.write_bytes_atomic(store.path("jobs", job_id, "animation.gif"), gif.splice(fragments, fps=fps))


# ---------------------------------------------------------------------------
# Control and health
# ---------------------------------------------------------------------------


def set_job_status(settings: Settings, job_id: str, action: str) -> str:
    """cancel | pause | resume | retry. Returns the new status."""
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise KeyError(job_id)
        if action == "cancel":
            if job.status not in ("done",):
                job.status = "canceled"
            return job.status
        if action == "pause":
            if job.status in ("queued", "running"):
                job.status = "paused"
            return job.status
        if action in ("resume", "retry"):
            if action == "resume" and job.status != "paused":
                return job.status
            if action == "retry" and job.status not in ("failed", "canceled", "paused"):
                return job.status
            s.execute(update(Tile).where(Tile.job_id == job_id, Tile.status.in_(("running", "failed")))
                      .values(status="queued", attempts=0))
            job.status = "running" if job.started else "queued"
            job.error = None
    if action in ("resume", "retry"):
        dispatch_job(settings, job_id)
    with session_scope(settings.sqlalchemy_url) as s:
        return s.get(Job, job_id).status


def heartbeat(settings: Settings, name: str, pid: int, current_tile: str | None = None, tiles_done: int = 0) -> None:
    with session_scope(settings.sqlalchemy_url) as s:
        w = s.get(Worker, name)
        if w is None:
            s.add(Worker(name=name, host=socket.gethostname(), pid=pid, heartbeat=time.time(),
                         current_tile=current_tile, tiles_done=tiles_done))
        else:
            w.heartbeat = time.time()
            w.pid = pid
            w.current_tile = current_tile
            w.tiles_done = tiles_done


_stuck_seen: dict[str, set] = {"frames": set(), "jobs": set()}


def reap(settings: Settings) -> int:
    """Re-enqueues the work of workers that stopped sending heartbeats (a
    crashed or killed worker): the tile it was rendering, and, since it may
    also have held a prefetched message that Redis only gives back after the
    visibility timeout, every queued tile of the unfinished jobs (duplicate
    messages are no-ops: a tile is claimed by compare-and-set). A tile that
    failed too often fails its job."""
    now = time.time()
    requeue: list[str] = []
    with session_scope(settings.sqlalchemy_url) as s:
        dead = [w for w in s.scalars(select(Worker)) if now - w.heartbeat > settings.heartbeat_timeout_s]
        dead_names = {w.name for w in dead}
        for t in s.scalars(select(Tile).where(Tile.status == "running")).all():
            if t.worker in dead_names or (t.started and now - t.started > settings.tile_hard_time_limit_s * 2):
                job = s.get(Job, t.job_id)
                if t.attempts >= settings.max_tile_attempts:
                    t.status = "failed"
                    job.status = "failed"
                    job.error = f"tile {t.frame_index}/{t.tile_index} failed {t.attempts} times"
                    continue
                t.status = "queued"
                t.worker = None
        # A frame whose assembler died (or hangs) is assembled again.
        orphans = []
        for f in s.scalars(select(Frame).where(Frame.status == "assembling")).all():
            if f.assembler in dead_names or (f.assembling_since and now - f.assembling_since > settings.tile_hard_time_limit_s):
                f.status = "rendering"
                orphans.append((f.job_id, f.index))
        # A worker that died between its last completion and the assembly (or
        # between the last frame and the animation) left a frame with every
        # tile done but nobody assembling it (or a job with every frame done
        # but not finished). Seen so in two rounds in a row (so that a live
        # worker about to do it is not raced), they are finished here.
        active = select(Job.id).where(Job.status.in_(("queued", "running")))
        stuck_frames = {tuple(r) for r in s.execute(select(Frame.job_id, Frame.index).where(
            Frame.status.in_(("queued", "rendering")), Frame.tiles_done >= Frame.tiles_total, Frame.job_id.in_(active)))}
        unfinished = select(Frame.job_id).where(Frame.status != "done")
        stuck_jobs = set(s.scalars(select(Job.id).where(Job.status.in_(("queued", "running")), Job.id.not_in(unfinished),
                                                       Job.id.in_(select(Frame.job_id)))))
        orphans += sorted(stuck_frames & _stuck_seen["frames"])
        finish = sorted(stuck_jobs & _stuck_seen["jobs"])
        _stuck_seen["frames"], _stuck_seen["jobs"] = stuck_frames, stuck_jobs
        if dead:
            requeue = list(s.scalars(select(Tile.job_id).where(Tile.status == "queued", Tile.job_id.in_(active)).distinct()))
            for w in dead:
                s.delete(w)
    for job_id, index in orphans:
        maybe_assemble(settings, job_id, index)  # idempotent
    for job_id in finish:
        _finish_job_if_last(settings, job_id)
    # Work given back goes ahead of everything (the highest priority).
    return sum(dispatch_job(settings, job_id, priority=9) for job_id in requeue)


def eta_seconds(job: Job, done: int, total: int) -> float | None:
    if not job.started or done == 0 or done >= total:
        return 0.0 if done >= total and total else None
    elapsed = time.time() - job.started
    return elapsed / done * (total - done)


def frames_of(deltas_spec: Any) -> list[float]:
    """A job's deltas: a list, or {start, stop, count} swept as `argand
    render --deltas` sweeps it (the same values to the last bit)."""
    from argand.render.frames import delta_sweep

    if isinstance(deltas_spec, dict):
        return delta_sweep(float(deltas_spec["start"]), float(deltas_spec["stop"]), int(deltas_spec["count"]))
    return [float(d) for d in deltas_spec]
