"""`argand serve`, the supervisor: Redis (embedded or external), the schema
upgraded, N worker processes (`argand worker`) and the API (uvicorn) in the
foreground; Ctrl-C stops everything. The settings travel to the workers as
their environment (Settings.environment); this process's own are passed
explicitly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

from argand.farm.database import upgrade
from argand.farm.settings import Settings
from argand.worker.broker import EmbeddedRedis


def worker_command(name: str) -> list[str]:
    return [sys.executable, "-m", "argand.cli", "worker", "--name", name]


def start_workers(settings: Settings, count: int) -> list[subprocess.Popen]:
    env = dict(os.environ, **settings.environment())
    return [subprocess.Popen(worker_command(f"w{i + 1}@{os.uname().nodename}"), env=env) for i in range(count)]


def stop_all(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()


def serve(settings: Settings, workers: int, announce=print) -> None:
    import uvicorn

    from argand.api.app import create_app

    settings.data_path.mkdir(parents=True, exist_ok=True)
    redis = None
    if settings.redis_url is None:
        redis = EmbeddedRedis(settings.redis_socket).start()
        settings = settings.model_copy(update={"redis_url": redis.url})
    upgrade(settings.sqlalchemy_url)  # before the workers and the API use it
    procs = start_workers(settings, workers)
    try:
        announce(f"Argand is serving on http://{settings.host}:{settings.port}/  (API docs: /docs; "
                 f"{workers} worker(s); data in {settings.data_path})")
        uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="warning")
    finally:
        stop_all(procs)
        if redis:
            redis.stop()
