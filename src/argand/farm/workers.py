"""The workers as the farm sees them: a row each, refreshed by heartbeats.

A worker's identity (its row, its Celery hostname and the name its tiles
are claimed under) is unique per process: the name it is given plus a boot
id (:func:`unique_name`). A process started again under the same name (a
restarted `argand serve`, a container restarted with a fixed name) is a new
identity, so the old one's heartbeats are seen to stop and what it held is
given back (argand.farm.reaper)."""

from __future__ import annotations

import re
import socket
import uuid

from sqlalchemy import select, update

from argand.farm.database import clock, session_scope
from argand.farm.models import Worker
from argand.farm.settings import Settings


#: Between a worker's given name and its boot id: w1@host -> w1+3fa9c2d1@host.
BOOT_MARK = "+"


def unique_name(name: str) -> str:
    """``name`` with a fresh boot id before its ``@host`` (at its end without one)."""
    base, at, host = name.partition("@")
    return f"{base}{BOOT_MARK}{uuid.uuid4().hex[:8]}{at}{host}"


def identities_of(name: str) -> str:
    """A regular expression (for declare_dead) of every identity
    :func:`unique_name` gives ``name``: w1@host -> w1+<boot id>@host."""
    base, at, host = name.partition("@")
    return f"{re.escape(base)}{re.escape(BOOT_MARK)}[0-9a-f]+{re.escape(at + host)}"


def given_name(identity: str) -> str:
    """The name a worker was given, without its boot id (w1+3fa9c2d1@host -> w1@host)."""
    base, at, host = identity.partition("@")
    return f"{base.split(BOOT_MARK, 1)[0]}{at}{host}"


def declare_dead(settings: Settings, pattern: str) -> list[str]:
    """Marks the workers whose identity matches ``pattern`` (a regular
    expression, matched whole) as dead now: the reaper's next round gives
    back their tiles and sends again what they may have prefetched, without
    waiting for heartbeat_timeout_s. For a caller that knows those processes
    are gone (a restarted `argand serve` holding its data folder's lock).
    Returns their names."""
    match = re.compile(pattern).fullmatch
    with session_scope(settings.sqlalchemy_url) as s:
        names = [n for n in s.scalars(select(Worker.name)) if match(n)]
        if names:
            s.execute(update(Worker).where(Worker.name.in_(names)).values(heartbeat=0.0))
    return names


def heartbeat(settings: Settings, name: str, pid: int, current_tile: str | None = None, tiles_done: int = 0) -> None:
    """Records that worker ``name`` is alive (at the database's clock), what
    it renders and how many tiles it finished."""
    with session_scope(settings.sqlalchemy_url) as s:
        now = clock(s)
        w = s.get(Worker, name)
        if w is None:
            s.add(Worker(name=name, host=socket.gethostname(), pid=pid, heartbeat=now,
                         current_tile=current_tile, tiles_done=tiles_done))
        else:
            w.heartbeat = now
            w.pid = pid
            w.current_tile = current_tile
            w.tiles_done = tiles_done


def is_alive(settings: Settings, worker: Worker, now: float) -> bool:
    return now - worker.heartbeat < settings.heartbeat_timeout_s


def list_workers(settings: Settings) -> list[dict]:
    with session_scope(settings.sqlalchemy_url) as s:
        now = clock(s)
        return [
            {"name": w.name, "host": w.host, "pid": w.pid, "heartbeat": w.heartbeat, "alive": is_alive(settings, w, now),
             "current_tile": w.current_tile, "tiles_done": w.tiles_done}
            for w in s.scalars(select(Worker).order_by(Worker.name))
        ]
