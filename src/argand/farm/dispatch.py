"""Sending a job's tiles to the workers: the tiles in given states, grouped
by argand.farm.planning into runs, written to the outbox (argand.farm.outbox)
in the caller's transaction and sent by a drainer."""

from __future__ import annotations


from sqlalchemy import func, select

from argand.farm.database import clock, engine_for
from argand.farm.models import Frame, Job, Tile, Worker
from argand.farm.outbox import add_runs, try_drain
from argand.farm.planning import batch_pixels, plan_runs, tile_rects
from argand.farm.settings import Settings


def alive_workers(settings: Settings) -> int:
    """Workers whose last heartbeat is recent."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        return int(c.execute(select(func.count()).select_from(Worker).where(
            Worker.heartbeat > clock(c) - settings.heartbeat_timeout_s)).scalar() or 0)


def queue_job_tiles(conn, settings: Settings, job_id: str, workers: int, only_status: tuple[str, ...] = ("queued",),
                    priority: int | None = None, not_before: float = 0.0,
                    only_tiles: set[tuple[int, int]] | None = None) -> int:
    """In the caller's transaction (``conn``): outbox rows for every tile of
    the job in one of the given states (see plan_runs), limited to the
    (frame, tile) pairs of ``only_tiles`` when given, at the job's priority
    unless ``priority`` is given. Returns the number of tiles."""
    job = conn.execute(select(Job.priority, Job.width, Job.height, Job.tile, Job.scene).where(Job.id == job_id)).first()
    if job is None:
        return 0
    positions = [tuple(p) for p in conn.execute(select(Frame.sigma_index, Frame.delta_index).where(
        Frame.job_id == job_id).order_by(Frame.index))]
    rows = conn.execute(select(Tile.frame_index, Tile.tile_index).where(
        Tile.job_id == job_id, Tile.status.in_(only_status)).order_by(Tile.frame_index, Tile.tile_index)).all()
    if only_tiles is not None:
        rows = [r for r in rows if tuple(r) in only_tiles]
    by_frame: dict[int, list[int]] = {}
    for f, t in rows:
        by_frame.setdefault(f, []).append(t)
    # (Frames that keep only their figures are sent a window of frames a
    # run, split by tiles: each tile solved once for the window.)
    window = settings.run_bands if settings.files_on_request else 1
    runs = plan_runs(by_frame, len(positions), tile_rects(job.width, job.height, job.tile),
                     batch_pixels(settings.batch_pixels, job.scene),
                     max(1, workers), positions, window=window)
    add_runs(conn, job_id, runs, job.priority if priority is None else priority, not_before)
    return len(rows)


def dispatch_job(settings: Settings, job_id: str, only_status: tuple[str, ...] = ("queued",),
                 priority: int | None = None, send: bool = True,
                 only_tiles: set[tuple[int, int]] | None = None) -> int:
    """queue_job_tiles in a transaction of its own, then (``send``) an
    attempt to send the job's messages (they wait in the outbox if the
    broker does not answer). Returns the number of tiles queued."""
    workers = alive_workers(settings)
    with engine_for(settings.sqlalchemy_url).begin() as c:
        n = queue_job_tiles(c, settings, job_id, workers, only_status, priority, only_tiles=only_tiles)
    if send and n:
        try_drain(settings, job_id)
    return n
