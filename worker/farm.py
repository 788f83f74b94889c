"""The farm's work model as plain functions (tasks and routes stay thin):
job -> frames (one per (sigma, delta)) -> tiles.

* The database is the source of truth; a tile is rendered by whichever
  worker takes its message, written atomically to the store, and counted
  once (a compare-and-set on its row). A redelivered tile that is already
  done is a no-op.
* The tile that completes a frame assembles it (EXR with all AOVs, PNG,
  thumbnail); the frame that completes the job builds the animation.
  Assembly is idempotent.
* Tiles of cancelled or paused jobs are not rendered. A reaper re-enqueues
  tiles whose worker stopped sending heartbeats.
"""

from __future__ import annotations

import math
import socket
import time
import uuid
from typing import Any

import numpy as np
from sqlalchemy import func, select, update

from argand.api.db import Frame, Job, Tile, Worker, session_scope
from argand.api.settings import Settings
from argand.worker.store import FrameStore

TASK_NAME = "argand.render_tile"


def store_for(settings: Settings) -> FrameStore:
    return FrameStore(str(settings.data_path / "store"))


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
    return [(x, y, min(x + tile, width), min(y + tile, height)) for y in range(0, height, tile) for x in range(0, width, tile)]


def create_job(settings: Settings, scene_name: str, scene: dict, sigma: float, deltas: list[float], width: int,
               height: int, tile: int, priority: int, method: str = "auto") -> str:
    job_id = uuid.uuid4().hex[:12]
    n_tiles = len(tile_rects(width, height, tile))
    with session_scope(settings.sqlalchemy_url) as s:
        job = Job(id=job_id, status="queued", scene_name=scene_name, scene=scene, sigma=sigma, width=width,
                  height=height, tile=tile, method=method, priority=priority)
        s.add(job)
        for i, d in enumerate(deltas):
            s.add(Frame(job_id=job_id, index=i, sigma=sigma, delta=d, status="queued", tiles_total=n_tiles))
            for t in range(n_tiles):
                s.add(Tile(job_id=job_id, frame_index=i, tile_index=t, status="queued"))
    dispatch_job(settings, job_id)
    return job_id


def dispatch_job(settings: Settings, job_id: str, only_status: tuple[str, ...] = ("queued",)) -> int:
    """Sends a message for every tile of the job in one of the given states,
    frames in preview order. Returns the number sent."""
    from argand.worker.app import get_app

    app = get_app(settings)
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            return 0
        priority = job.priority
        tiles = s.execute(
            select(Tile.frame_index, Tile.tile_index).where(Tile.job_id == job_id, Tile.status.in_(only_status))
        ).all()
        n_frames = len(job.frames)
    rank = {f: i for i, f in enumerate(preview_order(n_frames))}
    tiles.sort(key=lambda t: (rank[t[0]], t[1]))
    for frame_index, tile_index in tiles:
        app.send_task(TASK_NAME, args=[job_id, frame_index, tile_index], priority=max(0, min(9, 9 - priority)))
    return len(tiles)


# ---------------------------------------------------------------------------
# The tile task's body
# ---------------------------------------------------------------------------

_plan_cache: dict[tuple[str, int], Any] = {}
_marked: set[tuple[str, int]] = set()  # (job, frame) this process already marked as rendering
#: What this worker process is doing; its heartbeat thread reports it (so a
#: tile costs no extra database writes for bookkeeping).
ACTIVITY: dict[str, Any] = {"tile": None, "done": 0}


def _frame_plan(url: str, job_id: str, frame_index: int):
    """The frame's C++ plan, built once per worker process and frame."""
    from argand.render.convert import to_core_scene
    from argand.render.frames import FrameParams, plan
    from argand.scene import scene_from_dict

    key = (job_id, frame_index)
    if key not in _plan_cache:
        if len(_plan_cache) > 16:
            _plan_cache.clear()
        with session_scope(url) as s:
            job = s.get(Job, job_id)
            frame = s.scalar(select(Frame).where(Frame.job_id == job_id, Frame.index == frame_index))
            params = FrameParams(sigma=frame.sigma, delta=frame.delta, width=job.width, height=job.height, method=job.method)
            scene = scene_from_dict(job.scene)
            info = (params, tile_rects(job.width, job.height, job.tile), frame.tiles_total)
        _plan_cache[key] = (plan(to_core_scene(scene), params), *info)
    return _plan_cache[key]


