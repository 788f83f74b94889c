"""A user's control of a job: cancel, pause, resume, retry (argand.farm.
states.ACTIONS says which job states each applies to), a new priority, and
deletion. Runs in flight see a cancel or pause between two tiles."""

from __future__ import annotations

from sqlalchemy import update

from argand.farm.database import session_scope
from argand.farm.dispatch import dispatch_job
from argand.farm.models import Job, Tile
from argand.farm.settings import Settings
from argand.farm.states import ACTIONS, ACTIVE, JOB, TILE
from argand.farm.store import store_for


class NoSuchJob(LookupError):
    """The job does not exist (or no longer)."""

    def __init__(self, job_id: str) -> None:
        super().__init__(f"no job {job_id!r}")


def set_job_status(settings: Settings, job_id: str, action: str) -> str:
    """Applies ``action`` if the job's state allows it (else changes
    nothing); resume and retry give the unfinished tiles back to the queue
    and send them. Returns the job's state after."""
    if action not in ACTIONS:
        raise ValueError(f"action must be one of {', '.join(ACTIONS)}, not {action!r}")
    applies_to, target = ACTIONS[action]
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        if job.status not in applies_to:
            return job.status
        if target == "queued" and job.started:
            target = "running"
        job.status = JOB.check(job.status, target)
        resend = target in ACTIVE
        if resend:
            s.execute(update(Tile).where(Tile.job_id == job_id, Tile.status.in_(TILE.sources("queued")))
                      .values(status="queued", attempts=0, worker=None))
            job.error = None
    if resend:
        dispatch_job(settings, job_id)
    with session_scope(settings.sqlalchemy_url) as s:
        return s.get(Job, job_id).status


def set_priority(settings: Settings, job_id: str, priority: int) -> None:
    """A new priority takes effect at once: an active job's queued tiles are
    sent again at that priority (the older messages become no-ops, since a
    tile is claimed by compare-and-set)."""
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        job.priority = priority
        active = job.status in ACTIVE
    if active:
        dispatch_job(settings, job_id)


def delete_job(settings: Settings, job_id: str) -> None:
    """The job's rows and files. Its runs in flight stop at their next
    check (the job is gone)."""
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            raise NoSuchJob(job_id)
        s.delete(job)
    store_for(settings).remove_job(job_id)
