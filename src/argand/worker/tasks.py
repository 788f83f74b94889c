"""The workers' one task, thin: it checks the message and calls
argand.farm.tile_work.run_tiles, which tests call directly."""

from __future__ import annotations

import time

from celery import Celery
from pydantic import BaseModel, Field

from argand.farm.queue import TASK_NAME
from argand.farm.tile_work import run_tiles
from argand.farm.settings import Settings
from argand.worker.stall_check import TASKS


class RunMessage(BaseModel):
    """A run of tiles of one frame (sent from the outbox by argand.farm.outbox.drain)."""

    job_id: str = Field(min_length=1, max_length=32)
    frame_index: int = Field(ge=0)
    tile_indices: list[int] = Field(min_length=1)
    sent_at: float | None = None


def register_tasks(app: Celery, settings: Settings, worker_name: str) -> None:
    @app.task(name=TASK_NAME, bind=True, acks_late=True, reject_on_worker_lost=True)
    def render_tiles(self, job_id: str, frame_index: int, tile_indices: list[int], sent_at: float | None = None) -> str:
        TASKS.update(running=True, at=time.monotonic())
        try:
            m = RunMessage(job_id=job_id, frame_index=frame_index, tile_indices=tile_indices, sent_at=sent_at)
            return run_tiles(settings, m.job_id, m.frame_index, m.tile_indices, worker_name, m.sent_at)
        finally:
            TASKS.update(running=False, at=time.monotonic())
