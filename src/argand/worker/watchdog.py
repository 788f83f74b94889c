"""The workers' time limits, for real: the solo pool (one task at a time in
the worker's own process) ignores Celery's ``task_time_limit``, so a run of
tiles could outlive Redis's visibility timeout and be redelivered to a
second worker while it still rendered.

* Soft limit (``tile_soft_time_limit_s``): argand.farm.tile_work starts no
  tile after it and gives the rest of the run back (argand.farm.tile_work.run_tiles).
* Hard limit (``tile_hard_time_limit_s``): this thread ends the worker's
  process with SIGKILL once the run is past it, after writing on the run's
  tiles why (their ``error``), and not in the middle of writing a chunk and
  committing it (argand.farm.tile_work._complete). The tiles stay claimed by the dead worker's
  name; the reaper gives them back once its heartbeats are older than
  ``heartbeat_timeout_s`` (after the attempts, the job fails with that
  reason), and `argand serve` starts a worker in its place.

Why no tile is ever rendered by two workers at once: the process is dead
before anything gives its tiles away. The reaper gives a tile back only when
its worker's heartbeats stopped (and the killed process beats no more) or
when it has run for twice the hard limit (the watchdog kills at once the
hard limit); Redis redelivers the message after its visibility timeout,
also twice the hard limit (argand.farm.queue.transport_options), and a
redelivered message claims nothing that is still running (compare-and-set).
The render releases Python's GIL (argand's C++ core), so this thread runs
while a tile renders."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

from sqlalchemy import update

from argand.farm.database import engine_for
from argand.farm.models import Tile
from argand.farm.tile_work import ACTIVITY
from argand.farm.settings import Settings

#: How often the watchdog looks at the run's deadline.
CHECK_S = 0.2
#: At most this long to write the reason before the kill.
NOTE_S = 5.0


def past_hard_limit(now: float | None = None) -> bool:
    hard_at = ACTIVITY.get("hard_at")
    return hard_at is not None and (time.monotonic() if now is None else now) > hard_at


class Watchdog(threading.Thread):
    def __init__(self, settings: Settings, kill=lambda: os.kill(os.getpid(), signal.SIGKILL)) -> None:
        super().__init__(name="argand-watchdog", daemon=True)
        self.settings, self.kill = settings, kill
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.wait(CHECK_S):
            run = ACTIVITY.get("run")
            if run is None or not past_hard_limit():
                continue
            job_id, frame_index, claimed, worker = run
            reason = (f"TimeLimitExceeded: the run of {len(claimed)} tiles passed the hard time limit of "
                      f"{self.settings.tile_hard_time_limit_s} s (tile {ACTIVITY.get('tile')}); its worker was stopped")
            print(f"argand worker {worker}: {reason}", file=sys.stderr, flush=True)

            def note() -> None:
                with engine_for(self.settings.sqlalchemy_url).begin() as c:
                    # Still claimed by this worker: nobody else can take them yet.
                    c.execute(update(Tile).where(Tile.job_id == job_id, Tile.frame_index == frame_index,
                                                 Tile.tile_index.in_(claimed), Tile.status == "running",
                                                 Tile.worker == worker).values(error=reason))

            # The reason is written if the database answers within a few seconds; the kill comes regardless.
            writer = threading.Thread(target=note, daemon=True)
            writer.start()
            writer.join(min(NOTE_S, self.settings.tile_hard_time_limit_s / 2))  # killed before 2 x the hard limit
            # A chunk being written and committed is let through (a second at most), so that a
            # process killed here does not leave a chunk that no tile points at in the store.
            deadline = time.monotonic() + NOTE_S
            while ACTIVITY.get("writing") and time.monotonic() < deadline:
                time.sleep(0.01)
            self.kill()
            return
