"""The console of `argand serve`: one line per job event (submitted,
running, paused, canceled, failed, done), with the time it happened, read
from the database (the source of truth) once a second."""

from __future__ import annotations

import threading
import time
from typing import Callable

from argand.farm.progress import JobState, watch_jobs
from argand.farm.settings import Settings
from argand.farm.states import ENDED

#: Seconds between two reads of the jobs.
POLL_S = 1.0


def _clock(t: float | None) -> str:
    return time.strftime("%H:%M:%S", time.localtime(t or time.time()))


def _seconds(s: float) -> str:
    return f"{s:.1f} s" if s < 60 else f"{int(s // 60)} min {s % 60:.0f} s"


def describe(job: JobState) -> str:
    return f"job {job.id} ({job.scene_name}, {job.frames} frame{'s' * (job.frames != 1)} {job.width}x{job.height})"


def event_line(job: JobState, before: str) -> str | None:
    """The line for ``job`` now in its state, after ``before``; None when it
    has not changed."""
    if job.status == before:
        return None
    if job.status == "done":
        took = f" in {_seconds(job.finished - job.created)}" if job.finished else ""
        return f"{_clock(job.finished)}  {describe(job)} done{took}"
    if job.status == "failed":
        return f"{_clock(None)}  {describe(job)} failed: {job.error or 'no reason given'}"
    if job.status == "running" and before == "queued":
        return f"{_clock(job.started)}  {describe(job)} running"
    again = {"running": "running again", "queued": "queued again"}
    return f"{_clock(None)}  {describe(job)} {again.get(job.status, job.status)}"


class JobLog(threading.Thread):
    """Announces each job's changes of state from the time it starts: jobs
    created before it are not listed, but their later changes are."""

    def __init__(self, settings: Settings, announce: Callable[[str], None]) -> None:
        super().__init__(name="argand-job-log", daemon=True)
        self.settings, self.announce = settings, announce
        self.stop = threading.Event()
        self.since = time.time()
        self.seen: dict[str, str] = {}  # job id -> last state announced, while the job may change
        self.ended: dict[str, str] = {}  # job id -> the state it ended in (a retry brings it back)

    def poll(self) -> None:
        jobs = watch_jobs(self.settings, self.since, self.seen)
        for job in jobs:
            before = self.seen.get(job.id) or self.ended.pop(job.id, None)
            if before is None and job.created > self.since:
                self.announce(f"{_clock(job.created)}  {describe(job)} submitted")
                before = "queued"
            elif before is None:
                before = job.status  # an older job, active already: only its next change is news
            line = event_line(job, before)
            if line:
                self.announce(line)
            self.seen[job.id] = job.status
            self.since = max(self.since, job.created)
        listed = {job.id for job in jobs}
        for job_id, status in list(self.seen.items()):
            if job_id not in listed:
                self.announce(f"{_clock(None)}  job {job_id} deleted")
            if job_id not in listed or status in ENDED:
                del self.seen[job_id]
            if job_id in listed and status in ENDED:
                self.ended[job_id] = status

    def run(self) -> None:
        while not self.stop.wait(POLL_S):
            try:
                self.poll()
            except Exception as exc:  # the log reports, it never stops the farm
                self.announce(f"{_clock(None)}  (the job log could not read the database: {type(exc).__name__}: {exc})")
                self.stop.wait(10 * POLL_S)
