"""The messages between the farm and its workers: the task's name, the
queue, the broker's transport options (the sender and the workers must
agree on them), and the sending of runs of tiles. A message is
``[job_id, frame_index, tile_indices, sent_at]``; the worker's side is
argand.worker.tasks."""

from __future__ import annotations

import time

import redis
from celery import Celery

from argand.farm.settings import Settings

TASK_NAME = "argand.render_tiles"
QUEUE = "argand"
#: A job's priority (0..9, 9 first) and Redis's priority steps (0 first).
PRIORITIES = range(10)


def transport_options(settings: Settings) -> dict:
    return {
        # Above the longest message (a run of tiles; the hard time limit) so it is
        # not redelivered while it still runs; crashed workers are caught
        # sooner by the heartbeat reaper.
        "visibility_timeout": settings.tile_hard_time_limit_s * 2,
        "priority_steps": list(PRIORITIES),
        "sep": ":",
        "queue_order_strategy": "priority",
    }


def message_config(settings: Settings) -> dict:
    """What the sender and the workers' Celery app share."""
    return {
        "broker_url": settings.broker_url,
        "broker_transport_options": transport_options(settings),
        "broker_connection_retry_on_startup": True,
        "task_serializer": "json",
        "accept_content": ["json"],
        "result_serializer": "json",
        "result_backend": None,
        "task_ignore_result": True,
        "task_default_queue": QUEUE,
    }


_senders: dict[str, Celery] = {}


def _sender(settings: Settings) -> Celery:
    key = settings.broker_url
    if key not in _senders:
        app = Celery("argand-sender")
        app.conf.update(message_config(settings))
        _senders[key] = app
    return _senders[key]


def priority_level(priority: int) -> int:
    """A job's priority (0..9, 9 first) as Redis's priority step (0 first)."""
    return max(0, min(9, 9 - priority))


def send_messages(settings: Settings, messages: list[tuple[str, int, list[int], int]]) -> None:
    """Sends (job, frame, tile indices, job priority) messages, in order, on
    one producer (one broker connection, acquired once). Raises the broker's
    error if it does not take them. Callers go through argand.farm.outbox."""
    if not messages:
        return
    app = _sender(settings)
    with app.producer_or_acquire() as producer:
        for job_id, frame_index, tile_indices, priority in messages:
            app.send_task(TASK_NAME, args=[job_id, frame_index, list(tile_indices), time.time()],
                          priority=priority_level(priority), queue=QUEUE, producer=producer)


def broker_client(settings: Settings):
    """A Redis client on the farm's broker (embedded: its unix socket)."""
    url = settings.broker_url
    if url.startswith("redis+socket://"):
        return redis.Redis(unix_socket_path=url.split("://", 1)[1])
    return redis.Redis.from_url(url)
