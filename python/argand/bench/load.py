"""`argand bench load`: simulated users (Locust, argand.bench.load_users)
against a two-worker farm, over HTTP only.

Phases:

1. **ramp**: the users step up (e.g. 1, 5, 10, 20, 40, 60); each step's
   latency and throughput give the knee: the first step where a latency
   target is missed or a request fails. The sustainable level is the step
   before it.
2. **steady**: that many users for a bounded time, while a low-priority
   filler job keeps both workers rendering whenever the users' jobs leave
   them idle (the targets are for a farm that renders all the time).
3. **drain**: no users; every accepted job must end (done, or canceled by
   the user or the harness that cancelled it). A job that does not is lost.

Then the frames the farm finished during the steady phase are rendered
again by the same farm, idle (the same scenes, sizes and deltas, as jobs of
their own): their time over the steady phase's is the rendering throughput
under load as a share of unloaded.

Figures: per endpoint (requests/s, p50/p95/p99/max, failures) per phase;
jobs accepted vs ended; tiles rendered twice (from the farm's database
when the harness started the farm); frames/s; the RSS and CPU of the API,
the workers and Redis over time (psutil). Writes load.json, load.md and
load.png.
"""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable

import httpx
import numpy as np

from argand.bench import machine_info

#: The issue's targets on this machine (p99 in ms, throughput share).
TARGETS = {"status_list_p99_ms": 100.0, "frame_download_p99_ms": 200.0, "throughput_share": 0.9}
STATUS_LIST = ("GET /api/jobs", "GET /api/jobs/{id}")
FRAME_DOWNLOADS = ("GET frame.png", "GET thumbnail.png", "GET animation.gif")
ENDED = ("done", "failed", "canceled")
#: A step's first seconds are left out of its figures (users arriving).
SETTLE_S = 2.0


# ---------------------------------------------------------------------------
# Sampling the farm: processes (psutil) and /metrics
# ---------------------------------------------------------------------------


class FarmSampler(threading.Thread):
    """Every ``interval`` seconds: RSS and CPU of the farm's processes (when
    the farm's root process is known) and the farm's /metrics counters."""

    def __init__(self, url: str, root_pid: int | None, interval: float = 1.0) -> None:
        super().__init__(daemon=True, name="argand-load-sampler")
        self.url, self.root_pid, self.interval = url, root_pid, interval
        self.stop = threading.Event()
        self.processes: list[dict] = []  # {t, name, pid, rss_mb, cpu_percent, cpu_s}
        self.machine: list[dict] = []  # {t, cpu_percent}: the whole machine (other work included)
        #: Other processes to sample, pid -> name (the users' Locust process).
        self.extra: dict[int, str] = {}
        self.metrics: list[dict] = []  # {t, frames_done, tiles_queued, tiles_running, ms}
        self._procs: dict[int, object] = {}

    def _label(self, proc) -> str:
        cmd = " ".join(proc.cmdline())
        if "redis-server" in cmd:
            return "redis"
        if "celery" in cmd and "--hostname" in cmd:
            return "worker " + cmd.split("--hostname", 1)[1].split()[0].split("@")[0]
        if proc.pid == self.root_pid:
            return "api"
        return proc.name()

    def _sample_processes(self, now: float) -> None:
        import psutil

        self.machine.append({"t": now, "cpu_percent": psutil.cpu_percent(None)})
        procs = []
        for pid in list(self.extra):
            try:
                procs.append(psutil.Process(pid))
            except psutil.Error:
                self.extra.pop(pid, None)
        try:
            if self.root_pid:
                root = psutil.Process(self.root_pid)
                procs += [root] + root.children(recursive=True)
        except psutil.Error:
            pass
        for p in procs:
            try:
                if p.pid not in self._procs:
                    self._procs[p.pid] = p
                    p.cpu_percent(None)  # the first call starts the CPU clock
                    continue
                p = self._procs[p.pid]
                cpu = p.cpu_times()
                self.processes.append({"t": now, "name": self.extra.get(p.pid) or self._label(p), "pid": p.pid,
                                       "rss_mb": p.memory_info().rss / 2**20, "cpu_percent": p.cpu_percent(None),
                                       "cpu_s": cpu.user + cpu.system})
            except psutil.Error:
                continue

    def _sample_metrics(self, client: httpx.Client, now: float) -> None:
        t = time.perf_counter()
        try:
            text = client.get(self.url + "/metrics", timeout=30).text
        except httpx.HTTPError:
            return
        values = {}
        for line in text.splitlines():
            if line and not line.startswith("#"):
                key, _, value = line.rpartition(" ")
                values[key] = float(value)
        self.metrics.append({"t": now, "ms": 1000 * (time.perf_counter() - t),
                             "frames_done": values.get("argand_frames_done_total", 0.0),
                             "tiles_queued": values.get('argand_tiles{status="queued"}', 0.0),
                             "tiles_running": values.get('argand_tiles{status="running"}', 0.0)})

    def run(self) -> None:
        with httpx.Client() as client:
            while not self.stop.is_set():
                now = time.time()
                self._sample_processes(now)
                self._sample_metrics(client, now)
                self.stop.wait(self.interval)


# ---------------------------------------------------------------------------
# Running the users (a Locust process)
# ---------------------------------------------------------------------------


def run_users(url: str, schedule: list[tuple[float, int]], work: Path, tag: str, seed: int, presets: list[str],
              known_jobs: list[dict], wait_s: tuple[float, float], sse_hold_s: float,
              sampler: FarmSampler | None = None) -> dict:
    """Runs argand.bench.load_users through ``schedule`` ([seconds, users])
    and returns its result with the request rows under "rows"."""
    config = {"url": url, "schedule": schedule, "seed": seed, "presets": presets, "known_jobs": known_jobs,
              "wait_s": list(wait_s), "sse_hold_s": sse_hold_s,
              "samples": str(work / f"{tag}-rows.json"), "result": str(work / f"{tag}-result.json")}
    path = work / f"{tag}-config.json"
    path.write_text(json.dumps(config))
    budget = sum(s for s, _ in schedule) + 120
    with open(work / f"{tag}-locust.log", "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "argand.bench.load_users", str(path)], stdout=log,
                                stderr=subprocess.STDOUT)
        if sampler is not None:
            sampler.extra[proc.pid] = "users (locust)"
        try:
            proc.wait(budget)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    if proc.returncode != 0:
        raise RuntimeError(f"the users' process failed ({proc.returncode}): "
                           f"{(work / f'{tag}-locust.log').read_text()[-2000:]}")
    result = json.loads(Path(config["result"]).read_text())
    result["rows"] = json.loads(Path(config["samples"]).read_text())
    return result


# ---------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------


def percentiles(ms: list[float]) -> dict:
    if not ms:
        return {"p50_ms": None, "p95_ms": None, "p99_ms": None, "max_ms": None}
    a = np.asarray(ms)
    p50, p95, p99 = np.percentile(a, [50, 95, 99])
    return {"p50_ms": float(p50), "p95_ms": float(p95), "p99_ms": float(p99), "max_ms": float(a.max())}


