"""The Celery application and its one task. Tasks are thin: the logic lives
in argand.worker.farm, which tests call directly."""

from __future__ import annotations

import os
import socket
import threading

from celery import Celery
from celery.signals import worker_ready, worker_shutdown

from argand.api.settings import Settings, get_settings
from argand.worker import farm
from argand.worker.celery_config import celery_config

_apps: dict[str, Celery] = {}


def get_app(settings: Settings | None = None) -> Celery:
    settings = settings or get_settings()
    key = settings.broker_url
    if key not in _apps:
        app = Celery("argand")
        app.conf.update(celery_config(settings))

        @app.task(name=farm.TASK_NAME, bind=True, acks_late=True, reject_on_worker_lost=True)
        def render_tiles(self, job_id: str, frame_index: int, tile_indices: list[int]) -> str:
            return farm.run_tiles(settings, job_id, frame_index, [int(t) for t in tile_indices], worker_name())

        @app.task(name=farm.LEGACY_TASK_NAME, bind=True, acks_late=True, reject_on_worker_lost=True)
        def render_tile(self, job_id: str, frame_index: int, tile_index: int) -> str:
            return farm.run_tile(settings, job_id, frame_index, tile_index, worker_name())

        _apps[key] = app
    return _apps[key]


def worker_name() -> str:
    return os.environ.get("ARGAND_WORKER_NAME") or f"worker-{os.getpid()}@{socket.gethostname()}"


_stop = threading.Event()


def _beat(settings: Settings) -> None:
    while not _stop.is_set():
        try:
            farm.heartbeat(settings, worker_name(), os.getpid(), farm.ACTIVITY["tile"], farm.ACTIVITY["done"])
        except Exception:  # the database may be briefly busy; try again
            pass
        _stop.wait(settings.heartbeat_interval_s)


def _one_core() -> None:
    """A worker is one process on one core (run one per core): OpenImageIO's
    own thread pools would make workers fight over cores, and would let a
    lone worker borrow an idle core for its encoding, which no longer exists
    once every core runs a worker."""
    import OpenImageIO as oiio

    oiio.attribute("threads", 1)
    oiio.attribute("exr_threads", 1)


@worker_ready.connect
def _start_heartbeat(**_kwargs) -> None:
    _one_core()
    farm.heartbeat(get_settings(), worker_name(), os.getpid())  # registered before the first task
    threading.Thread(target=_beat, args=(get_settings(),), daemon=True, name="argand-heartbeat").start()


@worker_shutdown.connect
def _stop_heartbeat(**_kwargs) -> None:
    _stop.set()


# The module-level app for `celery -A argand.worker.app worker`.
app = get_app()
