"""The body of a worker's task: a run of tiles of one frame, and the same
tiles of the job's next frames where they are queued (claim_siblings).

* The database is the source of truth; a tile is rendered by whichever
  worker claims its row (compare-and-set), written atomically to the store,
  and counted once (a compare-and-set on its row, and the frame's counter in
  the same transaction). A redelivered tile that is done is a no-op.
* Completions are committed every ``COMMIT_INTERVAL_S`` within a run, so
  progress is smooth and a crash loses at most that much work.
* A job's frames share their rays: a run renders a tile of all the frames
  it holds in one pass (argand.render.frames.render_tile_bands_into: the
  primary roots solved once, each frame's pixels the bits it gets alone),
  straight into the EXR's interleaved layout; a run that holds a whole frame
  renders into the frame's buffer and assembles it from memory.
* A run stops between tiles (checked every ``STOP_CHECK_S``) when its job is
  cancelled or paused, and gives back what it did not render.
"""

from __future__ import annotations

import logging
import time
import uuid
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sqlalchemy import select, tuple_, update
from sqlalchemy.exc import NoResultFound

from argand.farm import assembly
from argand.farm.database import clock, engine_for
from argand.farm.layout import WINDOW_PREFIX
from argand.farm.models import Frame, Job, Tile
from argand.farm.planning import Rect, core_scene_of, frame_plan, samples_of, tile_rects
from argand.farm.outbox import add_runs, try_drain
from argand.farm.settings import Settings
from argand.farm.states import ACTIVE, FRAME, JOB, STOPPED, TILE
from argand.farm.store import is_store_error, store_for
from argand.render.options import EngineOptions
from argand.render.field import stored_tape
from argand.render.frames import INTERLEAVED_CHANNELS, TileRect, render_tile_bands_into

log = logging.getLogger(__name__)

#: Within a run of tiles: how often to look for a cancel or pause, and how
#: often to commit the tiles finished so far.
STOP_CHECK_S = 0.05
COMMIT_INTERVAL_S = 0.5

#: What this worker process is doing; its heartbeat thread reports it (so a
#: tile costs no extra database writes for bookkeeping), and its watchdog
#: (argand.worker.watchdog) reads the run's hard deadline (time.monotonic()).
ACTIVITY: dict[str, Any] = {"tile": None, "done": 0, "hard_at": None, "run": None, "writing": False}

#: Why a run stopped before its end because of its soft time limit.
SOFT_LIMIT = "soft time limit"

#: Frames' plans kept per worker process (a run's window of frames: 32 by default).
PLAN_CACHE = 128
_plan_cache: dict[tuple[str, int], Any] = {}
_job_cache: dict[str, Any] = {}
_marked: set[tuple[str, int]] = set()  # (job, frame) this process already marked as rendering


def _frame_plan(url: str, job_id: str, frame_index: int):
    """The frame's C++ plan, tile rectangles and tile count, built once per
    worker process and frame (the job's scene is converted once per job),
    with the job's engine options (Job.engine), not this worker's."""
    key = (job_id, frame_index)
    if key not in _plan_cache:
        if len(_plan_cache) > PLAN_CACHE:
            _plan_cache.clear()
        if job_id not in _job_cache or frame_index not in _job_cache[job_id][-1]:
            with engine_for(url).connect() as c:
                if len(_job_cache) > 8:
                    _job_cache.clear()
                job = c.execute(select(Job.scene, Job.width, Job.height, Job.tile, Job.method, Job.engine)
                                .where(Job.id == job_id)).one()
                # Every frame's band at once (a frame's σ, δ and tile count
                # never change): the window's other frames take theirs here.
                frames = {f.index: (f.sigma, f.delta, f.tiles_total) for f in c.execute(
                    select(Frame.index, Frame.sigma, Frame.delta, Frame.tiles_total).where(Frame.job_id == job_id))}
                if frame_index not in frames:
                    raise NoResultFound(f"job {job_id} has no frame {frame_index}")
                _job_cache[job_id] = (core_scene_of(job.scene), job.width, job.height, job.method,
                                      samples_of(job.scene), EngineOptions.from_stored(job.engine),
                                      tile_rects(job.width, job.height, job.tile), frames)
        core_scene, w, h, method, samples, engine, rects, frames = _job_cache[job_id]
        sigma, delta, tiles_total = frames[frame_index]
        _plan_cache[key] = (frame_plan(core_scene, sigma, delta, w, h, method, samples, engine), rects, tiles_total)
    return _plan_cache[key]