def endpoint_stats(rows: list[list], t0: float, t1: float) -> dict:
    """Per endpoint over [t0, t1): requests, requests/s, latency percentiles
    (successful and failed requests alike), failures and a few of their
    messages. Rows: [t, name, ms, ok, bytes, users, error]."""
    span = max(t1 - t0, 1e-9)
    by: dict[str, list[list]] = {}
    for r in rows:
        if t0 <= r[0] < t1:
            by.setdefault(r[1], []).append(r)
    out = {}
    for name in sorted(by):
        rs = by[name]
        errors = [r[6] for r in rs if not r[3]]
        out[name] = {"requests": len(rs), "rps": len(rs) / span, **percentiles([r[2] for r in rs]),
                     "failures": len(errors), "failure_examples": sorted(set(errors))[:3]}
    return out


def group_p99(rows: list[list], t0: float, t1: float, names: tuple[str, ...]) -> float | None:
    return percentiles([r[2] for r in rows if t0 <= r[0] < t1 and r[1] in names])["p99_ms"]


def ramp_steps(rows: list[list], phases: list[dict]) -> list[dict]:
    """Each step of the ramp: users, requests/s, the target groups' p99 and
    failures (the step's first SETTLE_S seconds left out)."""
    steps = []
    for a, b in zip(phases, phases[1:]):
        t0, t1 = a["t"] + SETTLE_S, b["t"]
        inside = [r for r in rows if t0 <= r[0] < t1]
        steps.append({"users": a["users"], "t0": t0, "t1": t1, "requests": len(inside),
                      "rps": len(inside) / max(t1 - t0, 1e-9), "failures": sum(1 for r in inside if not r[3]),
                      "status_list_p99_ms": group_p99(rows, t0, t1, STATUS_LIST),
                      "frame_download_p99_ms": group_p99(rows, t0, t1, FRAME_DOWNLOADS),
                      "all_p50_ms": percentiles([r[2] for r in inside])["p50_ms"]})
    return steps


def meets_targets(step: dict) -> bool:
    sl, fd = step["status_list_p99_ms"], step["frame_download_p99_ms"]
    return (step["failures"] == 0 and (sl is None or sl <= TARGETS["status_list_p99_ms"])
            and (fd is None or fd <= TARGETS["frame_download_p99_ms"]))


def knee(steps: list[dict]) -> dict:
    """The latency knee: the first step that misses a target (or fails a
    request); the sustainable level: the step before it (the first step if
    even that one misses). The throughput knee: the first step whose
    requests/s per user falls below 60% of the best of the steps before it
    (more users, little more throughput: the farm is saturated)."""
    latency = next((s for s in steps if not meets_targets(s)), None)
    index = steps.index(latency) if latency else len(steps)
    sustainable = steps[max(0, index - 1)]["users"] if steps else 1
    throughput = None
    best = 0.0
    for s in steps:
        per_user = s["rps"] / max(s["users"], 1)
        if best and per_user < 0.6 * best:
            throughput = s
            break
        best = max(best, per_user)
    return {"latency_knee_users": latency["users"] if latency else None,
            "throughput_knee_users": throughput["users"] if throughput else None,
            "sustainable_users": sustainable, "first_step_meets_targets": bool(steps) and meets_targets(steps[0]),
            "max_rps": max((s["rps"] for s in steps), default=0.0)}


def time_series(rows: list[list], metrics: list[dict], processes: list[dict], t_start: float, bin_s: float) -> dict:
    """Per bin of ``bin_s`` seconds since ``t_start``: users, requests/s,
    failures, latency percentiles (status/list, frame downloads), frames/s
    done, and each process's RSS and CPU."""
    end = max([r[0] for r in rows] + [m["t"] for m in metrics] + [t_start + bin_s])
    edges = np.arange(t_start, end + bin_s, bin_s)
    series: dict = {"t": [], "users": [], "rps": [], "failures": [], "status_list": {"p50": [], "p95": [], "p99": []},
                    "frames_dl_p99": [], "frames_per_s": [], "rss_mb": {}, "cpu_percent": {}}
    for a, b in zip(edges, edges[1:]):
        inside = [r for r in rows if a <= r[0] < b]
        sl = [r[2] for r in inside if r[1] in STATUS_LIST]
        series["t"].append(float(a - t_start))
        series["users"].append(max((r[5] for r in inside), default=0))
        series["rps"].append(len(inside) / bin_s)
        series["failures"].append(sum(1 for r in inside if not r[3]))
        pc = np.percentile(sl, [50, 95, 99]).tolist() if sl else [None] * 3
        for k, v in zip(("p50", "p95", "p99"), pc):
            series["status_list"][k].append(v)
        series["frames_dl_p99"].append(percentiles([r[2] for r in inside if r[1] in FRAME_DOWNLOADS])["p99_ms"])
        ms = [m for m in metrics if a <= m["t"] < b]
        before = [m for m in metrics if m["t"] < a]
        series["frames_per_s"].append((ms[-1]["frames_done"] - before[-1]["frames_done"]) / (ms[-1]["t"] - before[-1]["t"])
                                      if ms and before else None)
    names = sorted({p["name"] for p in processes})
    for name in names:
        rss, cpu = [], []
        for a, b in zip(edges, edges[1:]):
            ps = [p for p in processes if p["name"] == name and a <= p["t"] < b]
            rss.append(max(p["rss_mb"] for p in ps) if ps else None)
            cpu.append(float(np.mean([p["cpu_percent"] for p in ps])) if ps else None)
        series["rss_mb"][name] = rss
        series["cpu_percent"][name] = cpu
    return series


# ---------------------------------------------------------------------------
# Jobs: drain, replay, and what the database says
# ---------------------------------------------------------------------------


def job_views(client: httpx.Client, ids: list[str]) -> dict[str, dict]:
    out = {}
    for job_id in ids:
        r = client.get(f"/api/jobs/{job_id}", timeout=60)
        out[job_id] = r.json() if r.status_code == 200 else {"id": job_id, "status": f"http {r.status_code}"}
    return out


def drain(client: httpx.Client, ids: list[str], timeout_s: float, progress: Callable[[str], None]) -> dict:
    """Waits until every job has ended. A job left paused (a user stopped
    between pause and resume) is resumed. Returns the last views."""
    deadline = time.monotonic() + timeout_s
    resumed: list[str] = []
    while True:
        views = job_views(client, ids)
        open_ = [v for v in views.values() if v["status"] not in ENDED]
        for v in open_:
            if v["status"] == "paused":
                client.post(f"/api/jobs/{v['id']}/resume", timeout=60)
                resumed.append(v["id"])
        progress(f"drain: {len(ids) - len(open_)}/{len(ids)} jobs ended")
        if not open_ or time.monotonic() > deadline:
            return {"views": views, "resumed_at_drain": sorted(set(resumed))}
        time.sleep(1.0)


