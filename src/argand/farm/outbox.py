"""The outbox: messages to the workers are rows first, sent second.

Whatever makes tiles queued (a submission, a resume or retry, a tile given
back, the reaper) writes the messages for them as ``outbox`` rows in the same
transaction (:func:`add_runs`), so a broker outage or a crash right after the
commit cannot leave a queued tile without a message. :func:`drain` then
sends pending rows and deletes them once the broker took them:

* the API drains in a thread of its own (:class:`Drainer`), woken by every
  change it makes, so a request never waits on the broker;
* a worker drains what it gave back itself, and the reaper (under its lease
  in Redis, so once Redis is back) drains everything each round.

Delivery is at least once: a drainer holds the rows it sends for
``LEASE_S`` (a drainer that dies holding them lets go), and a message sent
twice is a no-op (a tile is claimed by compare-and-set). Rows of a job that
is no longer active (paused, canceled, failed, done) are dropped unsent: a
resume or retry writes new ones."""

from __future__ import annotations

import sys
import threading
import time
import uuid

from sqlalchemy import delete, func, select, update

from argand.farm.database import engine_for
from argand.farm.models import Job, Outbox
from argand.farm.queue import send_messages
from argand.farm.settings import Settings
from argand.farm.states import ACTIVE

#: Seconds a drainer holds the rows it is sending.
LEASE_S = 30.0
#: Rows one drain takes at a time.
BATCH = 500
#: A priority change re-sends a job's queued tiles at most once in this many
#: seconds (30 PATCHes in a row used to put 7,529 messages in Redis).
PRIORITY_RESEND_S = 10.0


def add_runs(conn, job_id: str, runs: list[tuple[int, list[int]]], priority: int, not_before: float = 0.0) -> int:
    """In the caller's transaction: one pending message per run of tiles
    (frame, tile indices), at ``priority`` (0..9, 9 first). Returns the
    number of rows."""
    if not runs:
        return 0
    now = time.time()
    conn.execute(Outbox.__table__.insert(), [
        dict(job_id=job_id, frame_index=f, tile_indices=list(tiles), priority=priority, created=now,
             not_before=not_before, lease_until=0.0) for f, tiles in runs])
    return len(runs)


def pending(settings: Settings) -> tuple[int, float | None]:
    """(messages not sent yet, seconds the oldest has waited or None)."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        n, oldest = c.execute(select(func.count(), func.min(Outbox.created))).one()
    return int(n or 0), (time.time() - oldest if oldest is not None else None)


def drain(settings: Settings, job_id: str | None = None) -> int:
    """Sends the pending messages (of one job, or all), oldest first, and
    deletes them once sent. Returns the number sent. Raises the broker's
    error when it does not answer (the rows stay, for the next drain)."""
    sent = 0
    eng = engine_for(settings.sqlalchemy_url)
    while True:
        now, me = time.time(), uuid.uuid4().hex
        mine = [Outbox.lease_until < now, Outbox.not_before <= now]
        if job_id is not None:
            mine.append(Outbox.job_id == job_id)
        with eng.connect() as c:  # a read first: an empty outbox costs no write lock
            if c.execute(select(Outbox.id).where(*mine).limit(1)).first() is None:
                return sent
        with eng.begin() as c:
            # Rows of jobs that stopped are dropped: nothing would claim their tiles.
            c.execute(delete(Outbox).where(*mine, Outbox.job_id.in_(select(Job.id).where(Job.status.not_in(ACTIVE)))))
            ids = select(Outbox.id).where(*mine).order_by(Outbox.id).limit(BATCH).scalar_subquery()
            rows = c.execute(update(Outbox).where(Outbox.id.in_(ids), Outbox.lease_until < now)
                             .values(lease_until=now + LEASE_S, sender=me)
                             .returning(Outbox.id, Outbox.job_id, Outbox.frame_index, Outbox.tile_indices,
                                        Outbox.priority)).all()
        if not rows:
            return sent
        rows.sort(key=lambda r: r.id)
        try:
            send_messages(settings, [(r.job_id, r.frame_index, r.tile_indices, r.priority) for r in rows])
        except BaseException:
            with eng.begin() as c:  # let go at once: the next drain tries again
                c.execute(update(Outbox).where(Outbox.sender == me).values(lease_until=0.0, sender=None))
            raise
        with eng.begin() as c:
            c.execute(delete(Outbox).where(Outbox.sender == me))
        sent += len(rows)
        if len(rows) < BATCH:
            return sent


def try_drain(settings: Settings, job_id: str | None = None, who: str = "argand") -> int:
    """drain(), a broker error reported on stderr instead of raised (the rows
    wait for the next drain). Returns the number sent."""
    try:
        return drain(settings, job_id)
    except Exception as exc:
        print(f"{who}: messages kept in the outbox, the broker did not take them: {type(exc).__name__}: {exc}",
              file=sys.stderr)
        return 0


class Drainer(threading.Thread):
    """The API's sender: drains the outbox when woken (after each change
    the API makes) and every ``every_s`` anyway (rows left by a broker
    outage, or written by another process)."""

    def __init__(self, settings: Settings, every_s: float = 1.0) -> None:
        super().__init__(name="argand-outbox", daemon=True)
        self.settings, self.every_s = settings, every_s
        self.wake, self.stop = threading.Event(), threading.Event()
        self.failing = False

    def run(self) -> None:
        while not self.stop.is_set():
            self.wake.wait(self.every_s)
            self.wake.clear()
            if self.stop.is_set():
                return
            try:
                drain(self.settings)
                if self.failing:
                    print("argand api: the broker answers again; the outbox is sent", file=sys.stderr)
                self.failing = False
            except Exception as exc:
                if not self.failing:  # said once per outage, not every second
                    print(f"argand api: messages wait in the outbox, the broker does not answer: "
                          f"{type(exc).__name__}: {exc}", file=sys.stderr)
                self.failing = True