def tile_key(job_id: str, frame_index: int):
    return (Tile.job_id == job_id, Tile.frame_index == frame_index)


@dataclass
class TileRun:
    """One message's tiles, as this worker renders them."""

    settings: Settings
    job_id: str
    frame_index: int
    worker: str
    claimed: list[int]
    plan: Any = None
    rects: list[Rect] = field(default_factory=list)
    total: int = 0
    #: The whole frame's buffer when the run holds every tile of the frame.
    frame_px: np.ndarray | None = None
    #: tile -> (pixels, escalations, root calls, stats), for this process's own assembly.
    local: dict[int, Any] = field(default_factory=dict)
    #: tile -> render seconds, rendered but not yet committed.
    pending: dict[int, float] = field(default_factory=dict)
    done: int = 0
    #: time.monotonic() after which no further tile is started (the soft time limit).
    soft_at: float = float("inf")
    #: Its frame's assembly was tried with the window's (assembly.maybe_assemble_many).
    assembled: bool = False

    def unrendered(self) -> list[int]:
        return [t for t in self.claimed if t not in self.local]

    def commit(self) -> None:
        if self.pending:
            self.done, self.total = _complete(self)
            self.pending = {}


def claim(settings: Settings, job_id: str, frame_index: int, tile_indices: list[int], worker: str,
          sent_at: float | None) -> tuple[str | None, list[int]]:
    """Claims the queued tiles among ``tile_indices`` (compare-and-set) and
    marks the job and frame started. Returns (why nothing was claimed or
    None, the claimed tiles in order)."""
    with engine_for(settings.sqlalchemy_url).begin() as c:
        now = clock(c)  # the reaper compares a tile's start with its own reading of this clock
        status = c.execute(select(Job.status).where(Job.id == job_id)).scalar()
        if status is None or status in STOPPED:
            return status or "gone", []
        claimed = sorted(c.execute(
            update(Tile)
            .where(*tile_key(job_id, frame_index), Tile.tile_index.in_(tile_indices),
                   Tile.status.in_(TILE.sources("running")))
            .values(status="running", worker=worker, started=now, attempts=Tile.attempts + 1,
                    waited=None if sent_at is None else max(0.0, now - sent_at))
            .returning(Tile.tile_index)
        ).scalars().all())
        if not claimed:
            return "taken or done", []
        if (job_id, frame_index) not in _marked:
            c.execute(update(Job).where(Job.id == job_id, Job.status == JOB.step("queued", "running"))
                      .values(status="running", started=now))
            c.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index,
                                          Frame.status == FRAME.step("queued", "rendering")).values(status="rendering"))
            _marked.add((job_id, frame_index))
    return None, claimed