def run_tile(settings: Settings, job_id: str, frame_index: int, tile_index: int, worker_name: str) -> str:
    """Renders one tile unless it is done, or its job is cancelled or paused.
    Returns what happened (for logs and tests). Two short transactions: the
    claim, and the completion with the frame's count."""
    from argand.render.frames import TileRect, render_tile_planned

    url = settings.sqlalchemy_url
    now = time.time()
    with session_scope(url) as s:
        status = s.scalar(select(Job.status).where(Job.id == job_id))
        if status is None:
            return "gone"
        if status in ("canceled", "paused", "failed"):
            return status
        # Claim the tile (compare-and-set): a duplicate message for a tile
        # that another worker holds, or that is done, is a no-op.
        claimed = s.execute(
            update(Tile)
            .where(Tile.job_id == job_id, Tile.frame_index == frame_index, Tile.tile_index == tile_index,
                   Tile.status == "queued")
            .values(status="running", worker=worker_name, started=now, attempts=Tile.attempts + 1)
        ).rowcount
        if not claimed:
            return "taken or done"
        if (job_id, frame_index) not in _marked:
            s.execute(update(Job).where(Job.id == job_id, Job.status == "queued").values(status="running", started=now))
            s.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index, Frame.status == "queued")
                      .values(status="rendering"))
            _marked.add((job_id, frame_index))
    ACTIVITY["tile"] = f"{job_id}/{frame_index}/{tile_index}"
    fplan, _params, rects, total = _frame_plan(url, job_id, frame_index)
    start = time.perf_counter()
    t = render_tile_planned(fplan, TileRect(*rects[tile_index]))
    seconds = time.perf_counter() - start
    store_for(settings).write_tile(job_id, frame_index, tile_index, {
        "rgba": t.rgba, **t.aovs, "meta": np.array([t.escalations, t.root_calls], dtype=np.int64)})
    with session_scope(url) as s:
        # Count the tile once: only the first completion flips its state.
        won = s.execute(
            update(Tile)
            .where(Tile.job_id == job_id, Tile.frame_index == frame_index, Tile.tile_index == tile_index, Tile.status != "done")
            .values(status="done", seconds=seconds, renders=Tile.renders + 1)
        ).rowcount
        done = s.scalar(select(func.count()).select_from(Tile).where(
            Tile.job_id == job_id, Tile.frame_index == frame_index, Tile.status == "done")) if won else 0
    ACTIVITY["tile"] = None
    ACTIVITY["done"] += 1
    if not won:
        return "already done"
    if done >= total:
        maybe_assemble(settings, job_id, frame_index, worker_name)
    return "rendered"


def maybe_assemble(settings: Settings, job_id: str, frame_index: int, assembler: str = "api") -> bool:
    url = settings.sqlalchemy_url
    with session_scope(url) as s:
        frame = s.scalar(select(Frame).where(Frame.job_id == job_id, Frame.index == frame_index))
        done = s.scalar(select(func.count()).select_from(Tile).where(
            Tile.job_id == job_id, Tile.frame_index == frame_index, Tile.status == "done"))
        if frame is None or done < frame.tiles_total:
            return False
        # Elect one assembler (compare-and-set); assembly is idempotent anyway.
        won = s.execute(update(Frame).where(Frame.id == frame.id, Frame.status.in_(("queued", "rendering")))
                        .values(status="assembling", assembler=assembler, assembling_since=time.time())).rowcount
    if not won:
        return False
    assemble_frame(settings, job_id, frame_index)
    with session_scope(url) as s:
        job = s.get(Job, job_id)
        remaining = s.scalar(select(func.count()).select_from(Frame).where(Frame.job_id == job_id, Frame.status != "done"))
        if remaining == 0 and job.status not in ("canceled",):
            build_animation(settings, job_id)
            job.status = "done"
            job.finished = time.time()
    return True


