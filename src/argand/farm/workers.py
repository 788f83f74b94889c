"""The workers as the farm sees them: a row each, refreshed by heartbeats."""

from __future__ import annotations

import socket
import time

from sqlalchemy import select

from argand.farm.database import session_scope
from argand.farm.models import Worker
from argand.farm.settings import Settings


def heartbeat(settings: Settings, name: str, pid: int, current_tile: str | None = None, tiles_done: int = 0) -> None:
    """Records that worker ``name`` is alive, what it renders and how many tiles it finished."""
    with session_scope(settings.sqlalchemy_url) as s:
        w = s.get(Worker, name)
        if w is None:
            s.add(Worker(name=name, host=socket.gethostname(), pid=pid, heartbeat=time.time(),
                         current_tile=current_tile, tiles_done=tiles_done))
        else:
            w.heartbeat = time.time()
            w.pid = pid
            w.current_tile = current_tile
            w.tiles_done = tiles_done


def is_alive(settings: Settings, worker: Worker, now: float) -> bool:
    return now - worker.heartbeat < settings.heartbeat_timeout_s


def list_workers(settings: Settings) -> list[dict]:
    now = time.time()
    with session_scope(settings.sqlalchemy_url) as s:
        return [
            {"name": w.name, "host": w.host, "pid": w.pid, "heartbeat": w.heartbeat, "alive": is_alive(settings, w, now),
             "current_tile": w.current_tile, "tiles_done": w.tiles_done}
            for w in s.scalars(select(Worker).order_by(Worker.name))
        ]
