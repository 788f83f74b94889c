"""A container's health check of its worker: `python -m argand.worker.health`
exits 0 if a worker on this host sent a heartbeat within heartbeat_timeout_s
(settings from the environment, as `argand worker` reads them), else 1."""

from __future__ import annotations

import socket
import sys

from argand.farm.settings import Settings
from argand.farm.workers import list_workers


def healthy(settings: Settings, host: str) -> bool:
    return any(w["alive"] and w["host"] == host for w in list_workers(settings))


if __name__ == "__main__":
    sys.exit(0 if healthy(Settings(), socket.gethostname()) else 1)