def claim_siblings(settings: Settings, job_id: str, frame_index: int, tiles: list[int], worker: str,
                   sent_at: float | None = None) -> dict[int, list[int]]:
    """The same tiles of the job's next frames (up to settings.run_bands
    frames in all, the run's own included), claimed by compare-and-set where
    they are queued: every frame of a job shares its rays, so one pass
    solves their primary roots once for all of them (render_tile_bands).
    The messages of those frames' tiles then find them taken or done. Their
    wait in the queue is counted from ``sent_at``, the run's own message's
    (a job's messages are sent together). Returns {frame: claimed tiles}."""
    if settings.run_bands <= 1 or not tiles:
        return {}
    with engine_for(settings.sqlalchemy_url).begin() as c:
        now = clock(c)  # the reaper compares a tile's start with its own reading of this clock
        # (A job's frames are numbered 0..n-1: the next ones are a range.)
        rows = c.execute(
            update(Tile)
            .where(Tile.job_id == job_id, Tile.frame_index > frame_index,
                   Tile.frame_index < frame_index + settings.run_bands, Tile.tile_index.in_(tiles),
                   Tile.status.in_(TILE.sources("running")))
            .values(status="running", worker=worker, started=now, attempts=Tile.attempts + 1,
                    waited=None if sent_at is None else max(0.0, now - sent_at))
            .returning(Tile.frame_index, Tile.tile_index)
        ).all()
        siblings: dict[int, list[int]] = {}
        for f, i in rows:
            siblings.setdefault(f, []).append(i)
        for f in siblings:
            siblings[f].sort()
        unmarked = [f for f in siblings if (job_id, f) not in _marked]
        if unmarked:  # (one statement for the window's frames, not one each)
            c.execute(update(Frame).where(Frame.job_id == job_id, Frame.index.in_(unmarked),
                                          Frame.status == FRAME.step("queued", "rendering")).values(status="rendering"))
            _marked.update((job_id, f) for f in unmarked)
    return siblings


def _job_status(settings: Settings, job_id: str) -> str | None:
    with engine_for(settings.sqlalchemy_url).connect() as c:
        return c.execute(select(Job.status).where(Job.id == job_id)).scalar()


def _render_claimed(runs: list[TileRun]) -> str | None:
    """Renders the runs' tiles (the first run's, and the same tiles of its
    sibling frames: one render_tile_bands pass a tile), committing on the
    way. Returns why it stopped early (the job's state: stopped, or done by
    other workers while this one was frozen or cut off; or "gone"), or None."""
    run = runs[0]
    channels = len(INTERLEAVED_CHANNELS)
    keep_figures_only = run.settings.files_on_request
    held = [set(r.claimed) for r in runs]
    last_check = last_commit = time.monotonic()
    for n, i in enumerate(run.claimed):
        if n and time.monotonic() > run.soft_at:
            return SOFT_LIMIT
        if time.monotonic() - last_check > STOP_CHECK_S:
            status = _job_status(run.settings, run.job_id)
            last_check = time.monotonic()
            if status not in ACTIVE:
                return status or "gone"
        ACTIVITY["tile"] = f"{run.job_id}/{run.frame_index}/{i}"
        group = [r for r, tiles in zip(runs, held) if i in tiles]
        x0, y0, x1, y1 = run.rects[i]
        # (files_on_request: the frames' figures only; their pixels are
        # decided again from the root field when a file is asked for.)
        outs = [None if keep_figures_only else (r.frame_px, x0, y0) if r.frame_px is not None else
                (np.empty((y1 - y0, x1 - x0, channels), np.float32), 0, 0) for r in group]
        start = time.perf_counter()
        store = store_for(run.settings)
        field_path = store.job(run.job_id).field_tile(i)
        tape: list | None = None if field_path.exists() else []
        figures = render_tile_bands_into([r.plan for r in group], TileRect(x0, y0, x1, y1), outs, record=tape)
        seconds = (time.perf_counter() - start) / len(group)
        if tape:
            _keep_field(run, store, field_path, tape[0])
        for r, out, (esc, calls, stats, levels) in zip(group, outs, figures):
            r.pending[i] = seconds
            block = None if out is None else out[0][y0:y1, x0:x1] if r.frame_px is not None else out[0]
            r.local[i] = (block, esc, calls, stats, levels)
        if time.monotonic() - last_commit > COMMIT_INTERVAL_S:
            _commit_all(runs)
            last_commit = time.monotonic()
    return None


def _keep_field(run: TileRun, store, path, tape: bytes) -> None:
    """Stores a tile's root field (the first run to render the tile writes
    it; the band routes decide any band from it). The field only spares the
    band routes a solve: a store that refuses it loses nothing (the routes
    solve the tile again), so its error does not stop the job."""
    try:
        store.prepare(path)
        store.write_atomic(path, stored_tape(tape))
    except OSError as exc:
        log.warning("job %s: tile %s's root field not kept (%s)", run.job_id, path.name, exc)