def tiles_rendered_twice(database: Path | None) -> int | None:
    """Tiles whose completed render was written more than once (from the
    farm's SQLite file; None when the harness did not start the farm)."""
    if database is None or not database.exists():
        return None
    with sqlite3.connect(f"file:{database}?mode=ro", uri=True, timeout=60) as db:
        return int(db.execute("SELECT count(*) FROM tiles WHERE renders > 1").fetchone()[0])


def frames_in(views: dict[str, dict], t0: float, t1: float) -> list[tuple[dict, list[dict]]]:
    """The frames (with their jobs) that the farm finished in [t0, t1)."""
    out = []
    for v in views.values():
        frames = [f for f in v.get("frames", []) if f["status"] == "done" and f["finished"] and t0 <= f["finished"] < t1]
        if frames:
            out.append((v, frames))
    return out


def replay(client: httpx.Client, work: list[tuple[dict, list[dict]]], timeout_s: float) -> dict:
    """The same frames rendered again by the idle farm, one job per original
    job (same scene, size, tile, method, sigma; those deltas). Returns the
    server's time from the first creation to the last frame."""
    ids = []
    for view, frames in work:
        body = {"scene": view["scene_name"] if view["scene_name"] != "custom" else view["scene"],
                "sigma": view["sigma"], "deltas": [f["delta"] for f in frames], "width": view["width"],
                "height": view["height"], "tile": view["tile"], "method": view["method"], "priority": 9}
        r = client.post("/api/jobs", json=body, timeout=120)
        r.raise_for_status()
        ids.append(r.json()["id"])
    deadline = time.monotonic() + timeout_s
    while True:
        views = job_views(client, ids)
        if all(v["status"] in ENDED for v in views.values()) or time.monotonic() > deadline:
            break
        time.sleep(0.5)
    done = all(v["status"] == "done" for v in views.values())
    created = min(v["created"] for v in views.values())
    finished = max((f["finished"] or 0.0) for v in views.values() for f in v["frames"])
    return {"jobs": len(ids), "frames": sum(len(f) for _, f in work), "all_done": done, "seconds": finished - created,
            "t0": created, "t1": finished}


class Filler(threading.Thread):
    """Keeps one low-priority job on the farm (a new one when the last ends)
    so that the workers render all the time; ``finish`` cancels the last."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True, name="argand-load-filler")
        self.client = httpx.Client(base_url=url)
        self.ids: list[str] = []
        self.canceled: list[str] = []
        self.stop = threading.Event()

    def _submit(self) -> None:
        r = self.client.post("/api/jobs", json=FILLER, timeout=120)
        r.raise_for_status()
        self.ids.append(r.json()["id"])

    def run(self) -> None:
        while not self.stop.wait(1.0):
            if self.client.get(f"/api/jobs/{self.ids[-1]}", timeout=60).json()["status"] in ENDED:
                self._submit()

    def start(self) -> None:
        self._submit()
        super().start()

    def finish(self) -> None:
        self.stop.set()
        self.join(120)
        self.client.post(f"/api/jobs/{self.ids[-1]}/cancel", timeout=60)
        self.canceled.append(self.ids[-1])
        self.client.close()


def cpu_use(sampler: FarmSampler, t0: float, t1: float) -> dict:
    """Cores used over [t0, t1] (CPU seconds / wall seconds) by the workers,
    the API, Redis, the users' process, and the whole machine."""
    out = {"workers": 0.0, "api": 0.0, "redis": 0.0, "users (locust)": 0.0}
    by_pid: dict[int, list[dict]] = {}
    for p in sampler.processes:
        if t0 <= p["t"] <= t1:
            by_pid.setdefault(p["pid"], []).append(p)
    for samples in by_pid.values():
        name = samples[0]["name"]
        key = "workers" if name.startswith("worker") else name
        if key in out and len(samples) > 1:
            out[key] += (samples[-1]["cpu_s"] - samples[0]["cpu_s"]) / max(samples[-1]["t"] - samples[0]["t"], 1e-9)
    machine = [m["cpu_percent"] for m in sampler.machine if t0 <= m["t"] <= t1]
    out["machine"] = float(np.mean(machine)) / 100 * (os.cpu_count() or 1) if machine else None
    return out


# ---------------------------------------------------------------------------
# The benchmark
# ---------------------------------------------------------------------------

#: The filler job: the lowest priority, as large as the users' largest jobs.
FILLER = {"scene": "bicube", "width": 256, "height": 256, "deltas": {"start": 0, "stop": "pi/9", "count": 24},
          "priority": 0}


def bench_load(out_dir: Path = Path("docs/bench"), url: str | None = None, smoke: bool = False,
               ramp_users: tuple[int, ...] | None = None, step_s: float | None = None, steady_s: float | None = None,
               steady_users: int | None = None, drain_timeout_s: float | None = None, seed: int = 1,
               profile: bool = False, probes: bool | None = None,
               progress: Callable[[str], None] = lambda m: None) -> dict:
    """Ramp, steady, drain (see the module's text); writes load.json,
    load.md and load.png into ``out_dir`` and returns the report."""
    from argand.bench.farm import LocalFarm

    ramp_users = ramp_users or ((1, 4) if smoke else (1, 5, 10, 20, 40, 60))
    probes = (not smoke) if probes is None else probes
    step_s = step_s or (4.0 if smoke else 20.0)
    steady_s = steady_s or (6.0 if smoke else 90.0)
    drain_timeout_s = drain_timeout_s or (120.0 if smoke else 600.0)
    wait_s, sse_hold_s = ((0.2, 0.8), 3.0) if smoke else ((0.5, 2.0), 15.0)
    with tempfile.TemporaryDirectory(prefix="argand-bench-load-") as tmp:
        work = Path(tmp)
        if url is None:
            progress("starting argand serve --workers 2")
            with LocalFarm(work / "farm", 2) as farm:
                report = _bench(farm.url, farm.proc.pid, work / "farm" / "argand.db", work, smoke, ramp_users, step_s,
                                steady_s, steady_users, drain_timeout_s, seed, wait_s, sse_hold_s, profile, probes,
                                progress)
        else:
            report = _bench(url.rstrip("/"), None, None, work, smoke, ramp_users, step_s, steady_s, steady_users,
                            drain_timeout_s, seed, wait_s, sse_hold_s, False, probes, progress)
    out_dir.mkdir(parents=True, exist_ok=True)
    series = report.pop("series")
    if report.get("profile"):  # py-spy's collapsed stacks of the API, for a closer look
        (out_dir / "load_profile.txt").write_text(report["profile"].pop("raw"))
    (out_dir / "load.json").write_text(json.dumps(dict(report, series=series), indent=1) + "\n")
    (out_dir / "load.md").write_text(markdown(report))
    chart(report, series, out_dir / "load.png")
    report["series"] = series
    return report


