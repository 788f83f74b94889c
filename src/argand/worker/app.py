"""The workers' Celery application, built from the settings it is given, and
a worker process's life: one task at a time on one core, a heartbeat (and
the reaper) and the time limits' watchdog (argand.worker.watchdog) beside it."""

from __future__ import annotations

import warnings

from celery import Celery
from celery.exceptions import SecurityWarning
from celery.signals import worker_ready, worker_shutdown

from argand.farm.queue import QUEUE
from argand.farm.settings import Settings
from argand.farm.workers import unique_name
from argand.worker.celery_config import celery_config
from argand.worker.heartbeat import Heartbeat
from argand.worker.stall_check import StallCheck
from argand.worker.watchdog import Watchdog
from argand.worker.tasks import register_tasks


def create_celery_app(settings: Settings, worker_name: str) -> Celery:
    app = Celery("argand")
    app.conf.update(celery_config(settings))
    register_tasks(app, settings, worker_name)
    return app


def _one_core() -> None:
    """A worker is one process on one core (run one per core): OpenImageIO's
    own thread pools would make workers fight over cores, and would let a
    lone worker borrow an idle core for its encoding, which no longer exists
    once every core runs a worker."""
    import OpenImageIO as oiio

    oiio.attribute("threads", 1)
    oiio.attribute("exr_threads", 1)


def _freeze_start_up() -> None:
    """Moves what the worker holds once started (its modules, Celery,
    SQLAlchemy, numpy: some hundred thousand objects) out of the garbage
    collector's sight: they live as long as the process, and a full
    collection walking them stalled a run by some 50-70 ms (measured: a
    24-frame job's assembly). Cycles made later are collected as ever."""
    import gc

    gc.collect()
    gc.freeze()


def worker_argv(name: str) -> list[str]:
    """Celery's command line for a worker: quiet (no banner: `argand serve`
    prints the farm's own lines), one task at a time."""
    return ["--quiet", "worker", "--pool", "solo", "--concurrency", "1", "--hostname", name, "--queues", QUEUE,
            "--loglevel", "WARNING", "--without-gossip", "--without-mingle"]


def run_worker(settings: Settings, name: str) -> None:
    """Runs a worker in this process until it is stopped (SIGTERM: a warm
    shutdown), under ``name`` plus a boot id of this process
    (argand.farm.workers.unique_name): its Celery hostname, heartbeat row
    and tile claims."""
    name = unique_name(name)
    # Celery warns at length about root, for a worker that would accept
    # pickle; these accept JSON only (celery_config), and `argand serve`
    # says in one line that it runs as root.
    warnings.filterwarnings("ignore", message="You're running the worker with superuser privileges", category=SecurityWarning)
    app = create_celery_app(settings, name)
    beat = Heartbeat(settings, name)
    watchdog = Watchdog(settings)
    stall_check = StallCheck(settings, name)

    def ready(**_kwargs) -> None:
        _one_core()
        _freeze_start_up()
        beat.start()
        watchdog.start()
        stall_check.start()

    worker_ready.connect(ready, weak=False)
    worker_shutdown.connect(lambda **_kwargs: beat.stop(), weak=False)
    app.worker_main(worker_argv(name))