def run_tiles(settings: Settings, job_id: str, frame_index: int, tile_indices: list[int], worker: str,
              sent_at: float | None = None) -> str:
    """Renders a run of tiles of one frame, skipping those done or held by
    another worker, and stopping between tiles when the job is cancelled or
    paused. Returns what happened (for logs and tests).

    Time limits (the solo pool does not enforce Celery's): past
    ``tile_soft_time_limit_s`` the run starts no further tile and gives the
    rest back (not counted as an attempt); past ``tile_hard_time_limit_s``
    the worker's watchdog ends the process (argand.worker.watchdog), its
    tiles staying claimed until the reaper sees its heartbeats stop."""
    started = time.monotonic()
    why, claimed = claim(settings, job_id, frame_index, tile_indices, worker, sent_at)
    if why:
        return why
    siblings = claim_siblings(settings, job_id, frame_index, claimed, worker, sent_at)
    ACTIVITY["run"] = (job_id, frame_index, claimed, worker)
    ACTIVITY["hard_at"] = started + settings.tile_hard_time_limit_s
    try:
        return _run_claimed(settings, job_id, frame_index, worker, claimed, started, siblings)
    finally:
        ACTIVITY["hard_at"] = ACTIVITY["run"] = None


def _run_claimed(settings: Settings, job_id: str, frame_index: int, worker: str, claimed: list[int],
                 started: float, siblings: dict[int, list[int]] | None = None) -> str:
    held = [(frame_index, claimed), *sorted((siblings or {}).items())]
    try:
        runs = [_new_run(settings, job_id, f, worker, tiles, started) for f, tiles in held]
    except NoResultFound:  # the job was deleted since the claim: its tiles went with it
        return _gone(settings, job_id)
    except BaseException as exc:
        # A frame that cannot be planned: its tiles go back (and after the
        # attempts, fail the job with the reason), never stay "running".
        for f, tiles in held:
            release(settings, job_id, f, worker, tiles, resend=True, reason=_reason(exc))
        raise
    try:
        stopped = _render_claimed(runs)
        if len(runs) > 1:
            # The window's frames together: one transaction for their tiles,
            # one election of their assemblers (a whole frame rendered here
            # is left to _finish_run, which commits it with its assembly).
            _commit_all([r for r in runs if not _whole_frame_here(r, stopped)])
            ready = [r for r in runs if not stopped and not r.pending and r.local and r.done >= r.total]
            assembly.maybe_assemble_many(runs[0].settings, runs[0].job_id,
                                         [(r.frame_index, r.local) for r in ready], runs[0].worker)
            for r in ready:
                r.assembled = True  # (elected or not: another process assembles it)
        return [_finish_run(run, stopped) for run in runs][0]
    except (_Gone, NoResultFound):
        return _gone(settings, job_id)
    except BaseException as exc:
        # An error: keep what is written, give back the rest (after the
        # attempts, the job fails); a store that refuses writes stops the job.
        for run in runs:
            try:
                run.commit()
            except Exception:  # the store is what failed: the pending tiles go back too
                pass
        if is_store_error(exc):
            stop_for_store(settings, job_id, worker, exc)
        else:
            for run in runs:
                release(settings, job_id, run.frame_index, worker, run.claimed, resend=True, reason=_reason(exc))
        raise
    finally:
        ACTIVITY["tile"] = None


def _new_run(settings: Settings, job_id: str, frame_index: int, worker: str, claimed: list[int],
             started: float) -> TileRun:
    fplan, rects, total = _frame_plan(settings.sqlalchemy_url, job_id, frame_index)
    run = TileRun(settings, job_id, frame_index, worker, claimed, fplan, rects, total,
                  soft_at=started + settings.tile_soft_time_limit_s)
    # A run that holds the whole frame renders straight into the frame's
    # buffer (the EXR's layout); otherwise each tile gets a block of its own
    # (with files_on_request, neither: the tiles' figures only).
    if len(claimed) == total and not settings.files_on_request:
        run.frame_px = np.empty((fplan.height, fplan.width, len(INTERLEAVED_CHANNELS)), np.float32)
    return run


