"""The workers' Celery configuration (Airflow's habits: JSON only, late
acks, prefetch 1, a visibility timeout set on purpose, explicit time
limits). What the sender must agree on is argand.farm.queue's."""

from __future__ import annotations

from argand.farm.queue import message_config
from argand.farm.settings import Settings


def celery_config(settings: Settings) -> dict:
    return {
        **message_config(settings),
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "worker_max_tasks_per_child": 2000,
        # The solo pool ignores these two; argand.worker.watchdog enforces them.
        "task_soft_time_limit": settings.tile_soft_time_limit_s,
        "task_time_limit": settings.tile_hard_time_limit_s,
        "worker_hijack_root_logger": False,
        "worker_send_task_events": False,
    }
