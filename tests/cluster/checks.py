"""What every cluster test checks of a job, and the figures it records.

* the job is done within a bound (no stuck job);
* every frame's EXR in the shared store equals, channel by channel and bit
  for bit, a local render_frame of the same scene and frame;
* every tile is counted done once (``renders`` = 1) and no tile file is
  left behind (a stale worker wrote nothing into the finished job); tiles
  claimed more than once (a redelivery, or work given back) are counted;
* the API answered every probe during the fault with a 2xx, or a 503 with
  Retry-After, in bounded time (:class:`Prober`)."""

from __future__ import annotations

import json
import threading
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from argand.media.atomic import is_temporary
from argand.media.frame_files import read_exr
from argand.render import AOV_CHANNELS, FrameParams, render_frame
from argand.scene import load_scene

#: The jobs of the cluster tests: 12 frames at 128x128 in 16-pixel tiles (768 tiles).
JOB = {"scene": "whitney", "deltas": {"start": 0, "stop": "pi/9", "count": 12}, "width": 128, "height": 128, "tile": 16}
FIGURES = Path(__file__).resolve().parents[2] / "build" / "cluster" / "figures.json"


@lru_cache(maxsize=64)
def local_frame(scene: str, sigma: float, delta: float, width: int, height: int):
    return render_frame(load_scene(scene), FrameParams(sigma=sigma, delta=delta, width=width, height=height), workers=1)


def submit(cluster, body: dict = JOB) -> str:
    with cluster.client(30) as c:
        r = c.post("/api/jobs", json=body)
    assert r.status_code == 201, r.text
    return r.json()["id"]


def tiles_done(cluster, job_id: str) -> int:
    return cluster.sql("select count(*) from tiles where job_id = :j and status = 'done'", j=job_id)[0][0]


def wait_tiles(cluster, job_id: str, n: int, timeout: float = 60) -> None:
    cluster.wait(lambda: tiles_done(cluster, job_id) >= n, timeout, f"{n} tiles of {job_id} are done", every=0.05)


def wait_done(cluster, job_id: str, timeout: float) -> float:
    """Seconds until the job is done (asserts it is, and not failed or stuck)."""
    def ended():
        status = cluster.sql("select status from jobs where id = :j", j=job_id)[0][0]
        assert status not in ("failed", "canceled"), f"job {job_id} {status}\n{cluster.logs()}"
        return status == "done"

    try:
        return cluster.wait(ended, timeout, f"job {job_id} is done")
    except AssertionError as exc:
        tiles = cluster.sql("select status, worker, count(*) from tiles where job_id = :j and status <> 'done' "
                            "group by status, worker", j=job_id)
        workers = cluster.sql("select name, heartbeat, extract(epoch from clock_timestamp()) - heartbeat from workers")
        raise AssertionError(f"{exc}; tiles not done: {tiles}; workers (name, heartbeat, age): {workers}") from None


def check_job(cluster, job_id: str, scene: str = "whitney") -> dict:
    """The job's frames against a local render, and its tiles' counts.
    Returns {"tiles", "claimed_again" (tiles claimed more than once)}."""
    job = cluster.sql("select width, height, status from jobs where id = :j", j=job_id)[0]
    assert job.status == "done"
    frames = cluster.sql("select index, sigma, delta, status from frames where job_id = :j order by index", j=job_id)
    folder = cluster.data / "store" / "jobs" / job_id
    for f in frames:
        assert f.status == "done", f
        local = local_frame(scene, f.sigma, f.delta, job.width, job.height)
        names, pixels = read_exr(folder / f"frame_{f.index:04d}.exr")
        for i, c in enumerate("RGBA"):
            assert np.array_equal(pixels[..., names.index(c)], local.rgba[..., i]), (f.index, c)
        for aov in AOV_CHANNELS:
            assert np.array_equal(pixels[..., names.index(aov)], local.aovs[aov].astype(np.float32)), (f.index, aov)
    tiles = cluster.sql("select renders, attempts, status from tiles where job_id = :j", j=job_id)
    assert all(t.status == "done" and t.renders == 1 for t in tiles), sorted({(t.status, t.renders) for t in tiles})
    left = sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.suffix == ".chunk" or is_temporary(p.name))
    assert not left, f"tile files left in the finished job: {left[:5]}"
    return {"tiles": len(tiles), "claimed_again": sum(t.attempts > 1 for t in tiles)}


class Prober(threading.Thread):
    """Asks the API for a job, the job list and /healthz every ``every``
    seconds from the test's own address, and keeps every answer's status
    and time (None for no answer within ``timeout``)."""

    def __init__(self, cluster, job_id: str, every: float = 0.5, timeout: float = 15) -> None:
        super().__init__(daemon=True)
        self.cluster, self.job_id, self.every, self.timeout = cluster, job_id, every, timeout
        self.answers: list[tuple[str, int | None, float, str | None]] = []
        self.stop_event = threading.Event()

    def run(self) -> None:
        with self.cluster.client(self.timeout) as c:
            while not self.stop_event.is_set():
                for path in (f"/api/jobs/{self.job_id}", "/api/jobs", "/healthz"):
                    start = time.monotonic()
                    try:
                        r = c.get(path)
                        code, retry = r.status_code, r.headers.get("retry-after")
                    except Exception:
                        code, retry = None, None
                    self.answers.append((path, code, time.monotonic() - start, retry))
                self.stop_event.wait(self.every)

    def __enter__(self) -> "Prober":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop_event.set()
        self.join(self.timeout + 5)

    def check(self, slowest_s: float = 10.0) -> dict:
        """Every answer a 2xx, or a 503 with Retry-After (/healthz: a 503 with
        its checks), within ``slowest_s``. Returns the figures."""
        bad = [a for a in self.answers if a[1] is None or a[1] >= 500 and a[1] != 503
               or (a[1] == 503 and a[0] != "/healthz" and not a[3]) or a[2] > slowest_s]
        assert self.answers and not bad, bad[:10]
        return {"probes": len(self.answers), "answered_503": sum(a[1] == 503 for a in self.answers),
                "slowest_answer_s": round(max(a[2] for a in self.answers), 2)}


def record(name: str, figures: dict) -> None:
    """Adds a fault's figures to build/cluster/figures.json (docs/reliability.md quotes them)."""
    FIGURES.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(FIGURES.read_text()) if FIGURES.exists() else {}
    data[name] = {k: round(v, 2) if isinstance(v, float) else v for k, v in figures.items()}
    FIGURES.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