class _Gone(Exception):
    """The run's job was deleted while it ran."""


def _gone(settings: Settings, job_id: str) -> str:
    """A run whose job was deleted under it: whatever it wrote into the
    store since (a chunk, a frame's files) is removed with the job's folder,
    if the job's row is indeed gone."""
    if _job_status(settings, job_id) is None:
        store_for(settings).remove_job(job_id)
    return "gone"


def stop_for_store(settings: Settings, job_id: str, worker: str, exc: BaseException) -> None:
    """A write to the store failed (full, read-only, refused): the job fails
    at once with the reason, the tiles this worker held go back to the
    queue without counting an attempt, and a frame it was assembling goes
    back to rendering. Written files are whole or absent (atomic renames),
    so a retry, once the store is fixed, takes the job up where it stopped."""
    reason = f"the store cannot be written ({_reason(exc)}); free space or fix {settings.store_path}, then retry the job"
    with engine_for(settings.sqlalchemy_url).begin() as c:
        c.execute(update(Job).where(Job.id == job_id, Job.status.in_(JOB.sources("failed")))
                  .values(status="failed", error=reason[:600]))
        c.execute(update(Tile).where(Tile.job_id == job_id, Tile.status == "running", Tile.worker == worker)
                  .values(status=TILE.check("running", "queued"), worker=None, error=reason[:600],
                          attempts=Tile.attempts - 1))
        c.execute(update(Frame).where(Frame.job_id == job_id, Frame.assembler == worker,
                                      Frame.status == FRAME.step("assembling", "rendering")).values(status="rendering"))


def _finish_run(run: TileRun, stopped: str | None) -> str:
    if run.pending and not stopped and len(run.local) == len(run.pending) == run.total:
        # The run rendered the whole frame: assemble from memory, then count
        # the tiles and the frame done in one transaction (no tile files).
        if _finish_whole_frame(run):
            return "rendered"
    run.commit()
    if stopped == SOFT_LIMIT:
        release(run.settings, run.job_id, run.frame_index, run.worker, run.unrendered(), resend=True, untried=True,
                reason=f"TimeLimitExceeded: the run of {len(run.claimed)} tiles passed the soft time limit of "
                       f"{run.settings.tile_soft_time_limit_s} s after {len(run.local)}; the rest was given back")
        return stopped
    if stopped:
        release(run.settings, run.job_id, run.frame_index, run.worker, run.unrendered(), resend=False)
        return stopped
    if run.done >= run.total and not run.assembled:  # a whole frame with commits on the way still assembles from its own buffer
        whole = run.frame_px if run.frame_px is not None and len(run.local) == run.total else None
        assembly.maybe_assemble(run.settings, run.job_id, run.frame_index, run.worker, run.local, whole)
    return "rendered"


def _tile_arrays(t: tuple[np.ndarray | None, int, int, np.ndarray, np.ndarray]) -> dict[str, np.ndarray]:
    """A tile as stored: its pixels (unless files_on_request), meta =
    [escalations, root calls, pixels per status code, hits], and its pixels
    per ladder level."""
    block, esc, calls, stats, levels = t
    out = {"meta": np.array([esc, calls, *stats], dtype=np.int64), "levels": np.asarray(levels, np.int64)}
    if block is not None:
        out["px"] = np.ascontiguousarray(block)
    return out