def assemble_frame(settings: Settings, job_id: str, frame_index: int) -> None:
    """Tiles -> frame_NNNN.exr/.png/.json + thumbnail (idempotent)."""
    from pathlib import Path

    from argand.render.frames import FrameParams, FrameResult, frame_figures
    from argand.render.output import to_srgb8, write_frame, write_png

    store = store_for(settings)
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        frame = s.scalar(select(Frame).where(Frame.job_id == job_id, Frame.index == frame_index))
        tiles = s.scalars(select(Tile).where(Tile.job_id == job_id, Tile.frame_index == frame_index)).all()
        w, h, size, method = job.width, job.height, job.tile, job.method
        sigma, delta = frame.sigma, frame.delta
        seconds = sum(t.seconds or 0.0 for t in tiles)
    rgba = np.zeros((h, w, 4), np.float32)
    aovs = {"Z": np.zeros((h, w), np.float32), "arg": np.zeros((h, w), np.float32), "re": np.zeros((h, w), np.float32),
            "im": np.zeros((h, w), np.float32), "count": np.zeros((h, w), np.int32), "status": np.zeros((h, w), np.uint8)}
    escalations = calls = 0
    for i, (x0, y0, x1, y1) in enumerate(tile_rects(w, h, size)):
        t = store.read_tile(job_id, frame_index, i)
        rgba[y0:y1, x0:x1] = t["rgba"]
        for k in aovs:
            aovs[k][y0:y1, x0:x1] = t[k]
        escalations += int(t["meta"][0])
        calls += int(t["meta"][1])
    params = FrameParams(sigma=sigma, delta=delta, width=w, height=h, method=method)
    result = FrameResult(params, rgba, aovs, seconds, escalations, calls)
    result.figures = frame_figures(result)
    out = Path(store.job_dir(job_id))
    write_frame(result, out, frame_index)
    png = to_srgb8(rgba)
    step = max(1, max(w, h) // 160)
    write_png(np.ascontiguousarray(png[::step, ::step]), out / f"thumb_{frame_index:04d}.png")
    with session_scope(settings.sqlalchemy_url) as s:
        s.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index)
                  .values(status="done", figures=result.figures))


def build_animation(settings: Settings, job_id: str) -> None:
    from pathlib import Path

    import OpenImageIO as oiio

    from argand.render.output import write_gif

    out = Path(store_for(settings).job_dir(job_id))
    with session_scope(settings.sqlalchemy_url) as s:
        n = len(s.get(Job, job_id).frames)
    frames = []
    for i in range(n):
        buf = oiio.ImageBuf(str(out / f"frame_{i:04d}.png"))
        frames.append(buf.get_pixels(oiio.UINT8))
    write_gif(frames, out / "animation.gif")


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


def reap(settings: Settings) -> int:
    """Re-enqueues the work of workers that stopped sending heartbeats (a
    crashed or killed worker): the tile it was rendering, and, since it may
    also have held a prefetched message that Redis only gives back after the
    visibility timeout, every queued tile of the unfinished jobs (duplicate
    messages are no-ops: a tile is claimed by compare-and-set). A tile that
    failed too often fails its job."""
    now = time.time()
    requeue: list[tuple[str, int, int]] = []
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
        if dead:
            active = select(Job.id).where(Job.status.in_(("queued", "running")))
            requeue = [tuple(r) for r in s.execute(
                select(Tile.job_id, Tile.frame_index, Tile.tile_index).where(Tile.status == "queued", Tile.job_id.in_(active))
            ).all()]
            for w in dead:
                s.delete(w)
    for job_id, index in orphans:
        maybe_assemble(settings, job_id, index)  # idempotent
    if requeue:
        from argand.worker.app import get_app

        app = get_app(settings)
        for job_id, f, i in requeue:
            app.send_task(TASK_NAME, args=[job_id, f, i], priority=0)
    return len(requeue)


def eta_seconds(job: Job, done: int, total: int) -> float | None:
    if not job.started or done == 0 or done >= total:
        return 0.0 if done >= total and total else None
    elapsed = time.time() - job.started
    return elapsed / done * (total - done)


def frames_of(deltas_spec: Any) -> list[float]:
    if isinstance(deltas_spec, dict):
        start, stop, count = float(deltas_spec["start"]), float(deltas_spec["stop"]), int(deltas_spec["count"])
        if count == 1:
            return [start]
        return [start + (stop - start) * i / (count - 1) for i in range(count)]
    return [float(d) for d in deltas_spec]


def _isfinite(values: list[float]) -> bool:
    return all(math.isfinite(v) for v in values)
