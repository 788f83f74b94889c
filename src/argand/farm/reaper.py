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
* The queue against the database (:meth:`Reaper.reconcile`, every
  ``queue_check_s``): the database is the source of truth, so a queued tile
  of an active job that no message carries (not in the broker's lists, not
  held by a worker, not in the outbox) in two censuses in a row is sent
  again (a broker that lost its messages: a FLUSHALL, an AOF tail lost on a
  crash, a Redis replaced without its volume); and a waiting message that
  can claim nothing (its job stopped or is gone, its tiles are no longer
  queued, or an older priority's copy of tiles that a message at the job's
  priority carries) is dropped.
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
from collections import defaultdict
from dataclasses import dataclass, field

from sqlalchemy import select
from sqlalchemy.orm import Session

from argand.farm import assembly
from argand.farm.database import clock, engine_for, session_scope
from argand.farm.dispatch import dispatch_job
from argand.farm.models import Frame, Job, Outbox, Tile, Worker
from argand.farm.outbox import drain
from argand.farm.queue import BrokerRun, broker_runs, drop_waiting, level_of_key, priority_level
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


@dataclass
class Census:
    """The queue against the database at one moment: the queued tiles of
    the active jobs, those no message carries (job -> {(frame, tile)}), and
    the stale waiting messages: those that can claim nothing (``idle``) and
    the copies at another priority of tiles that messages at the job's
    priority carry (``copies``)."""

    queued: int = 0
    unsent: dict[str, set[tuple[int, int]]] = field(default_factory=dict)
    idle: list[BrokerRun] = field(default_factory=list)
    copies: list[BrokerRun] = field(default_factory=list)

    @property
    def unsent_tiles(self) -> int:
        return sum(len(t) for t in self.unsent.values())

    @property
    def stale(self) -> list[BrokerRun]:
        return self.idle + self.copies


def _outbox_cover(c) -> dict[str, set[tuple[int, int]]]:
    cover: dict[str, set[tuple[int, int]]] = defaultdict(set)
    for job_id, frame, tiles in c.execute(select(Outbox.job_id, Outbox.frame_index, Outbox.tile_indices)):
        cover[job_id].update((frame, t) for t in tiles)
    return cover


def _judge_job(census: Census, job_id: str, queued: set[tuple[int, int]], runs: list[BrokerRun],
               outbox: set[tuple[int, int]], level: int) -> None:
    """One active job's part of the census: its tiles without a message, its
    stale messages. A waiting message at another priority than the job's is
    stale when waiting messages at the job's priority carry all its queued
    tiles (an older priority's copy; or a given-back tile's top-priority copy
    whose tile was waiting anyway)."""
    current = {(r.frame_index, t) for r in runs if r.key is not None and level_of_key(r.key) == level
               for t in r.tile_indices}
    carried = outbox | {(r.frame_index, t) for r in runs for t in r.tile_indices}
    census.queued += len(queued)
    if queued - carried:
        census.unsent[job_id] = queued - carried
    for r in runs:
        if r.key is None:
            continue  # held by a worker: it acknowledges it when done
        mine = {(r.frame_index, t) for t in r.tile_indices} & queued
        if not mine:
            census.idle.append(r)
        elif level_of_key(r.key) != level and mine <= current:
            census.copies.append(r)


def take_census(settings: Settings, client, job_id: str | None = None) -> Census:
    """Reads the active jobs and the outbox, then the broker, then each
    job's queued tiles (one job at a time: the memory is one job's tiles).
    A message moves only forward (outbox, list, worker), so reading the
    outbox first misses none; reading the tiles last, a tile claimed
    meanwhile is no longer queued, and a message whose tiles were given
    back meanwhile does not look idle. A tile given back after the broker
    was read may look unsent in this census (never in two in a row: its new
    message is seen in the next)."""
    census = Census()
    eng = engine_for(settings.sqlalchemy_url)
    with eng.connect() as c:
        active = select(Job.id).where(Job.status.in_(ACTIVE), *([Job.id == job_id] if job_id else []))
        jobs = {job: priority for job, priority in c.execute(select(Job.id, Job.priority).where(Job.id.in_(active)))}
        outbox = _outbox_cover(c)
    by_job: dict[str, list[BrokerRun]] = defaultdict(list)
    # A worker that holds a message longer than a run may last is dead (the
    # watchdog stops a run at the hard limit): its message carries nothing.
    for run in broker_runs(client, settings.tile_hard_time_limit_s + settings.heartbeat_timeout_s):
        if job_id is None or run.job_id == job_id:
            by_job[run.job_id].append(run)
    for owner, runs in by_job.items():
        if owner not in jobs:  # stopped, ended or deleted: nothing to claim
            census.idle += [r for r in runs if r.key is not None]
    with eng.connect() as c:
        for owner, priority in jobs.items():
            queued = {(f, t) for f, t in c.execute(select(Tile.frame_index, Tile.tile_index).where(
                Tile.job_id == owner, Tile.status == "queued"))}
            _judge_job(census, owner, queued, by_job.get(owner, []), outbox.get(owner, set()), priority_level(priority))
    return census


def still_idle(settings: Settings, runs: list[BrokerRun]) -> list[BrokerRun]:
    """Those of ``runs`` that still can claim nothing, read again: a tile
    given back, or a job resumed, after the census read the tiles has new
    messages that the census may have taken for idle ones."""
    if not runs:
        return []
    with engine_for(settings.sqlalchemy_url).connect() as c:
        queued = {tuple(row) for row in c.execute(select(Tile.job_id, Tile.frame_index, Tile.tile_index).where(
            Tile.status == "queued", Tile.job_id.in_({r.job_id for r in runs}),
            Tile.job_id.in_(select(Job.id).where(Job.status.in_(ACTIVE)))))}
    return [r for r in runs if not any((r.job_id, r.frame_index, t) in queued for t in r.tile_indices)]


class Reaper:
    """Keeps what it saw stuck in the last round (a stuck frame or job is
    finished when seen in two rounds in a row)."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self._seen_frames: set[tuple[str, int]] = set()
        self._seen_jobs: set[str] = set()
        self._unsent: dict[str, set[tuple[int, int]]] = {}
        self._next_census = 0.0

    def round(self) -> int:
        """One round. Returns the number of tiles sent again."""
        settings = self.settings
        requeue: list[str] = []
        with session_scope(settings.sqlalchemy_url) as s:
            now = clock(s)  # the heartbeats' clock (argand.farm.database.clock)
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

    def census_due(self) -> bool:
        return time.monotonic() >= self._next_census

    def reconcile(self, client) -> int:
        """The queue against the database (at most every queue_check_s, and
        at most a tenth of the time: a census that took 1 s waits 10 s):
        drops the stale messages, sends again the tiles without a message in
        this census and the one before. Returns the number of tiles sent again."""
        if not self.census_due():
            return 0
        start = time.monotonic()
        census = take_census(self.settings, client)
        drop_waiting(client, still_idle(self.settings, census.idle) + census.copies)
        lost = {job_id: tiles & self._unsent[job_id] for job_id, tiles in census.unsent.items()
                if job_id in self._unsent}
        self._unsent = census.unsent
        n = sum(dispatch_job(self.settings, job_id, send=False, only_tiles=tiles) for job_id, tiles in lost.items()
                if tiles)
        if n:
            drain(self.settings)
        took = time.monotonic() - start
        self._next_census = start + max(self.settings.queue_check_s, 10 * took)
        return n
