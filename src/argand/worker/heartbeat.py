"""A worker's background thread: a heartbeat every heartbeat_interval_s
(what it renders and how many tiles it finished), and, in the one worker
that holds the reaper's lease, a round of the reaper (argand.farm.reaper)
at most every second.

Why the reaper runs here: its work is to notice workers that stopped, so it
is needed exactly while the farm has workers; in a worker it runs under
`argand serve` and under docker-compose alike without a process of its own,
and the API stays HTTP only. A lease in Redis (a key that expires unless its
holder renews it) keeps it to one worker at a time; when that worker dies,
another takes the lease after REAPER_LEASE_S. A holder whose round fails
(its host cut off from the database but not from Redis) gives the lease up
at once and stands down for REAPER_STAND_DOWN_S, so that a worker that
reaches the database reaps in its place."""

from __future__ import annotations

import os
import sys
import threading
import time

from argand.farm.queue import broker_client
from argand.farm.reaper import Reaper
from argand.farm.tile_work import ACTIVITY
from argand.farm.settings import Settings
from argand.farm.workers import heartbeat

REAPER_KEY = "argand:reaper-lease"
REAPER_LEASE_S = 5.0
REAPER_EVERY_S = 1.0


#: A worker whose reaper round failed (its database out of reach) neither
#: keeps nor takes the lease for this long, so a worker that can reach the
#: database takes it over.
REAPER_STAND_DOWN_S = 3 * REAPER_LEASE_S

_RELEASE = "if redis.call('get', KEYS[1]) == ARGV[1] then return redis.call('del', KEYS[1]) end return 0"


def release_lease(client, name: str) -> None:
    """Gives the reaper's lease up if ``name`` holds it (atomically: a lease
    another worker took meanwhile stays theirs)."""
    client.eval(_RELEASE, 1, REAPER_KEY, name)


def holds_lease(client, name: str) -> bool:
    """Takes the reaper's lease if it is free, renews it if ``name`` holds it."""
    ms = int(REAPER_LEASE_S * 1000)
    if client.set(REAPER_KEY, name, nx=True, px=ms):
        return True
    if client.get(REAPER_KEY) == name.encode():
        client.pexpire(REAPER_KEY, ms)
        return True
    return False


class Heartbeat:
    """The heartbeat's thread and the reaper's (a long round of the reaper,
    an assembly, does not hold up the heartbeats)."""

    def __init__(self, settings: Settings, name: str) -> None:
        self.settings, self.name = settings, name
        self.stop_event = threading.Event()
        self.standing_down_until = 0.0  # time.monotonic() before which it takes no lease (reap_once)

    def beat(self) -> None:
        heartbeat(self.settings, self.name, os.getpid(), ACTIVITY["tile"], ACTIVITY["done"])

    def _every(self, seconds: float, step) -> None:
        while not self.stop_event.wait(seconds):
            try:
                step()
            except Exception as exc:  # the database may be briefly busy; next round
                print(f"argand worker {self.name}: {exc!r}", file=sys.stderr)

    def reap_once(self, client, reaper: Reaper) -> None:
        """One round of the reaper if this worker holds (or takes) the lease.
        A worker cut off from the database but not from Redis would
        otherwise renew the lease forever, its rounds failing, and nobody
        would give back a dead worker's tiles: a round that fails gives the
        lease up (the error is raised on), and this worker stands down for
        REAPER_STAND_DOWN_S."""
        if time.monotonic() < self.standing_down_until or not holds_lease(client, self.name):
            return
        try:
            reaper.round()
            reaper.reconcile(client)
        except Exception:
            self.standing_down_until = time.monotonic() + REAPER_STAND_DOWN_S
            release_lease(client, self.name)
            raise

    def _reap_rounds(self) -> None:
        client, reaper = broker_client(self.settings), Reaper(self.settings)

        def step() -> None:
            self.reap_once(client, reaper)

        self._every(max(REAPER_EVERY_S, self.settings.heartbeat_interval_s), step)

    def start(self) -> None:
        """Beats once now (the worker registered before its first task), then
        starts the threads. A database that does not answer that first beat
        (a worker started while its host is cut off from it, or while it
        restarts) does not stop them: the heartbeat thread beats once it
        answers. (Raised out of Celery's worker_ready, it left a worker that
        took tasks but never beat again, and never started its watchdog and
        stall check: "unhealthy" for good; tests/cluster found it.)"""
        try:
            self.beat()
        except Exception as exc:  # noqa: BLE001 - any database error; the thread retries
            print(f"argand worker {self.name}: no first heartbeat ({exc!r}); beating every "
                  f"{self.settings.heartbeat_interval_s:g} s until the database answers", file=sys.stderr, flush=True)
        threading.Thread(target=self._every, args=(self.settings.heartbeat_interval_s, self.beat), daemon=True,
                         name="argand-heartbeat").start()
        threading.Thread(target=self._reap_rounds, daemon=True, name="argand-reaper").start()

    def stop(self) -> None:
        self.stop_event.set()
