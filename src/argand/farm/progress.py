"""A job's progress and estimated time left, from its frames' counters; the
jobs' states for a log of their changes (argand.serve.job_log)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Iterable

from sqlalchemy import func, or_, select

from argand.farm.database import session_scope
from argand.farm.models import Frame, Job
from argand.farm.settings import Settings
from argand.farm.states import ACTIVE


def job_progress(job: Job) -> tuple[int, int]:
    """(tiles done, tiles in all) from the frames' counters."""
    done = sum(f.tiles_done or 0 for f in job.frames)
    total = sum(f.tiles_total for f in job.frames)
    return int(done), int(total)


def eta_seconds(job: Job, done: int, total: int) -> float | None:
    """Seconds left at the job's pace so far, only while it runs: None for a
    job that is queued, paused, canceled, failed or done (nothing is being
    rendered, so no time is running out), and before its first tile."""
    if job.status != "running" or not job.started or done == 0 or done >= total:
        return None
    elapsed = time.time() - job.started
    return elapsed / done * (total - done)


def jobs_progress(s, job_ids: list[str]) -> dict[str, tuple[int, int]]:
    """(tiles done, tiles in all) of each of ``job_ids``, in one aggregate query
    over their frames' counters (no frame is loaded); 0/0 for a job without frames."""
    if not job_ids:
        return {}
    rows = s.execute(select(Frame.job_id, func.coalesce(func.sum(Frame.tiles_done), 0), func.sum(Frame.tiles_total))
                     .where(Frame.job_id.in_(job_ids)).group_by(Frame.job_id)).all()
    out = {job_id: (0, 0) for job_id in job_ids}
    out.update({job_id: (int(done or 0), int(total or 0)) for job_id, done, total in rows})
    return out


@dataclass(frozen=True)
class JobState:
    """What a log of jobs' changes needs of a job."""
    id: str
    status: str
    scene_name: str
    frames: int
    width: int
    height: int
    created: float
    started: float | None
    finished: float | None
    error: str | None


def watch_jobs(settings: Settings, created_after: float, watched: Iterable[str]) -> list[JobState]:
    """The jobs created after ``created_after``, those of ``watched`` and every
    active one (a retried job comes back), in one query over the jobs and
    their frames' count; in order of creation."""
    frames = select(func.count()).where(Frame.job_id == Job.id).scalar_subquery()
    q = (select(Job.id, Job.status, Job.scene_name, frames, Job.width, Job.height, Job.created, Job.started,
                Job.finished, Job.error)
         .where(or_(Job.created > created_after, Job.id.in_(list(watched)), Job.status.in_(ACTIVE)))
         .order_by(Job.created))
    with session_scope(settings.sqlalchemy_url) as s:
        return [JobState(*row) for row in s.execute(q)]