def _bench(url, root_pid, database, work, smoke, ramp_users, step_s, steady_s, steady_users, drain_timeout_s, seed,
           wait_s, sse_hold_s, profile, probes, progress) -> dict:
    client = httpx.Client(base_url=url)
    presets = [p["name"] for p in client.get("/api/presets", timeout=120).json()]
    api_pid = root_pid
    sampler = FarmSampler(url, root_pid)
    t_start = time.time()
    sampler.start()
    try:
        # 1. The ramp.
        progress(f"ramp: {' -> '.join(map(str, ramp_users))} users, {step_s:g} s each")
        ramp = run_users(url, [(step_s, u) for u in ramp_users], work, "ramp", seed, presets, [], wait_s, sse_hold_s,
                         sampler)
        steps = ramp_steps(ramp["rows"], ramp["phases"])
        found = knee(steps)
        users = steady_users or found["sustainable_users"]
        # 2. The steady phase, with a filler job keeping both workers busy.
        filler = Filler(url)
        filler.start()
        known = client.get("/api/jobs?per_page=200", timeout=60).json()["jobs"]
        profiler = _start_profiler(api_pid, steady_s, work) if profile and api_pid else None
        progress(f"steady: {users} users for {steady_s:g} s")
        steady = run_users(url, [(steady_s, users)], work, "steady", seed + 1, presets, known, wait_s, sse_hold_s,
                           sampler)
        t0, t1 = steady["phases"][0]["t"] + SETTLE_S, steady["phases"][-1]["t"]
        filler.finish()
        profile_report = _stop_profiler(profiler) if profiler else None
        # 3. The drain.
        accepted = [s["id"] for s in ramp["submitted"] + steady["submitted"]]
        canceled = set(ramp["canceled"] + steady["canceled"] + filler.canceled)
        ended = drain(client, accepted + filler.ids, drain_timeout_s, progress)
        t_drained = time.time()
        views = ended["views"]
        lost = sorted(j for j, v in views.items() if v["status"] not in ENDED)
        unexpected = sorted(j for j, v in views.items() if v["status"] in ENDED and
                            v["status"] != ("canceled" if j in canceled else "done")
                            and not (j in canceled and v["status"] == "done"))
        # 4. Throughput: the steady phase's frames again, on the idle farm.
        window = frames_in(views, t0, t1)
        frames_loaded = sum(len(f) for _, f in window)
        progress(f"replaying the steady phase's {frames_loaded} frames on the idle farm")
        replayed = replay(client, window, drain_timeout_s) if window else None
        # 5. Probes for the diagnosis, on the idle farm full of the run's jobs.
        diagnosis = None
        if probes:
            done = [views[j] for j in accepted if views[j]["status"] == "done"] or list(views.values())
            target = max(done, key=lambda v: len(v.get("frames", [])))["id"]
            workers = sorted({p["pid"] for p in sampler.processes if p["name"].startswith("worker")})
            diagnosis = probe(url, api_pid, workers if root_pid else [], target, smoke, progress)
        busy = [m for m in sampler.metrics if t0 <= m["t"] < t1]
        saturated = sum(1 for m in busy if m["tiles_queued"] + m["tiles_running"] >= 2) / max(len(busy), 1)
    finally:
        sampler.stop.set()
        sampler.join(10)
        client.close()
    rows = ramp["rows"] + steady["rows"]
    exceptions = ramp["exceptions"] + steady["exceptions"]
    steady_stats = endpoint_stats(steady["rows"], t0, t1)
    throughput = None
    if replayed and replayed["all_done"]:
        loaded_fps = frames_loaded / (t1 - t0)
        unloaded_fps = replayed["frames"] / replayed["seconds"]
        r0, r1 = replayed["t0"], replayed["t1"]
        throughput = {"frames": frames_loaded, "loaded_s": t1 - t0, "unloaded_s": replayed["seconds"],
                      "loaded_fps": loaded_fps, "unloaded_fps": unloaded_fps, "share": loaded_fps / unloaded_fps,
                      "workers_saturated_share": saturated,
                      # where the machine's CPU went (seconds of CPU per second of wall time, i.e. cores)
                      "cores_loaded": cpu_use(sampler, t0, t1), "cores_unloaded": cpu_use(sampler, r0, r1),
                      "worker_cpu_s_per_frame_loaded": cpu_use(sampler, t0, t1)["workers"] * (t1 - t0) / frames_loaded,
                      "worker_cpu_s_per_frame_unloaded": cpu_use(sampler, r0, r1)["workers"] * (r1 - r0) / replayed["frames"]}
    status_counts: dict[str, int] = {}
    for j in accepted:
        status_counts[views[j]["status"]] = status_counts.get(views[j]["status"], 0) + 1
    jobs = {"accepted": len(accepted), "ended": len(accepted) - len([j for j in lost if j in accepted]),
            "by_status": status_counts, "canceled_by_users": len(set(ramp["canceled"] + steady["canceled"])),
            "lost": lost, "unexpected_end": unexpected, "resumed_at_drain": ended["resumed_at_drain"],
            "drain_s": t_drained - t1, "filler_jobs": filler.ids}
    steady_group = {"status_list_p99_ms": group_p99(steady["rows"], t0, t1, STATUS_LIST),
                    "frame_download_p99_ms": group_p99(steady["rows"], t0, t1, FRAME_DOWNLOADS),
                    "failures": sum(s["failures"] for s in steady_stats.values()) + sum(e["count"] for e in steady["exceptions"])}
    twice = tiles_rendered_twice(database)
    verdict = {
        "status_list_p99": _verdict(steady_group["status_list_p99_ms"], TARGETS["status_list_p99_ms"]),
        "frame_download_p99": _verdict(steady_group["frame_download_p99_ms"], TARGETS["frame_download_p99_ms"]),
        "errors": "met" if steady_group["failures"] == 0 and not exceptions else "missed",
        "lost_jobs": "met" if not lost and not unexpected else "missed",
        "tiles_rendered_twice": "unknown" if twice is None else ("met" if twice == 0 else "missed"),
        "throughput": "unknown" if throughput is None else
                      ("met" if throughput["share"] >= TARGETS["throughput_share"] else "missed"),
    }
    processes = sampler.processes
    rss = {name: {"max_mb": max(p["rss_mb"] for p in processes if p["name"] == name),
                  "last_mb": [p["rss_mb"] for p in processes if p["name"] == name][-1],
                  "mean_cpu_percent_steady": float(np.mean([p["cpu_percent"] for p in processes
                                                            if p["name"] == name and t0 <= p["t"] < t1] or [0.0]))}
           for name in sorted({p["name"] for p in processes})}
    return {
        "benchmark": "load",
        "machine": machine_info(),
        "smoke": smoke,
        "url": None if root_pid else url,
        "config": {"ramp_users": list(ramp_users), "step_s": step_s, "steady_s": steady_s, "steady_users": users,
                   "wait_s": list(wait_s), "sse_hold_s": sse_hold_s, "seed": seed, "filler": FILLER,
                   "settle_s": SETTLE_S},
        "targets": TARGETS,
        "ramp": {"steps": steps, "endpoints": endpoint_stats(ramp["rows"], ramp["phases"][0]["t"], ramp["phases"][-1]["t"])},
        "knee": found,
        "steady": {"users": users, "seconds": t1 - t0, "endpoints": steady_stats, **steady_group},
        "exceptions": exceptions,
        "jobs": jobs,
        "tiles_rendered_twice": twice,
        "throughput": throughput,
        "processes": rss,
        "metrics_ms": percentiles([m["ms"] for m in sampler.metrics]),
        "verdict": verdict,
        "profile": profile_report,
        "probes": diagnosis,
        "phases_s": {"ramp": [ramp["phases"][0]["t"] - t_start, ramp["phases"][-1]["t"] - t_start],
                     "steady": [t0 - t_start, t1 - t_start], "drain": [t1 - t_start, t_drained - t_start]},
        "series": time_series(rows, sampler.metrics, processes, t_start, 1.0 if smoke else 5.0),
    }


