"""What the load test measures, and the pure functions that turn the users'
request rows [t, name, ms, ok, bytes, users, error] into its figures."""

from __future__ import annotations

import numpy as np

#: The load test's targets on this machine (p99 in ms, throughput share).
TARGETS = {"status_list_p99_ms": 100.0, "frame_download_p99_ms": 200.0, "throughput_share": 0.9}
STATUS_LIST = ("GET /api/jobs", "GET /api/jobs/{id}")
FRAME_DOWNLOADS = ("GET frame.png", "GET thumbnail.png", "GET animation.gif")
#: Users scrubbing the σ and δ sliders of done jobs: each request renders a band.
BANDS = ("GET band.png",)
#: What a scrubbing user needs: bands at p95 within this, and no error.
BAND_P95_MS = 100.0
ENDED = ("done", "failed", "canceled")
#: A step's first seconds are left out of its figures (users arriving).
SETTLE_S = 2.0
#: The filler job: the lowest priority, as large as the users' largest jobs.
FILLER = {"scene": "bicube", "width": 256, "height": 256, "deltas": {"start": 0, "stop": "pi/9", "count": 24},
          "priority": 0}


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
                      "band_p95_ms": percentiles([r[2] for r in inside if r[1] in BANDS])["p95_ms"],
                      "band_failures": sum(1 for r in inside if r[1] in BANDS and not r[3]),
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


def verdict_of(value: float | None, limit: float) -> str:
    return "unknown" if value is None else ("met" if value <= limit else "missed")


def scrubbers_held(steps: list[dict]) -> int | None:
    """The most users of the ramp's steps (from the first) whose band
    requests all kept p95 <= BAND_P95_MS with no error; None when even the
    first step missed (or no band was asked)."""
    held = None
    for s in steps:
        if s.get("band_p95_ms") is None or s["band_p95_ms"] > BAND_P95_MS or s.get("band_failures", 0):
            break
        held = s["users"]
    return held
