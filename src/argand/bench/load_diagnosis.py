"""The load test's evidence for the causes of its misses: py-spy on the API
during the steady phase, and probes that time the list and status requests
under conditions that isolate one suspect each."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable

import httpx

from argand.bench.load_figures import FILLER, percentiles

def start_profiler(pid: int, seconds: float, work: Path):
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


def stop_profiler(profiler) -> dict | None:
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
NAMED = ("list_jobs", "get_job", "job_out", "job_view", "job_progress", "_emit_lazyload", "submit", "create_job",
         "send_messages", "drain", "_send", "_progress",
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
