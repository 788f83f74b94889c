"""A worker whose consumer stopped taking messages, ended so that its
supervisor starts it again.

Celery's Redis consumer can stay idle for good after its connection to
Redis was cut in the middle of a command (a network partition, a Redis
restart): the process lives, its heartbeats go on, and it takes no message
again (celery/celery issues 8030, 10205). The cluster harness's partition
of a worker host from Redis shows it (tests/cluster). This thread notices
it: messages wait in the queue, the broker answers, and this worker has
neither run nor started a task for ``STALL_S``. Then it ends the process
with SIGTERM (a warm shutdown: it holds no tile; an exit if that hangs), and its supervisor
(compose's restart policy, systemd, `argand serve`) starts a fresh one. A
stalled worker holds no tiles, so nothing waits on it but its own share of
the work."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

from argand.farm.queue import broker_client, queue_keys
from argand.farm.settings import Settings

#: Seconds a worker may sit idle while messages wait before it is deemed stalled.
STALL_S = 15.0
#: Seconds the warm shutdown may take before the process exits regardless.
END_WAIT_S = 10.0
#: How often the queue is looked at.
CHECK_S = 2.0

#: Whether this process runs a task now, and when it last started or ended
#: one (time.monotonic()); the task's body updates it (argand.worker.tasks).
TASKS = {"running": False, "at": time.monotonic()}


def waiting_messages(client) -> int:
    """Messages in the farm's queue, at every priority."""
    return sum(client.llen(key) for key in queue_keys())


def stalled(idle_s: float, waiting: int) -> bool:
    return waiting > 0 and idle_s > STALL_S


class StallCheck(threading.Thread):
    def __init__(self, settings: Settings, name: str,
                 end=lambda: os.kill(os.getpid(), signal.SIGTERM)) -> None:
        super().__init__(name="argand-stall-check", daemon=True)
        self.settings, self.name, self.end = settings, name, end
        self.stop = threading.Event()

    def run(self) -> None:
        client = broker_client(self.settings)
        while not self.stop.wait(CHECK_S):
            if TASKS["running"]:
                continue
            try:
                waiting = waiting_messages(client)
            except Exception:  # the broker does not answer: the consumer's own reconnection is at work
                TASKS["at"] = max(TASKS["at"], time.monotonic() - STALL_S / 2)
                continue
            idle = time.monotonic() - TASKS["at"]
            if stalled(idle, waiting):
                print(f"argand worker {self.name}: {waiting} messages wait and this worker took none for "
                      f"{idle:.0f} s: its connection to the broker is stuck; stopping so that it is started again",
                      file=sys.stderr, flush=True)
                self.end()
                time.sleep(END_WAIT_S)  # a warm shutdown that hangs on the stuck connection: no goodbye then
                os._exit(1)
