"""A worker started while its database does not answer (its host cut off,
the database restarting) beats once the database answers: its first
heartbeat failing must not leave it without a heartbeat thread for good
(tests/cluster found such a worker: it took tasks, never beat, and its
host's health check failed for as long as it ran)."""

from __future__ import annotations

import time

from argand.farm.workers import list_workers
from argand.worker import heartbeat as heartbeat_module
from argand.worker.heartbeat import Heartbeat

from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)


def test_a_worker_whose_first_heartbeat_fails_beats_once_the_database_answers(farm_parts, monkeypatch):  # noqa: F811
    settings, _ = farm_parts
    settings = settings.model_copy(update={"heartbeat_interval_s": 0.1})
    real, failures = heartbeat_module.heartbeat, []

    def flaky(*args, **kwargs):
        if len(failures) < 3:  # the database does not answer the first three beats
            failures.append(time.monotonic())
            raise ConnectionError("the database does not answer")
        return real(*args, **kwargs)

    monkeypatch.setattr(heartbeat_module, "heartbeat", flaky)
    beat = Heartbeat(settings, "w1+0badc0de@host")
    beat.start()  # does not raise
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not [w for w in list_workers(settings) if w["alive"]]:
            time.sleep(0.05)
        assert [w["name"] for w in list_workers(settings) if w["alive"]] == ["w1+0badc0de@host"]
        assert len(failures) == 3
    finally:
        beat.stop()
