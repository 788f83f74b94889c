"""A user's control of a job: cancel, pause, resume, retry (argand.farm.
states.ACTIONS says which job states each applies to), a new priority, and
deletion. Runs in flight see a cancel or pause between two tiles. A resume
of a job that is already active sends again its queued tiles that no
message carries (what the reaper's census would find)."""

from __future__ import annotations

import time

from sqlalchemy import delete, update
from sqlalchemy.orm import Session

from argand.farm.database import in_session
from argand.farm.dispatch import alive_workers, dispatch_job, queue_job_tiles
from argand.farm.models import Job, Outbox, Tile
from argand.farm.outbox import PRIORITY_RESEND_S, try_drain
from argand.farm.queue import broker_client
from argand.farm.reaper import take_census
from argand.farm.settings import Settings
from argand.farm.states import ACTIONS, ACTIVE, ENDED, JOB, TILE
from argand.farm.store import store_for
from argand.farm.submission import check_in_flight


class NoSuchJob(LookupError):
    """The job does not exist (or no longer)."""

    def __init__(self, job_id: str) -> None:
        super().__init__(f"no job {job_id!r}")


def set_job_status(settings: Settings, job_id: str, action: str, send: bool = True,
                   session: Session | None = None) -> str:
    """Applies ``action`` if the job's state allows it (else changes
    nothing); resume and retry give the unfinished tiles back to the queue
    and write their messages in the same transaction (argand.farm.outbox),
    sent here with ``send``. A resume of an active job sends again its
    queued tiles that no message carries (resend_unsent). In ``session``
    when given (committed here), else in one of its own. Returns the job's
    state after. Raises FarmBusy when the action would make an ended job
    active while max_active_jobs are (the limit of a new submission)."""
    if action not in ACTIONS:
        raise ValueError(f"action must be one of {', '.join(ACTIONS)}, not {action!r}")
    applies_to, target = ACTIONS[action]
    workers = alive_workers(settings)
    with in_session(settings.sqlalchemy_url, session) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        if job.status not in applies_to:
            status, resend = job.status, False
            lost = action == "resume" and status in ACTIVE
        else:
            if job.status in ENDED and target in ACTIVE:
                check_in_flight(settings, s)
            status, resend, lost = _apply(s, settings, job, target, workers), target in ACTIVE, False
    if lost:
        resend_unsent(settings, job_id, send)
    if resend and send:
        try_drain(settings, job_id)
    return status


def _apply(s, settings: Settings, job: Job, target: str, workers: int) -> str:
    """The job's change of state in session ``s``; a job made active again
    gets its unfinished tiles back, and their messages. Returns its state."""
    if target == "queued" and job.started:
        target = "running"
    job.status = JOB.check(job.status, target)
    if target in ACTIVE:
        s.execute(update(Tile).where(Tile.job_id == job.id, Tile.status.in_(TILE.sources("queued")))
                  .values(status="queued", attempts=0, worker=None))
        job.error = None
        s.flush()
        queue_job_tiles(s.connection(), settings, job.id, workers)
    return job.status


def resend_unsent(settings: Settings, job_id: str, send: bool = True) -> int:
    """The active job's queued tiles that no message carries (in the broker,
    held by a worker or in the outbox), sent again now. Without an answer
    from the broker nothing is sent (the reaper's census repairs it once the
    broker is back). Returns the number of tiles sent again."""
    try:
        client = broker_client(settings)
        client.connection_pool.connection_kwargs.update(socket_timeout=2, socket_connect_timeout=2)
        lost = take_census(settings, client, job_id).unsent.get(job_id)
    except Exception:  # redis errors, whatever the client: the reaper repairs later
        return 0
    return dispatch_job(settings, job_id, send=send, only_tiles=lost) if lost else 0


def set_priority(settings: Settings, job_id: str, priority: int, send: bool = True,
                 session: Session | None = None) -> None:
    """A new priority: an active job's queued tiles are sent again at that
    priority (the older messages become no-ops, since a tile is claimed by
    compare-and-set). Bounded: the same priority sends nothing, and a job's
    tiles are sent again at most once per PRIORITY_RESEND_S (a later change
    replaces the messages still waiting, and goes out when that time has
    passed), so PATCHes in a loop cannot flood the broker. In ``session``
    when given (committed here), else in one of its own."""
    workers = alive_workers(settings)
    with in_session(settings.sqlalchemy_url, session) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        if job.priority == priority:
            return
        job.priority = priority
        if job.status not in ACTIVE:
            return
        now = time.time()
        last = job.priority_resent or 0.0
        due = last if last > now else max(now, last + PRIORITY_RESEND_S)  # one waiting re-send at most
        job.priority_resent = due
        s.flush()
        # The messages not sent yet carry the old priority: replaced.
        s.execute(delete(Outbox).where(Outbox.job_id == job_id, Outbox.lease_until < now))
        queue_job_tiles(s.connection(), settings, job_id, workers, not_before=due)
    if send:
        try_drain(settings, job_id)


def delete_job(settings: Settings, job_id: str, session: Session | None = None) -> None:
    """The job's rows, then its files. Its runs in flight stop at their next
    check (the job is gone). In ``session`` when given (committed here
    before the files go), else in one of its own."""
    with in_session(settings.sqlalchemy_url, session) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        s.delete(job)
    store_for(settings).remove_job(job_id)
