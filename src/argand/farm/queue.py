"""The messages between the farm and its workers: the task's name, the
queue, the broker's transport options (the sender and the workers must
agree on them), and the sending of runs of tiles. A message is
``[job_id, frame_index, tile_indices, sent_at]``; the worker's side is
argand.worker.tasks."""

from __future__ import annotations

import base64
import json
import socket
import time
from dataclasses import dataclass

import redis
from celery import Celery

from argand.farm.settings import Settings

TASK_NAME = "argand.render_tiles"
QUEUE = "argand"
#: A job's priority (0..9, 9 first) and Redis's priority steps (0 first).
PRIORITIES = range(10)
#: A broker across the network answers in bounded time: seconds to connect,
#: and seconds a command may wait for its answer (a send into a cut link
#: fails then, and its messages wait in the outbox, instead of waiting for
#: TCP to give up).
BROKER_CONNECT_TIMEOUT_S = 3
BROKER_TIMEOUT_S = 5


def tcp_liveness() -> dict[int, int]:
    """TCP options (level IPPROTO_TCP) that end a broker connection whose
    link stopped carrying packets: keepalives when it is idle, and a limit
    on how long sent data may stay unacknowledged. Without them a worker
    that waits on a connection cut mid-command (its consumer waits for
    readiness, which no socket timeout bounds) waits for TCP to give up,
    about 15 minutes, and takes no work after the link is back."""
    options = {socket.TCP_KEEPIDLE: BROKER_TIMEOUT_S, socket.TCP_KEEPINTVL: 1, socket.TCP_KEEPCNT: 3}
    if hasattr(socket, "TCP_USER_TIMEOUT"):
        options[socket.TCP_USER_TIMEOUT] = BROKER_TIMEOUT_S * 1000
    return options


def transport_options(settings: Settings) -> dict:
    return {
        # Above the longest message (a run of tiles; the hard time limit) so it is
        # not redelivered while it still runs; crashed workers are caught
        # sooner by the heartbeat reaper.
        "visibility_timeout": settings.tile_hard_time_limit_s * 2,
        "priority_steps": list(PRIORITIES),
        "sep": ":",
        "queue_order_strategy": "priority",
        "socket_connect_timeout": BROKER_CONNECT_TIMEOUT_S,
        "socket_timeout": BROKER_TIMEOUT_S,
        "socket_keepalive": True,
        "socket_keepalive_options": tcp_liveness(),
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


#: Kombu's Redis transport: the hash of the messages delivered to a worker
#: and not acknowledged yet (late acks: until the run ends).
UNACKED_KEY = "unacked"
#: Kombu's sorted set of those messages' delivery times (by delivery tag).
UNACKED_INDEX_KEY = "unacked_index"
#: Messages read from the broker at a time.
READ_PAGE = 1000


def queue_keys() -> list[str]:
    """The queue's Redis lists, one per priority step (kombu: the step's
    number after the separator; step 0 is the bare name)."""
    return [QUEUE if level == 0 else f"{QUEUE}:{level}" for level in PRIORITIES]


def level_of_key(key: str) -> int:
    return int(key.rpartition(":")[2]) if ":" in key else 0


@dataclass(frozen=True)
class BrokerRun:
    """A message to the workers found in the broker: where it is (a queue
    list, or the unacknowledged hash: ``key`` None), its bytes, its run of tiles."""

    key: str | None
    raw: bytes
    job_id: str
    frame_index: int
    tile_indices: tuple[int, ...]


def _run_of(raw: bytes) -> tuple[str, int, tuple[int, ...]] | None:
    """(job, frame, tiles) of a raw kombu message of ours; None for anything else."""
    try:
        message = json.loads(raw)
        if message["headers"]["task"] != TASK_NAME:
            return None
        body = message["body"]
        if message["properties"].get("body_encoding") == "base64":
            body = base64.b64decode(body)
        args = json.loads(body)[0]
        return str(args[0]), int(args[1]), tuple(int(t) for t in args[2])
    except (ValueError, KeyError, IndexError, TypeError, AttributeError):
        return None


def broker_runs(client, held_for_at_most: float | None = None) -> list[BrokerRun]:
    """Every message of ours in the broker: waiting in the queue's lists, and
    delivered to a worker but not acknowledged (with ``held_for_at_most``,
    only those delivered less than that many seconds ago: a worker that held
    one longer is dead, and Redis gives it back only after the visibility
    timeout). Read page by page (a reader takes no lock; a message that
    moves meanwhile may be missed or seen twice)."""
    found: list[BrokerRun] = []
    for key in queue_keys():
        start = 0
        while True:
            page = client.lrange(key, start, start + READ_PAGE - 1)
            found += [BrokerRun(key, raw, *run) for raw in page if (run := _run_of(raw)) is not None]
            if len(page) < READ_PAGE:
                break
            start += READ_PAGE
    held = client.hgetall(UNACKED_KEY)
    if held_for_at_most is not None:
        since = time.time() - held_for_at_most
        recent = {tag for tag, at in client.zrange(UNACKED_INDEX_KEY, 0, -1, withscores=True) if at >= since}
        held = {tag: value for tag, value in held.items() if tag in recent}
    for value in held.values():
        try:
            raw = json.dumps(json.loads(value)[0]).encode()
        except (ValueError, IndexError, TypeError):
            continue
        if (run := _run_of(raw)) is not None:
            found.append(BrokerRun(None, raw, *run))
    return found


def drop_waiting(client, runs: list[BrokerRun]) -> int:
    """Removes these waiting messages from their lists (one copy each; a
    message a worker took meanwhile is simply not found). Returns how many
    were removed."""
    if not runs:
        return 0
    pipe = client.pipeline(transaction=False)
    for run in runs:
        if run.key is not None:
            pipe.lrem(run.key, 1, run.raw)
    return sum(int(n) for n in pipe.execute())


def broker_client(settings: Settings):
    """A Redis client on the farm's broker (embedded: its unix socket)."""
    url = settings.broker_url
    bounded = {"socket_timeout": BROKER_TIMEOUT_S, "socket_connect_timeout": BROKER_CONNECT_TIMEOUT_S}
    if url.startswith("redis+socket://"):
        return redis.Redis(unix_socket_path=url.split("://", 1)[1], **bounded)
    return redis.Redis.from_url(url, socket_keepalive=True, socket_keepalive_options=tcp_liveness(), **bounded)