def _window_figures(pending: list[TileRun]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The runs' pending figures-only tiles as a stacked window
    (FrameStore.write_window_stacked): their (frame, tile) rows, and each of
    _tile_arrays' arrays stacked in that order, made at once (a window holds
    some 200 tiles)."""
    keys = np.array([(r.frame_index, i) for r in pending for i in r.pending], np.int64).reshape(-1, 2)
    local = [r.local[i] for r in pending for i in r.pending]
    stats = np.stack([t[3] for t in local]).astype(np.int64, copy=False)
    meta = np.empty((len(local), 2 + stats.shape[1]), np.int64)
    meta[:, 0] = [t[1] for t in local]
    meta[:, 1] = [t[2] for t in local]
    meta[:, 2:] = stats
    levels = np.stack([np.asarray(t[4], np.int64) for t in local])
    return keys, {"meta": meta, "levels": levels}


def _still_held(run: TileRun, tiles) -> set[int]:
    """Those of ``tiles`` that this worker still holds (a tile the reaper gave
    to another worker while this one was frozen or cut off is theirs)."""
    with engine_for(run.settings.sqlalchemy_url).connect() as c:
        return set(c.execute(select(Tile.tile_index).where(
            *tile_key(run.job_id, run.frame_index), Tile.tile_index.in_(list(tiles)), Tile.status == "running",
            Tile.worker == run.worker)).scalars())


def _complete(run: TileRun) -> tuple[int, int]:
    """Writes the run's pending tiles that this worker still holds to the
    store (one chunk file), then marks them done (those it still holds then)
    and adds them to the frame's counter, in one transaction. A stale worker
    writes nothing into a job that went on without it; a chunk that lost the
    race between the check and the commit is removed. Returns (frame's tiles
    done, in all); raises _Gone when the job was deleted."""
    held = _still_held(run, run.pending)
    run.pending = {i: s for i, s in run.pending.items() if i in held}
    store = store_for(run.settings)
    chunk = f"{min(run.pending):05d}-{uuid.uuid4().hex[:10]}" if run.pending else None
    ACTIVITY["writing"] = True  # the watchdog does not end the process between the write and its outcome
    try:
        if chunk:
            store.write_chunk(run.job_id, run.frame_index, chunk, {i: _tile_arrays(run.local[i]) for i in run.pending})
        with engine_for(run.settings.sqlalchemy_url).begin() as c:
            won = _mark_done(c, run, chunk) if chunk else []
            q = update(Frame).where(Frame.job_id == run.job_id, Frame.index == run.frame_index)
            row = c.execute(q.values(tiles_done=Frame.tiles_done + len(won))
                            .returning(Frame.tiles_done, Frame.tiles_total)).one_or_none()
        if chunk and not won:
            store.discard_chunk(run.job_id, run.frame_index, chunk)
    finally:
        ACTIVITY["writing"] = False
    if row is None:
        raise _Gone(run.job_id)
    ACTIVITY["done"] += len(won)
    return row.tiles_done, row.tiles_total


def _whole_frame_here(run: TileRun, stopped: str | None) -> bool:
    """The run rendered its whole frame in one go (nothing committed yet):
    _finish_run assembles it from memory and commits tiles and frame together."""
    return bool(run.pending) and not stopped and len(run.local) == len(run.pending) == run.total


def _commit_all(runs: list[TileRun]) -> None:
    """_complete for several runs of one job (a window's frames, the same
    tiles) at once: one query for the tiles this worker still holds, one
    window chunk for their figures (a chunk file per frame where the tiles
    keep pixels), and one transaction that marks them done and adds them to
    their frames' counters; a chunk that lost its race is removed. Raises
    _Gone when the job was deleted."""
    pending = [r for r in runs if r.pending]
    if not pending:
        return
    if len(pending) == 1:
        pending[0].commit()
        return
    first = pending[0]
    settings, job_id, worker = first.settings, first.job_id, first.worker
    with engine_for(settings.sqlalchemy_url).connect() as c:
        held = set(map(tuple, c.execute(select(Tile.frame_index, Tile.tile_index).where(
            Tile.job_id == job_id, Tile.frame_index.in_([r.frame_index for r in pending]), Tile.status == "running",
            Tile.worker == worker)).all()))
    for r in pending:
        r.pending = {i: sec for i, sec in r.pending.items() if (r.frame_index, i) in held}
    store = store_for(settings)
    # One chunk name for the window, one statement for every tile, one per
    # distinct count for the frames. Tiles without pixels (files on
    # request: their figures only) go into one window chunk for all the
    # frames; tiles with pixels into a file in each frame's folder, which
    # goes once that frame is assembled.
    name = f"{min(min(r.pending) for r in pending if r.pending):05d}-{uuid.uuid4().hex[:10]}" \
        if any(r.pending for r in pending) else None
    window = name is not None and all(r.local[i][0] is None for r in pending for i in r.pending)
    if window:
        name = WINDOW_PREFIX + name
    ACTIVITY["writing"] = True  # the watchdog does not end the process between the writes and their outcome
    try:
        if window:
            store.write_window_stacked(job_id, name, *_window_figures(pending))
        else:
            for r in pending:
                if r.pending:
                    store.write_chunk(job_id, r.frame_index, name, {i: _tile_arrays(r.local[i]) for i in r.pending})
        with engine_for(settings.sqlalchemy_url).begin() as c:
            won, rows = _mark_window_done(c, pending, name)
        if window:
            if not any(won.values()):  # (a frame that won some tile reads its part)
                store.discard_chunk(job_id, pending[0].frame_index, name)
        else:
            for r in pending:
                if r.pending and not won[r.frame_index]:
                    store.discard_chunk(job_id, r.frame_index, name)
    finally:
        ACTIVITY["writing"] = False
    for r in pending:
        row = rows.get(r.frame_index)
        if row is None:
            raise _Gone(job_id)
        ACTIVITY["done"] += len(won[r.frame_index])
        r.done, r.total = row.tiles_done, row.tiles_total
        r.pending = {}


def _mark_window_done(c, pending: list[TileRun], name: str | None) -> tuple[dict[int, list[int]], dict[int, Any]]:
    """In the caller's transaction: the runs' pending tiles that their
    worker still holds become done, stored in chunk ``name`` (one UPDATE;
    each tile's seconds the window's mean), and each frame's counter grows
    by its count (one UPDATE per distinct count). Returns ({frame: tiles
    won}, {frame: (index, tiles_done, tiles_total) row; none for a frame
    that is gone})."""
    first = pending[0]
    won: dict[int, list[int]] = {r.frame_index: [] for r in pending}
    rows: dict[int, Any] = {}
    if name:
        seconds = [sec for r in pending for sec in r.pending.values()]
        pairs = [(r.frame_index, i) for r in pending for i in r.pending]
        frames = sorted({f for f, _ in pairs})
        tiles = sorted({t for _, t in pairs})
        # (The common window holds the same tiles of every frame: two plain
        # IN lists then say it, cheaper to bind and to match than pairs.)
        which = (Tile.frame_index.in_(frames), Tile.tile_index.in_(tiles)) \
            if len(pairs) == len(frames) * len(tiles) else (tuple_(Tile.frame_index, Tile.tile_index).in_(pairs),)
        for f, t in c.execute(
            update(Tile)
            .where(Tile.job_id == first.job_id, *which,
                   Tile.status == TILE.step("running", "done"), Tile.worker == first.worker)
            .values(status="done", seconds=sum(seconds) / len(seconds), renders=Tile.renders + 1, chunk=name)
            .returning(Tile.frame_index, Tile.tile_index)
        ).all():
            won[f].append(t)
    by_count: dict[int, list[int]] = {}
    for f, tiles in won.items():
        by_count.setdefault(len(tiles), []).append(f)
    for n, frames in by_count.items():
        for row in c.execute(update(Frame).where(Frame.job_id == first.job_id, Frame.index.in_(frames))
                             .values(tiles_done=Frame.tiles_done + n)
                             .returning(Frame.index, Frame.tiles_done, Frame.tiles_total)).all():
            rows[row.index] = row
    return won, rows


def _mark_done(c, run: TileRun, chunk: str) -> list[int]:
    """In the caller's transaction: the pending tiles that this worker still
    holds become done, stored in ``chunk``. Returns them. A tile's recorded
    render time is its run's mean (one value for the statement, so it
    compiles once however many tiles; the frame's sum is the same)."""
    seconds = run.pending
    return c.execute(
        update(Tile)
        .where(*tile_key(run.job_id, run.frame_index), Tile.tile_index.in_(list(seconds)),
               Tile.status == TILE.step("running", "done"), Tile.worker == run.worker)
        .values(status="done", seconds=sum(seconds.values()) / len(seconds), renders=Tile.renders + 1, chunk=chunk)
        .returning(Tile.tile_index)
    ).scalars().all()


