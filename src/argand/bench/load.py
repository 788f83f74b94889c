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
from argand.bench.load_diagnosis import probe, start_profiler, stop_profiler
from argand.bench.load_figures import (ENDED, FILLER, FRAME_DOWNLOADS, SETTLE_S, STATUS_LIST, TARGETS, verdict_of,
                                       endpoint_stats, group_p99, knee, percentiles, ramp_steps, time_series)
from argand.bench.load_report import chart, markdown

# ---------------------------------------------------------------------------
# Sampling the farm: processes (psutil) and /metrics
# ---------------------------------------------------------------------------


#: /metrics is scraped every this many process samples (seconds).
METRICS_EVERY = 5


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
        """api, redis, or "worker NAME" for a worker: `argand worker --name
        NAME` (what argand serve starts) or `celery ... worker --hostname
        NAME` (an earlier version)."""
        args = proc.cmdline()
        cmd = " ".join(args)
        if "redis-server" in cmd:
            return "redis"
        for flag in ("--name", "--hostname"):
            if flag in args and ("worker" in args or "celery" in cmd):
                return "worker " + args[args.index(flag) + 1].split("@")[0]
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
            tick = 0
            while not self.stop.is_set():
                now = time.time()
                self._sample_processes(now)
                if tick % METRICS_EVERY == 0:  # /metrics costs the API real work: not every second
                    self._sample_metrics(client, now)
                tick += 1
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
                "sigma": frames[0]["sigma"], "deltas": [f["delta"] for f in frames], "width": view["width"],
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
            # Every simulated user comes from 127.0.0.1: the per-client stream
            # limit (made for distinct addresses) would count them as one client.
            with LocalFarm(work / "farm", 2, env={"ARGAND_MAX_STREAMS_PER_CLIENT": "1000"}) as farm:
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
        profiler = start_profiler(api_pid, steady_s, work) if profile and api_pid else None
        progress(f"steady: {users} users for {steady_s:g} s")
        steady = run_users(url, [(steady_s, users)], work, "steady", seed + 1, presets, known, wait_s, sse_hold_s,
                           sampler)
        t0, t1 = steady["phases"][0]["t"] + SETTLE_S, steady["phases"][-1]["t"]
        filler.finish()
        profile_report = stop_profiler(profiler) if profiler else None
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
        t_replay = time.time()
        replayed = replay(client, window, drain_timeout_s) if window else None
        t_probes = time.time()
        # 5. Probes for the diagnosis, on the idle farm full of the run's jobs.
        diagnosis = None
        if probes:
            done = [views[j] for j in accepted if views[j]["status"] == "done"] or list(views.values())
            target = max(done, key=lambda v: len(v.get("frames", [])))["id"]
            workers = sorted({p["pid"] for p in sampler.processes if p["name"].startswith("worker")})
            diagnosis = probe(url, api_pid, workers if root_pid else [], target, smoke, progress)
        t_end = time.time()
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
        "status_list_p99": verdict_of(steady_group["status_list_p99_ms"], TARGETS["status_list_p99_ms"]),
        "frame_download_p99": verdict_of(steady_group["frame_download_p99_ms"], TARGETS["frame_download_p99_ms"]),
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
                     "steady": [t0 - t_start, t1 - t_start], "drain": [t1 - t_start, t_drained - t_start],
                     "replay": [t_replay - t_start, t_probes - t_start], "probes": [t_probes - t_start, t_end - t_start]},
        "series": time_series(rows, sampler.metrics, processes, t_start, 1.0 if smoke else 5.0),
    }


