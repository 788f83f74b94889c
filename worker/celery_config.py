"""Celery configuration (Airflow's habits: JSON only, late acks, prefetch 1,
a visibility timeout set on purpose, explicit time limits)."""

from __future__ import annotations

from argand.api.settings import Settings


def celery_config(settings: Settings) -> dict:
    return {
        "broker_url": settings.broker_url,
        "result_backend": None,
        "task_ignore_result": True,
        "task_serializer": "json",
        "accept_content": ["json"],
        "result_serializer": "json",
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "worker_max_tasks_per_child": 2000,
        "task_soft_time_limit": settings.tile_soft_time_limit_s,
        "task_time_limit": settings.tile_hard_time_limit_s,
        "broker_connection_retry_on_startup": True,
        "broker_transport_options": {
            # Above the longest message (a run of tiles; the hard time limit) so it is
            # not redelivered while it still runs; crashed workers are caught
            # sooner by the heartbeat reaper.
            "visibility_timeout": settings.tile_hard_time_limit_s * 2,
            "priority_steps": list(range(10)),
            "sep": ":",
            "queue_order_strategy": "priority",
        },
        "task_default_queue": "argand",
        "worker_hijack_root_logger": False,
        "worker_send_task_events": False,
    }