class _Lost(Exception):
    """Some tile of the run is no longer this worker's (the reaper gave it away)."""


def _finish_whole_frame(run: TileRun) -> bool:
    """Assembles a frame this worker rendered alone, then marks its tiles and
    the frame done in one transaction: a crash before the commit leaves the
    tiles claimed by a dead worker, and the reaper has them rendered again;
    a crash after it leaves a finished frame. Returns False (nothing
    committed; the caller goes the usual way) if any tile was taken away."""
    if len(_still_held(run, run.pending)) < len(run.pending):
        return False
    figures = assembly.assemble_frame(run.settings, run.job_id, run.frame_index, run.local,
                                      seconds=sum(run.pending.values()), commit=False, frame_px=run.frame_px)
    try:
        with engine_for(run.settings.sqlalchemy_url).begin() as c:
            won = _mark_done(c, run, "frame")
            if len(won) < len(run.pending):
                raise _Lost
            n = c.execute(update(Frame).where(
                Frame.job_id == run.job_id, Frame.index == run.frame_index, Frame.status.in_(FRAME.sources("done", among=("queued", "rendering"))),
            ).values(tiles_done=len(won), status="done", assembler=run.worker, figures=figures,
                     assembly_s=figures["assembly_s"], finished=time.time())).rowcount
            if n != 1:
                raise _Lost
    except _Lost:
        return False
    ACTIVITY["done"] += len(won)
    run.pending = {}
    assembly.finish_job_if_last(run.settings, run.job_id)
    return True


