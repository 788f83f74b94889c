"""A job's progress and estimated time left, from its frames' counters."""

from __future__ import annotations

import time

from argand.farm.models import Job


def job_progress(job: Job) -> tuple[int, int]:
    """(tiles done, tiles in all) from the frames' counters."""
    done = sum(f.tiles_done or 0 for f in job.frames)
    total = sum(f.tiles_total for f in job.frames)
    return int(done), int(total)


def eta_seconds(job: Job, done: int, total: int) -> float | None:
    """Seconds left at the job's pace so far: 0 when every tile is done,
    None before the first."""
    if not job.started or done == 0 or done >= total:
        return 0.0 if done >= total and total else None
    elapsed = time.time() - job.started
    return elapsed / done * (total - done)