def _verdict(value: float | None, limit: float) -> str:
    return "unknown" if value is None else ("met" if value <= limit else "missed")


def _start_profiler(pid: int, seconds: float, work: Path):
    """py-spy on the API process for the steady phase (if py-spy is here)."""
    spy = Path(sys.executable).with_name("py-spy")
    if not spy.exists():
        return None
    out = work / "api-profile.txt"
    # --idle: a thread waiting inside SQLite (a lock) or Redis is sampled too;
    # summarize_profile tells waiting for work from waiting inside a request.
    proc = subprocess.Popen([str(spy), "record", "--pid", str(pid), "--duration", str(int(seconds)), "--rate", "50",
                             "--format", "raw", "--threads", "--idle", "--output", str(out), "--nonblocking"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return proc, out


def _stop_profiler(profiler) -> dict | None:
    proc, out = profiler
    try:
        proc.wait(60)
    except subprocess.TimeoutExpired:
        proc.kill()
        return None
    if not out.exists():
        return None
    raw = out.read_text()
    return dict(summarize_profile(raw), raw=raw)


def _thread_kind(frames: list[str]) -> str:
    """Which of the API's threads a stack is from (py-spy --threads puts
    'thread (id): name' first)."""
    stack = ";".join(frames)
    if "_reaper" in stack:
        return "reaper"
    if "AnyIO worker thread" in frames[0] or "WorkerThread.run" in stack:
        return "threadpool (sync endpoints)"
    return "event loop"


def _function(frame: str) -> str:
    """'name (path/to/file.py:12)' -> 'name (file.py)'."""
    name, _, where = frame.partition(" (")
    return f"{name} ({where.split(':')[0].rsplit('/', 1)[-1]})" if where else name


#: Leaves where a thread waits (not work): a queue, a lock, the selector.
IDLE_LEAVES = ("Condition.wait", "Event.wait", "select (", "epoll", "Runner.run", "_run_once", "WorkerThread.run",
               "Condition.notify", "run_forever")
#: Functions whose inclusive share of the API's busy samples the diagnosis cites.
NAMED = ("list_jobs", "get_job", "job_view", "job_progress", "_emit_lazyload", "submit", "create_job", "_send",
         "control", "set_job_status", "dispatch_job", "patch", "stream", "reap", "_file", "metrics", "validate_scene",
         "do_execute", "do_commit", "send_task")
#: Our own functions worth naming in the summary.
OWN = ("argand/", "api/main.py", "worker/farm.py", "api/db.py")


def summarize_profile(collapsed: str, top: int = 12) -> dict:
    """From py-spy's collapsed stacks of the API: busy samples (the leaf is
    not a wait) per kind of thread, and per kind the project's functions on
    the stack in the most busy samples (inclusive) with their share."""
    busy: dict[str, int] = {}
    inclusive: dict[str, dict[str, int]] = {}
    named: dict[str, int] = {}
    idle = 0
    for line in collapsed.splitlines():
        stack, _, count = line.rpartition(" ")
        if not stack or not count.isdigit():
            continue
        n = int(count)
        frames = stack.split(";")
        if any(w in frames[-1] for w in IDLE_LEAVES):
            idle += n
            continue
        kind = _thread_kind(frames)
        busy[kind] = busy.get(kind, 0) + n
        names = {f.split(" (")[0].rsplit(".", 1)[-1] for f in frames[1:]}
        for name in NAMED:
            if name in names:
                named[name] = named.get(name, 0) + n
        table = inclusive.setdefault(kind, {})
        for f in {_function(f) for f in frames[1:] if any(o in f for o in OWN)}:
            table[f] = table.get(f, 0) + n
    total = sum(busy.values())
    return {"busy_samples": busy, "idle_samples": idle, "busy_total": total,
            "named_share_of_busy": {k: named.get(k, 0) / max(total, 1) for k in NAMED},
            "top_own_functions": {kind: [{"function": f, "samples": n, "share_of_busy": n / max(total, 1)}
                                         for f, n in sorted(table.items(), key=lambda kv: -kv[1])[:top]]
                                  for kind, table in inclusive.items()}}


# ---------------------------------------------------------------------------
# Probes: what a request costs, and what slows it (for the diagnosis)
# ---------------------------------------------------------------------------


def _latencies(url: str, path: str, clients: int, per_client: int) -> tuple[list[float], float]:
    """``clients`` threads each GET ``path`` ``per_client`` times in a row;
    returns the latencies (ms) and the wall time."""
    out: list[float] = []
    errors: list[str] = []

    def run() -> None:
        with httpx.Client(base_url=url) as c:
            for _ in range(per_client):
                t = time.perf_counter()
                r = c.get(path, timeout=120)
                out.append(1000 * (time.perf_counter() - t))
                if r.status_code != 200:
                    errors.append(f"{path}: {r.status_code}")

    threads = [threading.Thread(target=run) for _ in range(clients)]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise RuntimeError(f"probe failed: {errors[:3]}")
    return out, time.perf_counter() - start


def _process_cpu_s(pid: int | None) -> float | None:
    if pid is None:
        return None
    import psutil

    c = psutil.Process(pid).cpu_times()
    return c.user + c.system


class _EventStreams:
    """``n`` clients holding a job's SSE stream open (reading it)."""

    def __init__(self, url: str, job_id: str, n: int) -> None:
        self.url, self.job_id, self.n = url, job_id, n
        self.stop = threading.Event()
        self.events = 0

    def _hold(self) -> None:
        with httpx.Client(base_url=self.url, timeout=None) as c:
            with c.stream("GET", f"/api/jobs/{self.job_id}/events") as r:
                for line in r.iter_lines():
                    self.events += line.startswith("event:")
                    if self.stop.is_set():
                        return

    def __enter__(self) -> "_EventStreams":
        self.threads = [threading.Thread(target=self._hold, daemon=True) for _ in range(self.n)]
        for t in self.threads:
            t.start()
        time.sleep(1.0)
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()


def probe(url: str, api_pid: int | None, worker_pids: list[int], job_id: str, smoke: bool,
          progress: Callable[[str], None]) -> dict:
    """Latency of the list (20 jobs a page) and of one job's status, with 1
    and 8 clients in a row, under conditions that isolate the suspects:
    the idle farm; both workers rendering; rendering with N clients holding
    SSE streams; rendering with the workers at a lower CPU priority
    (nice 10, set from here: an experiment, only on a farm the harness
    started). Also the API's CPU time per request (one client, idle farm)."""
    import psutil

    client = httpx.Client(base_url=url)
    per = 10 if smoke else 40
    paths = {"list": "/api/jobs?per_page=20", "status": f"/api/jobs/{job_id}"}
    out: dict = {"conditions": {}, "api_cpu_ms_per_request": {}}

    def measure(condition: str) -> None:
        rows = {}
        for what, path in paths.items():
            for clients in (1, 8):
                cpu0 = _process_cpu_s(api_pid)
                ms, wall = _latencies(url, path, clients, per if clients == 1 else per // 2)
                cpu1 = _process_cpu_s(api_pid)
                rows[f"{what}, {clients} client(s)"] = {**percentiles(ms), "rps": len(ms) / wall,
                                                        "api_cores": None if cpu0 is None else (cpu1 - cpu0) / wall}
                if condition == "idle farm" and clients == 1 and cpu0 is not None:
                    out["api_cpu_ms_per_request"][what] = 1000 * (cpu1 - cpu0) / len(ms)
        out["conditions"][condition] = {"load_average_1min": os.getloadavg()[0], "rows": rows}

    progress("probe: the idle farm")
    measure("idle farm")
    filler = client.post("/api/jobs", json=dict(FILLER, deltas={"start": 0, "stop": "pi/6", "count": 400}),
                         timeout=120).json()["id"]
    try:
        time.sleep(2.0)
        progress("probe: both workers rendering")
        measure("workers rendering")
        streams = 4 if smoke else 20
        progress(f"probe: rendering, {streams} SSE streams open")
        with _EventStreams(url, filler, streams) as held:
            measure(f"workers rendering, {streams} SSE streams open")
        out["sse_events_read"] = held.events
        if worker_pids:
            progress("probe: rendering, workers at nice 10")
            procs = [psutil.Process(p) for p in worker_pids]
            before = [p.nice() for p in procs]
            for p in procs:
                p.nice(10)
            try:
                measure("workers rendering at nice 10")
            finally:
                for p, n in zip(procs, before):
                    try:
                        p.nice(n)
                    except psutil.Error:  # lowering it back needs root; the farm ends soon anyway
                        pass
    finally:
        client.post(f"/api/jobs/{filler}/cancel", timeout=60)
        client.close()
    return out


# ---------------------------------------------------------------------------
# Markdown and chart
# ---------------------------------------------------------------------------


def _ms(v) -> str:
    return "–" if v is None else f"{v:.0f}"


def endpoint_table(stats: dict) -> list[str]:
    lines = ["| endpoint | requests | req/s | p50 ms | p95 ms | p99 ms | max ms | failures |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in stats.items():
        lines.append(f"| `{name}` | {s['requests']} | {s['rps']:.2f} | {_ms(s['p50_ms'])} | {_ms(s['p95_ms'])} | "
                     f"{_ms(s['p99_ms'])} | {_ms(s['max_ms'])} | {s['failures']} |")
    return lines


def markdown(report: dict) -> str:
    k, st, jobs, v = report["knee"], report["steady"], report["jobs"], report["verdict"]
    lines = [f"Users (Locust) against `argand serve --workers 2` on this machine ({report['machine']['cpu_count']} cores, "
             "shared with the users' own process); everything over loopback HTTP. "
             f"Ramp {' → '.join(map(str, report['config']['ramp_users']))} users, {report['config']['step_s']:g} s a step; "
             f"steady {st['users']} users for {st['seconds']:.0f} s with a low-priority filler job keeping both workers "
             "rendering; then a drain.", "",
             "### Ramp", "",
             "| users | req/s | status+list p99 ms | frame downloads p99 ms | failures | meets targets |",
             "|---:|---:|---:|---:|---:|---|"]
    for s in report["ramp"]["steps"]:
        lines.append(f"| {s['users']} | {s['rps']:.1f} | {_ms(s['status_list_p99_ms'])} | {_ms(s['frame_download_p99_ms'])} | "
                     f"{s['failures']} | {'yes' if meets_targets(s) else 'no'} |")
    lines += ["", f"Latency knee: {k['latency_knee_users'] or 'none within the ramp'} users; throughput knee (requests/s per "
              f"user below 60% of the best before it): {k['throughput_knee_users'] or 'none within the ramp'} "
              f"(at most {k.get('max_rps', 0):.1f} requests/s); "
              f"sustainable: {k['sustainable_users']} users"
              + ("" if k["first_step_meets_targets"] else " (even the first step misses a target)") + ".", "",
              f"### Steady phase ({st['users']} users)", ""]
    lines += endpoint_table(st["endpoints"])
    tp = report["throughput"]
    lines += ["", "| target | value | verdict |", "|---|---:|---|",
              f"| status and list p99 ≤ {report['targets']['status_list_p99_ms']:.0f} ms | {_ms(st['status_list_p99_ms'])} ms | {v['status_list_p99']} |",
              f"| frame downloads p99 ≤ {report['targets']['frame_download_p99_ms']:.0f} ms | {_ms(st['frame_download_p99_ms'])} ms | {v['frame_download_p99']} |",
              f"| 0 errors | {st['failures']} failed requests, {sum(e['count'] for e in report['exceptions'])} exceptions in users | {v['errors']} |",
              f"| 0 lost jobs | {jobs['accepted']} accepted, {jobs['ended']} ended ({', '.join(f'{n} {s}' for s, n in sorted(jobs['by_status'].items()))}); "
              f"lost {len(jobs['lost'])}, ended otherwise than expected {len(jobs['unexpected_end'])} | {v['lost_jobs']} |",
              f"| 0 tiles rendered twice | {report['tiles_rendered_twice'] if report['tiles_rendered_twice'] is not None else 'unknown (farm not ours)'} | {v['tiles_rendered_twice']} |",
              "| rendering under load ≥ 90% of unloaded | " + (
                  f"{100 * tp['share']:.0f}% ({tp['frames']} frames: {tp['loaded_fps']:.2f} frames/s under load, "
                  f"{tp['unloaded_fps']:.2f} idle; workers busy in {100 * tp['workers_saturated_share']:.0f}% of samples)"
                  if tp else "unknown") + f" | {v['throughput']} |",
              ]
    if tp:
        def cores(c: dict) -> str:
            ours = sum(v for k, v in c.items() if k != "machine")
            other = f", everything else on the machine {c['machine'] - ours:.2f}" if c["machine"] is not None else ""
            return ", ".join(f"{k} {v:.2f}" for k, v in c.items() if k != "machine") + other
        lines += ["", f"Where the CPU went (cores in use): under load: {cores(tp['cores_loaded'])}; "
                  f"replay on the idle farm: {cores(tp['cores_unloaded'])}. Worker CPU per frame: "
                  f"{tp['worker_cpu_s_per_frame_loaded']:.3f} s under load, {tp['worker_cpu_s_per_frame_unloaded']:.3f} s idle."]
    lines += ["", f"Drain: {jobs['drain_s']:.1f} s after the users stopped"
              + (f"; {len(jobs['resumed_at_drain'])} job(s) left paused by a stopped user were resumed" if jobs["resumed_at_drain"] else "") + ".",
              "", "Memory (RSS, MB) and CPU of the farm's processes:", "", "| process | max RSS | last RSS | mean CPU % (steady) |",
              "|---|---:|---:|---:|"]
    for name, p in report["processes"].items():
        lines.append(f"| {name} | {p['max_mb']:.0f} | {p['last_mb']:.0f} | {p['mean_cpu_percent_steady']:.0f} |")
    lines += diagnosis_markdown(report)
    found = causes(report)
    if found:
        lines += ["", "### Causes of the misses, and where the fixes belong", ""] + [f"{i}. {c}" for i, c in enumerate(found, 1)]
    if report["exceptions"]:
        lines += ["", "Exceptions in the users' code: " + "; ".join(f"{e['count']}× {e['msg']}" for e in report["exceptions"])]
    failures = [(n, s["failure_examples"]) for n, s in {**report["ramp"]["endpoints"], **st["endpoints"]}.items() if s["failures"]]
    if failures:
        lines += ["", "Failures: " + "; ".join(f"`{n}`: {' / '.join(ex)}" for n, ex in failures)]
    return "\n".join(lines) + "\n"


def diagnosis_markdown(report: dict) -> list[str]:
    """The probes' table and the profile's shares (the figures the causes in
    docs/benchmarks.md cite)."""
    lines: list[str] = []
    pr = report.get("probes")
    if pr:
        lines += ["", "### Probes (after the drain; the farm holds the run's jobs)", "",
                  "Latency in ms (p50 / p99) of `GET /api/jobs?per_page=20` (list) and of one job's `GET /api/jobs/{id}` "
                  "(status), one client or 8 clients sending in a row; the machine's 1-minute load average beside.", "",
                  "| condition | load avg | " + " | ".join(next(iter(pr["conditions"].values()))["rows"]) + " |",
                  "|---|---:|" + "---:|" * len(next(iter(pr["conditions"].values()))["rows"])]
        for name, c in pr["conditions"].items():
            cells = [f"{_ms(r['p50_ms'])} / {_ms(r['p99_ms'])} ({r['rps']:.0f}/s)" for r in c["rows"].values()]
            lines.append(f"| {name} | {c['load_average_1min']:.1f} | " + " | ".join(cells) + " |")
        cpu = pr["api_cpu_ms_per_request"]
        if cpu:
            lines += ["", "The API's CPU time per request (one client, idle farm): "
                      + ", ".join(f"{k} {v:.1f} ms" for k, v in cpu.items()) + "."]
    prof = report.get("profile")
    if prof and prof.get("busy_total"):
        shares = {k: v for k, v in prof["named_share_of_busy"].items() if v >= 0.01}
        lines += ["", f"py-spy on the API during the steady phase: {prof['busy_total']} busy samples ("
                  + ", ".join(f"{k} {v}" for k, v in prof["busy_samples"].items()) + "); share of them inside: "
                  + ", ".join(f"`{k}` {100 * v:.0f}%" for k, v in sorted(shares.items(), key=lambda kv: -kv[1])) + "."]
    return lines


def _row(report: dict, condition: str, row: str) -> dict | None:
    pr = report.get("probes") or {}
    for name, c in pr.get("conditions", {}).items():
        if name.startswith(condition) and (condition != "workers rendering" or name == condition):
            return c["rows"].get(row)
    return None


def causes(report: dict) -> list[str]:
    """The diagnosed causes, each with this run's figures and where its fix
    belongs. The wording follows the figures: a cause the probes do not
    bear out this time is said to be so."""
    out: list[str] = []
    st = report["steady"]["endpoints"]
    prof = (report.get("profile") or {}).get("named_share_of_busy", {})
    cpu = (report.get("probes") or {}).get("api_cpu_ms_per_request", {})
    conditions = (report.get("probes") or {}).get("conditions", {})

    def pct(name: str) -> str:
        return f"{100 * prof.get(name, 0.0):.0f}%"

    def lat(condition: str, row: str) -> str:
        r = _row(report, condition, row)
        return f"{_ms(r['p50_ms'])}/{_ms(r['p99_ms'])} ms" if r else "–"

    downloads = [st[n] for n in FRAME_DOWNLOADS if n in st]
    ramp_low = next((s for s in report["ramp"]["steps"] if s["frame_download_p99_ms"] is not None), None)
    if cpu:
        out.append(
            f"**The job list is expensive, and holds the GIL while it is built.** One page of 20 jobs costs "
            f"{cpu.get('list', 0):.1f} ms of the API's CPU, a job's status {cpu.get('status', 0):.1f} ms (idle farm, "
            f"one client); with 8 clients the idle farm serves at most "
            f"{(_row(report, 'idle farm', 'list, 8 client(s)') or {}).get('rps', 0):.0f} lists/s. `list_jobs` builds "
            "the full `job_view` of every listed job: a lazy load of each job's frames (N+1 queries), every frame's "
            "`figures` JSON decoded and copied, each job's scene JSON; the cost grows with the jobs' frames"
            + (f". In the steady phase `list_jobs` is in {pct('list_jobs')} of the API's active samples, `job_view` "
               f"{pct('job_view')}, SQLAlchemy's lazy loads {pct('_emit_lazyload')}" if prof else "")
            + (f"; the API is one process, so while a list is built every other request waits for the GIL: frame "
               f"downloads (plain files) reach p99 {_ms(max(d['p99_ms'] for d in downloads))} ms in the steady phase"
               + (f" against {_ms(ramp_low['frame_download_p99_ms'])} ms at {ramp_low['users']} users early in the "
                  "ramp, when the list was short" if ramp_low else "") if downloads else "") + ". "
            "Fix: api/main.py `list_jobs`/`job_view` (after the move: the job queries of argand.farm): a list view "
            "without per-frame figures, the progress of every listed job in one aggregate query over frames "
            "(or `selectinload(Job.frames)`), JSON columns deferred; the job's own view keeps its frames.")
    rendering, niced = _row(report, "workers rendering", "list, 1 client(s)"), \
        _row(report, "workers rendering at nice 10", "list, 1 client(s)")
    if rendering and niced:
        gain = rendering["p50_ms"] / max(niced["p50_ms"], 1e-9)
        out.append(
            "**Renders and requests share the CPU at the same priority.** On 2 cores the two workers take what "
            "they can and a request waits its turn behind them. The list with one client (p50/p99): idle farm "
            f"{lat('idle farm', 'list, 1 client(s)')}, workers rendering {lat('workers rendering', 'list, 1 client(s)')}, "
            f"workers at nice 10 {lat('workers rendering at nice 10', 'list, 1 client(s)')}"
            + (f" ({gain:.1f}× faster at the median)" if gain >= 1.2 else
               " (no clear gain in this run: the machine's other load moved more than the priority did)")
            + f"; status with 8 clients: {lat('idle farm', 'status, 8 client(s)')}, "
            f"{lat('workers rendering', 'status, 8 client(s)')}, {lat('workers rendering at nice 10', 'status, 8 client(s)')}. "
            "Fix: worker/serve.py `start_workers` (after the move: where argand.farm starts workers): start the "
            "Celery workers at a lower priority (`os.nice(10)` in a `preexec_fn`, or `nice -n 10` before "
            "`worker_command`); they still get every cycle the API leaves.")
    sse = next((k for k in conditions if "SSE" in k), None)
    if sse:
        without = {k: v for k, v in conditions["workers rendering"]["rows"].items()}
        with_ = conditions[sse]["rows"]
        worst = max(with_, key=lambda k: with_[k]["max_ms"] / max(without[k]["max_ms"], 1e-9))
        out.append(
            "**The SSE poller does database work on the event loop** (a latent cause). `events.stream` "
            "(api/main.py) opens a session and builds the whole `job_view` every 0.5 s per open stream, "
            "synchronously inside the async generator: while it runs, nothing else on the loop moves. "
            f"With {sse.split(', ')[1]} on a job of 400 frames, the request that suffered most was `{worst}`: "
            f"max {_ms(with_[worst]['max_ms'])} ms against {_ms(without[worst]['max_ms'])} ms without streams "
            f"(p50/p99 {lat(sse, worst)} against {lat('workers rendering', worst)})"
            + (f"; at the steady phase's {report['steady']['users']} users `stream` is only {pct('stream')} of the "
               "API's active samples, so it is not what missed the targets there" if prof else "") + ". "
            "Fix: api/main.py `events`: the tick in a thread (`await run_in_threadpool(...)`) and a compact progress "
            "query (counters and frame states) instead of `job_view`; better, one poller per job shared by its "
            "streams.")
    submit = st.get("POST /api/jobs")
    resume = st.get("POST /api/jobs/{id}/resume")
    if submit:
        out.append(
            f"**Celery dispatch in the request path.** `POST /api/jobs` p50/p99 {_ms(submit['p50_ms'])}/"
            f"{_ms(submit['p99_ms'])} ms"
            + (f", resume {_ms(resume['p50_ms'])}/{_ms(resume['p99_ms'])} ms" if resume else "")
            + ": the request inserts every tile and sends every message before it answers (`create_job` → `_send`, "
            "one `send_task` and Redis round trip per message, a `saferepr` of its arguments each)"
            + (f"; `create_job` is in {pct('create_job')} of the API's active samples, `send_task` {pct('send_task')}"
               if prof else "") + ". "
            "Fix: worker/farm.py `_send` (after the move: argand.farm's dispatch): publish a job's messages on one "
            "producer connection (`app.producer_or_acquire()`), or answer 201 once the rows are committed and send "
            "from a background task; the same for `dispatch_job` (resume, priority).")
    if prof:
        sql = prof.get("do_execute", 0.0) + prof.get("do_commit", 0.0)
        if sql < 0.25:
            out.append(
                f"**The SQLite write lock: no evidence.** The API spends {100 * sql:.0f}% of its active samples "
                f"inside SQL statements and commits, waits included (`do_execute` {pct('do_execute')}, `do_commit` "
                f"{pct('do_commit')}); reads run on WAL snapshots and do not wait for the workers' commits.")
        else:
            out.append(
                f"**Time inside SQLite: {100 * sql:.0f}% of the API's active samples** (`do_execute` "
                f"{pct('do_execute')}, `do_commit` {pct('do_commit')}, waits included): load_profile.txt has the "
                "statements; a write waiting for the workers' commits (busy_timeout) shows there.")
    tp = report.get("throughput")
    if tp:
        loaded, idle = tp["cores_loaded"], tp["cores_unloaded"]
        ours = sum(v for k, v in loaded.items() if k != "machine")
        others = (loaded["machine"] - ours) if loaded.get("machine") is not None else None
        others_idle = (idle["machine"] - sum(v for k, v in idle.items() if k != "machine")) \
            if idle.get("machine") is not None else None
        per_frame = tp["worker_cpu_s_per_frame_loaded"] / tp["worker_cpu_s_per_frame_unloaded"] - 1
        out.append(
            f"**Rendering under load: {100 * tp['share']:.0f}% of the idle farm's rate.** The workers had "
            f"{loaded['workers']:.2f} cores under load against {idle['workers']:.2f} in the idle replay, and a frame "
            f"took {100 * per_frame:+.0f}% worker CPU. The API and the users' process took {loaded['api']:.2f} and "
            f"{loaded['users (locust)']:.2f} cores"
            + (f"; other work on this shared machine {others:.2f} cores under load and {others_idle:.2f} during the "
               "replay. Here the farm's own cost cannot be told apart from its neighbours'; on a machine of its "
               "own the API's share is what the list fix reduces" if others is not None else "") + ".")
    return out


def chart(report: dict, series: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array(series["t"])
    fig, (a, b, c) = plt.subplots(3, 1, figsize=(10, 9.5), sharex=True)
    a.plot(t, series["rps"], color="C0", label="requests / s")
    a.set_ylabel("requests / s")
    a2 = a.twinx()
    a2.step(t, series["users"], where="post", color="k", lw=1, label="users")
    fps = [np.nan if v is None else v for v in series["frames_per_s"]]
    a2.plot(t, fps, color="C2", lw=1, label="frames / s rendered")
    a2.set_ylabel("users; frames / s")
    a.legend(loc="upper left", fontsize=8)
    a2.legend(loc="upper right", fontsize=8)
    for key, style in (("p50", ":"), ("p95", "--"), ("p99", "-")):
        b.plot(t, [np.nan if v is None else v for v in series["status_list"][key]], style, color="C3",
               label=f"status + list {key}")
    b.plot(t, [np.nan if v is None else v for v in series["frames_dl_p99"]], color="C4", label="frame downloads p99")
    b.axhline(report["targets"]["status_list_p99_ms"], color="C3", lw=0.8, ls="-.", label="status/list target")
    b.axhline(report["targets"]["frame_download_p99_ms"], color="C4", lw=0.8, ls="-.", label="downloads target")
    b.set_yscale("log")
    b.set_ylabel("latency (ms)")
    b.legend(fontsize=7, ncol=3, loc="upper left")
    for name, rss in series["rss_mb"].items():
        c.plot(t, [np.nan if v is None else v for v in rss], label=f"{name} RSS")
    c.set_ylabel("RSS (MB)")
    c.set_xlabel("seconds since start")
    c3 = c.twinx()
    api_cpu = series["cpu_percent"].get("api")
    if api_cpu:
        c3.plot(t, [np.nan if v is None else v for v in api_cpu], color="0.5", lw=0.8, ls="--", label="api CPU %")
        c3.set_ylabel("api CPU %")
        c3.legend(loc="upper right", fontsize=7)
    c.legend(fontsize=7, loc="upper left")
    for ax in (a, b, c):
        for phase, (s, e) in report["phases_s"].items():
            ax.axvspan(s, e, color={"ramp": "C0", "steady": "C1", "drain": "C2"}[phase], alpha=0.06)
        ax.grid(True, alpha=0.3)
    a.set_title(f"argand bench load: ramp, steady ({report['steady']['users']} users), drain — shaded")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