def _reason(exc: BaseException) -> str:
    """An error as a job's message: its type and text, cut to 300 characters."""
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"[:300]


def release(settings: Settings, job_id: str, frame_index: int, worker: str, tiles: list[int], resend: bool,
            reason: str | None = None, untried: bool = False) -> None:
    """Gives tiles this worker claimed but did not finish back to the queue
    (a pause, a cancel, a time limit or an error) and, if the job goes on,
    writes their message to the outbox in the same transaction (then sends
    it if the broker answers); after an error, a tile that failed too often
    fails its job instead. ``untried``: the tiles were never started (a run
    stopped by its soft time limit), so the attempt is not counted."""
    if not tiles:
        return
    with engine_for(settings.sqlalchemy_url).begin() as c:
        mine = (*tile_key(job_id, frame_index), Tile.tile_index.in_(tiles), Tile.status == "running", Tile.worker == worker)
        if resend and not untried:
            failed = c.execute(update(Tile).where(*mine, Tile.attempts >= settings.max_tile_attempts)
                               .values(status=TILE.check("running", "failed"), error=reason)
                               .returning(Tile.tile_index)).scalars().all()
            if failed:
                c.execute(update(Job).where(Job.id == job_id, Job.status.in_(JOB.sources("failed"))).values(
                    status="failed", error=f"tile {frame_index}/{failed[0]} failed {settings.max_tile_attempts} times"
                    + (f" ({reason})" if reason else "")))
                resend = False
        back = c.execute(update(Tile).where(*mine).values(
            status=TILE.check("running", "queued"), worker=None, error=reason,
            **({"attempts": Tile.attempts - 1} if untried else {})).returning(Tile.tile_index)).scalars().all()
        if resend and back:
            add_runs(c, job_id, [(frame_index, sorted(back))], priority=9)
    if resend:
        try_drain(settings, job_id, who=f"argand worker {worker}")
