"""The farm's Prometheus metrics, read from the database on each scrape (the
workers record what the histograms need on the rows they already write):
gauges of jobs and tiles by state and of live workers, a counter of frames
done, and histograms of tile render time, frame assembly time and queue
wait (a message's sending to its claim). The API adds request latency.

The gauges and the counter are counts over indexed columns, read on every
scrape; the histograms scan the finished tiles, so they are read again only
when those counts changed and at most once every ``histogram_refresh_s``
(between two reads a scrape gets the last ones: at most that many seconds old).

Work nobody is doing: the queue compared with the database
(argand.farm.reaper.take_census, at most once every ``histogram_refresh_s``):
``argand_tiles_unsent``, the queued tiles of active jobs that no message
carries (lost by the broker: the reaper sends them again), and
``argand_messages_stale``, waiting messages that can claim nothing (the
reaper drops them). Absent while the broker does not answer."""

from __future__ import annotations

import threading
import time

from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, HistogramMetricFamily
from sqlalchemy import case, func, select

from argand.farm.database import session_scope
from argand.farm.models import Frame, Job, Tile, Worker
from argand.farm.queue import broker_client
from argand.farm.reaper import take_census
from argand.farm.settings import Settings
from argand.farm.states import JOB, TILE

#: Seconds: a tile renders in milliseconds to seconds; an assembly and a
#: queue wait in tens of milliseconds to minutes.
TILE_BUCKETS = (0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30)
ASSEMBLY_BUCKETS = (0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30)
WAIT_BUCKETS = (0.01, 0.05, 0.1, 0.5, 1, 5, 10, 30, 60, 300, 1800)


def _histogram(s, name: str, doc: str, column, where, buckets) -> HistogramMetricFamily:
    """Cumulative bucket counts and the sum of ``column`` over the rows of ``where``, in one query."""
    row = s.execute(select(*[func.sum(case((column <= b, 1), else_=0)) for b in buckets],
                           func.count(column), func.sum(column)).where(where, column.is_not(None))).one()
    counts, total, sum_ = row[:len(buckets)], row[len(buckets)] or 0, row[len(buckets) + 1] or 0.0
    values = [(str(b), int(c or 0)) for b, c in zip(buckets, counts)] + [("+Inf", int(total))]
    return HistogramMetricFamily(name, doc, buckets=values, sum_value=float(sum_))


def _by_status(s, name: str, doc: str, model, states) -> GaugeMetricFamily:
    counts = dict(s.execute(select(model.status, func.count()).group_by(model.status)).all())
    g = GaugeMetricFamily(name, doc, labels=["status"])
    for status in states:
        g.add_metric([status], counts.get(status, 0))
    return g


class FarmCollector:
    """A prometheus_client collector over the farm's database."""

    def __init__(self, settings: Settings, histogram_refresh_s: float = 5.0) -> None:
        self.settings = settings
        self.histogram_refresh_s = histogram_refresh_s
        self._lock = threading.Lock()
        self._histograms: list[HistogramMetricFamily] = []
        self._token = None  # the counts the histograms were read at
        self._read_at = -float("inf")
        self._census: list[GaugeMetricFamily] = []
        self._census_at = -float("inf")

    def describe(self):  # no description up front: collect() is called on scrape only
        return []

    def _read_histograms(self, s) -> list[HistogramMetricFamily]:
        return [
            _histogram(s, "argand_tile_render_seconds", "Render time of a tile (its run's mean)",
                       Tile.seconds, Tile.status == "done", TILE_BUCKETS),
            _histogram(s, "argand_frame_assembly_seconds", "Assembly time of a frame",
                       Frame.assembly_s, Frame.status == "done", ASSEMBLY_BUCKETS),
            _histogram(s, "argand_queue_wait_seconds", "From a message's sending to its tile's claim",
                       Tile.waited, Tile.status.in_(TILE.states), WAIT_BUCKETS),
        ]

    def _read_census(self) -> list[GaugeMetricFamily]:
        mono = time.monotonic()
        if mono - self._census_at >= self.histogram_refresh_s:
            self._census_at = mono
            try:
                client = broker_client(self.settings)
                client.connection_pool.connection_kwargs.update(socket_timeout=2, socket_connect_timeout=2)
                census = take_census(self.settings, client)
            except Exception:  # the broker does not answer: /healthz says so; no figure rather than a wrong one
                self._census = []
                return self._census
            unsent = GaugeMetricFamily("argand_tiles_unsent", "Queued tiles of active jobs that no message carries "
                                       "(not in the broker, not held by a worker, not in the outbox)")
            unsent.add_metric([], census.unsent_tiles)
            stale = GaugeMetricFamily("argand_messages_stale", "Messages waiting in the broker that can claim nothing")
            stale.add_metric([], len(census.stale))
            self._census = [unsent, stale]
        return self._census

    def collect(self):
        now = time.time()
        with session_scope(self.settings.sqlalchemy_url) as s:
            jobs = _by_status(s, "argand_jobs", "Jobs by status", Job, JOB.states)
            tiles = _by_status(s, "argand_tiles", "Tiles by status", Tile, TILE.states)
            frames_done = s.scalar(select(func.count()).select_from(Frame).where(Frame.status == "done"))
            done = CounterMetricFamily("argand_frames_done", "Frames assembled")
            done.add_metric([], frames_done)
            alive = GaugeMetricFamily("argand_workers_alive", "Workers with a recent heartbeat")
            alive.add_metric([], s.scalar(select(func.count()).select_from(Worker).where(
                Worker.heartbeat > now - self.settings.heartbeat_timeout_s)))
            token = (tuple(sample.value for sample in tiles.samples), frames_done)
            with self._lock:
                mono = time.monotonic()
                if token != self._token and mono - self._read_at >= self.histogram_refresh_s:
                    self._histograms, self._token, self._read_at = self._read_histograms(s), token, mono
                histograms = self._histograms
                census = self._read_census()
        yield from (jobs, tiles, done, alive, *census, *histograms)
