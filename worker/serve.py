"""`argand serve`: Redis (embedded or external), the API (uvicorn) and N
Celery worker processes, in the foreground; Ctrl-C stops everything."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

from argand.api.settings import Settings


def worker_command(name: str) -> list[str]:
    return [sys.executable, "-m", "celery", "-A", "argand.worker.app", "worker", "--pool", "solo",
            "--concurrency", "1", "--hostname", name, "--queues", "argand", "--loglevel", "WARNING",
            "--without-gossip", "--without-mingle"]


def child_env(settings: Settings, broker_url: str) -> dict[str, str]:
    env = dict(os.environ)
    env["ARGAND_DATA_DIR"] = str(settings.data_path)
    env["ARGAND_REDIS_URL"] = broker_url
    env["ARGAND_DATABASE_URL"] = settings.sqlalchemy_url
    return env


def start_workers(settings: Settings, broker_url: str, count: int) -> list[subprocess.Popen]:
    procs = []
    for i in range(count):
        name = f"w{i + 1}@{os.uname().nodename}"
        env = child_env(settings, broker_url)
        env["ARGAND_WORKER_NAME"] = name
        procs.append(subprocess.Popen(worker_command(name), env=env))
    return procs


def serve(settings: Settings, workers: int, announce=print) -> None:
    import uvicorn

    from argand.worker.broker import EmbeddedRedis

    settings.data_path.mkdir(parents=True, exist_ok=True)
    redis = None
    broker_url = settings.redis_url
    if broker_url is None:
        redis = EmbeddedRedis(settings.redis_socket).start()
        broker_url = redis.url
    os.environ.update(child_env(settings, broker_url))
    from argand.api.settings import get_settings

    get_settings.cache_clear()
    live = get_settings()
    # Create the schema before the workers race for it.
    from argand.api.db import engine_for

    engine_for(live.sqlalchemy_url)
    procs = start_workers(live, broker_url, workers)
    try:
        from argand.api.main import create_app

        announce(f"Argand is serving on http://{settings.host}:{settings.port}/  (API docs: /docs; "
                 f"{workers} worker(s); data in {settings.data_path})")
        uvicorn.run(create_app(live), host=settings.host, port=settings.port, log_level="warning")
    finally:
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in procs:
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                p.kill()
        if redis:
            redis.stop()
