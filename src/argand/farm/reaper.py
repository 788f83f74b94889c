"""The reaper: finds work that nobody will finish and has it finished.

* A worker whose heartbeats stopped (killed, crashed): its tiles go back to
  the queue (a tile that failed too often fails its job instead), and since
  it may also have held a prefetched message that Redis gives back only
  after the visibility timeout, every queued tile of the unfinished jobs is
  sent again at the top priority (a duplicate message is a no-op: a tile is
  claimed by compare-and-set).
* The outbox (argand.farm.outbox): messages that a broker outage kept from
  being sent are sent (the reaper holds its lease in Redis, so it runs
  exactly when Redis is back).
* A frame whose assembler died (or hangs) is assembled again.
* A worker that died between its last commit and the assembly (or between
  the last frame and the animation) left a frame with every tile done but
  nobody assembling it (or a job whose frames are all done but that is not
  finished): seen so in two rounds in a row (so that a live worker about to
  do it is not raced), they are finished here.

It runs in the workers (argand.worker.heartbeat), one at a time: see
:class:`Reaper`."""

from __future__ import annotations

import time

from sqlalchemy import select
from sqlalchemy.orm import Session

from argand.farm import assembly
from argand.farm.database import session_scope
from argand.farm.dispatch import dispatch_job
from argand.farm.models import Frame, Job, Tile, Worker
from argand.farm.outbox import drain
from argand.farm.settings import Settings
from argand.farm.states import ACTIVE, FRAME, JOB, TILE


def _requeue_tiles_of(s: Session, settings: Settings, dead: set[str], now: float) -> set[str]:
    """Tiles running on a dead worker, or for far longer than the hard time
    limit, go back to the queue, or fail their job after too many attempts.
    Returns the jobs of the tiles put back (their messages must be sent again:
    a tile queued with no message would wait forever)."""
    jobs: set[str] = set()
    for t in s.scalars(select(Tile).where(Tile.status == "running")).all():
        if t.worker in dead or (t.started and now - t.started > settings.tile_hard_time_limit_s * 2):
            if t.attempts >= settings.max_tile_attempts:
                t.status = TILE.check(t.status, "failed")
                job = s.get(Job, t.job_id)
                if JOB.allowed(job.status, "failed"):
                    job.status = JOB.check(job.status, "failed")
                    why = t.error or f"its worker stopped: no heartbeat for {settings.heartbeat_timeout_s:g} s"
                    job.error = f"tile {t.frame_index}/{t.tile_index} failed {t.attempts} times ({why})"
                continue
            t.status = TILE.check(t.status, "queued")
            t.worker = None
            jobs.add(t.job_id)
    return jobs


def _orphaned_assemblies(s: Session, settings: Settings, dead: set[str], now: float) -> list[tuple[str, int]]:
    """Frames whose assembler died or hangs, sent back to rendering."""
    orphans = []
    for f in s.scalars(select(Frame).where(Frame.status == "assembling")).all():
        if f.assembler in dead or (f.assembling_since and now - f.assembling_since > settings.tile_hard_time_limit_s):
            f.status = FRAME.check(f.status, "rendering")
            orphans.append((f.job_id, f.index))
    return orphans


def _stuck(s: Session) -> tuple[set[tuple[str, int]], set[str]]:
    """(frames with every tile done that nobody assembles, jobs with every
    frame done that are not finished), of active jobs."""
    active = select(Job.id).where(Job.status.in_(ACTIVE))
    frames = {tuple(r) for r in s.execute(select(Frame.job_id, Frame.index).where(
        Frame.status.in_(FRAME.sources("assembling")), Frame.tiles_done >= Frame.tiles_total, Frame.job_id.in_(active)))}
    unfinished = select(Frame.job_id).where(Frame.status != "done")
    jobs = set(s.scalars(select(Job.id).where(Job.status.in_(ACTIVE), Job.id.not_in(unfinished),
                                             Job.id.in_(select(Frame.job_id)))))
    return frames, jobs


class Reaper:
    """Keeps what it saw stuck in the last round (a stuck frame or job is
    finished when seen in two rounds in a row)."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self._seen_frames: set[tuple[str, int]] = set()
        self._seen_jobs: set[str] = set()

    def round(self) -> int:
        """One round. Returns the number of tiles sent again."""
        settings, now = self.settings, time.time()
        requeue: list[str] = []
        with session_scope(settings.sqlalchemy_url) as s:
            dead_workers = [w for w in s.scalars(select(Worker)) if now - w.heartbeat > settings.heartbeat_timeout_s]
            dead = {w.name for w in dead_workers}
            requeued = _requeue_tiles_of(s, settings, dead, now)
            orphans = _orphaned_assemblies(s, settings, dead, now)
            frames, jobs = _stuck(s)
            orphans += sorted(frames & self._seen_frames)
            finish = sorted(jobs & self._seen_jobs)
            self._seen_frames, self._seen_jobs = frames, jobs
            if dead_workers:
                requeue = list(s.scalars(select(Tile.job_id).where(
                    Tile.status == "queued", Tile.job_id.in_(select(Job.id).where(Job.status.in_(ACTIVE)))).distinct()))
                for w in dead_workers:
                    s.delete(w)
            active = set(s.scalars(select(Job.id).where(Job.id.in_(requeued), Job.status.in_(ACTIVE))))
            requeue = sorted(set(requeue) | active)
        for job_id, index in orphans:
            assembly.maybe_assemble(settings, job_id, index)  # idempotent
        for job_id in finish:
            assembly.finish_job_if_last(settings, job_id)
        # Work given back goes ahead of everything (the highest priority).
        n = sum(dispatch_job(settings, job_id, priority=9, send=False) for job_id in requeue)
        # Everything the outbox holds: this round's, and what a broker outage left.
        drain(settings)
        return n
