"""The load harness (argand bench load): its smoke run against a real
two-worker farm (argand serve on a free loopback port, its own data folder),
and the pure functions that turn request rows into the report."""

from __future__ import annotations

import json

import pytest

from argand.bench.load_diagnosis import summarize_profile
from argand.bench.load_figures import (FRAME_DOWNLOADS, STATUS_LIST, TARGETS, endpoint_stats, knee, meets_targets,
                                       percentiles, ramp_steps)
from argand.bench.load_users import check_job_view


@pytest.mark.slow
def test_smoke_run_against_a_real_farm(tmp_path):
    from argand.bench.load import bench_load

    report = bench_load(out_dir=tmp_path, smoke=True)
    steady = report["steady"]["endpoints"]
    ramp = report["ramp"]["endpoints"]
    # The users did what users do, and every response passed its checks.
    assert {"GET /api/jobs", "GET /api/jobs/{id}", "POST /api/jobs"} <= set(ramp) | set(steady)
    assert sum(s["requests"] for s in steady.values()) > 0
    failures = {n: s["failure_examples"] for n, s in {**ramp, **steady}.items() if s["failures"]}
    assert not failures, failures
    assert report["exceptions"] == []
    # Every accepted job ended as it should (done, or canceled by whoever cancelled it).
    jobs = report["jobs"]
    assert jobs["accepted"] > 0
    assert jobs["ended"] == jobs["accepted"] and jobs["lost"] == [] and jobs["unexpected_end"] == []
    assert report["tiles_rendered_twice"] == 0
    # The figures the report is made of are there.
    assert report["throughput"] is not None and report["throughput"]["frames"] > 0
    assert report["processes"]["api"]["max_mb"] > 0
    assert any(name.startswith("worker") for name in report["processes"])
    written = json.loads((tmp_path / "load.json").read_text())
    assert written["jobs"] == jobs and len(written["series"]["t"]) > 0
    assert "| `GET /api/jobs` |" in (tmp_path / "load.md").read_text()
    assert (tmp_path / "load.png").read_bytes().startswith(b"\x89PNG")


def _row(t, name, ms, ok=1, users=1):
    return [t, name, ms, ok, 10, users, None if ok else "boom"]


def test_endpoint_stats_counts_failures_and_percentiles_per_endpoint():
    rows = [_row(100 + i * 0.01, "GET /api/jobs", float(i + 1)) for i in range(100)]
    rows += [_row(100.5, "POST /api/jobs", 50.0, ok=0), _row(99.0, "POST /api/jobs", 1.0)]  # the second is outside
    stats = endpoint_stats(rows, 100.0, 110.0)
    assert stats["GET /api/jobs"]["requests"] == 100
    assert stats["GET /api/jobs"]["rps"] == pytest.approx(10.0)
    assert stats["GET /api/jobs"]["max_ms"] == 100.0
    assert 98.0 <= stats["GET /api/jobs"]["p99_ms"] <= 100.0
    assert stats["POST /api/jobs"]["requests"] == 1 and stats["POST /api/jobs"]["failures"] == 1
    assert stats["POST /api/jobs"]["failure_examples"] == ["boom"]
    assert percentiles([])["p99_ms"] is None


def test_the_knee_is_the_first_step_that_misses_a_target():
    phases = [{"t": 0.0, "users": 1}, {"t": 10.0, "users": 5}, {"t": 20.0, "users": 10}, {"t": 30.0, "users": 0}]
    rows = []
    for t in range(3, 10):
        rows.append(_row(float(t), STATUS_LIST[0], 10.0, users=1))
    for k in range(50):
        rows.append(_row(13 + k * 0.1, STATUS_LIST[1], 20.0, users=5))
        rows.append(_row(13 + k * 0.1, FRAME_DOWNLOADS[0], 30.0, users=5))
    for k in range(100):  # 10 users: status p99 far above the target
        rows.append(_row(23 + k * 0.05, STATUS_LIST[0], TARGETS["status_list_p99_ms"] * 3, users=10))
    steps = ramp_steps(rows, phases)
    assert [s["users"] for s in steps] == [1, 5, 10]
    assert [meets_targets(s) for s in steps] == [True, True, False]
    found = knee(steps)
    assert found["latency_knee_users"] == 10 and found["sustainable_users"] == 5
    # A failed request is a miss whatever the latency.
    steps[1]["failures"] = 1
    assert knee(steps)["latency_knee_users"] == 5 and knee(steps)["sustainable_users"] == 1


def test_the_throughput_knee_is_where_more_users_bring_little_more():
    # requests/s per user: 0.8, 0.7, 0.6, 0.43 (below 60% of the best, 0.8), 0.28
    steps = [{"users": u, "rps": r, "failures": 0, "status_list_p99_ms": 10.0, "frame_download_p99_ms": 10.0}
             for u, r in ((5, 4.0), (10, 7.0), (20, 12.0), (40, 17.2), (60, 17.0))]
    found = knee(steps)
    assert found["throughput_knee_users"] == 40 and found["max_rps"] == 17.2
    assert found["latency_knee_users"] is None and found["sustainable_users"] == 60


def test_check_job_view_refuses_what_the_front_end_could_not_show():
    good = {"id": "a", "status": "running", "progress": 0.5, "tiles_done": 1, "tiles_total": 2, "priority": 5,
            "frames": [{"index": 0, "status": "done", "png_url": "/p", "thumbnail_url": "/t"}]}
    assert check_job_view(good) is None
    assert "progress" in check_job_view(dict(good, progress=1.5))
    assert "status" in check_job_view(dict(good, status="weird"))
    assert "tiles_done" in check_job_view(dict(good, tiles_done=3))
    assert "png_url" in check_job_view(dict(good, frames=[{"index": 0, "status": "done", "png_url": None}]))
    assert "frame" in check_job_view(dict(good, status="done", frames=[{"index": 0, "status": "rendering"}]))
    assert check_job_view([]) == "not a JSON object"


def test_profile_summary_separates_work_from_waiting():
    collapsed = "\n".join([
        "thread (1): AnyIO worker thread;WorkerThread.run (anyio/_backends/_asyncio.py:1);"
        "list_jobs (argand/api/main.py:194);job_view (argand/api/main.py:105) 30",
        "thread (1): AnyIO worker thread;WorkerThread.run (anyio/_backends/_asyncio.py:1);"
        "Condition.wait (threading.py:327) 500",
        "thread (2): MainThread;run (uvicorn/server.py:1);stream (argand/api/main.py:300) 10",
        "thread (3): argand-reaper;_reaper (argand/api/main.py:450);reap (argand/worker/farm.py:560) 5",
    ])
    summary = summarize_profile(collapsed)
    assert summary["idle_samples"] == 500 and summary["busy_total"] == 45
    assert summary["busy_samples"] == {"threadpool (sync endpoints)": 30, "event loop": 10, "reaper": 5}
    assert summary["named_share_of_busy"]["list_jobs"] == pytest.approx(30 / 45)
    assert summary["named_share_of_busy"]["stream"] == pytest.approx(10 / 45)


def test_scrubbers_held_is_the_last_step_whose_bands_kept_p95_with_no_error():
    from argand.bench.load_figures import BAND_P95_MS, ramp_steps, scrubbers_held
    from argand.bench.load_report import band_lines

    def steps(p95s_and_fails):
        rows, phases, t = [], [], 0.0
        for users, (ms, failed) in zip((1, 5, 10, 20), p95s_and_fails):
            phases.append({"t": t, "users": users})
            for k in range(20):  # every band request of the step takes `ms`, `failed` of them fail
                rows.append(_row(t + 3 + k * 0.1, "GET band.png", ms, ok=0 if k < failed else 1, users=users))
            rows.append(_row(t + 3, "GET /api/jobs", 5.0, users=users))
            t += 10.0
        phases.append({"t": t, "users": 0})
        return ramp_steps(rows, phases)

    assert scrubbers_held(steps([(20, 0), (40, 0), (90, 0), (150, 0)])) == 10
    assert scrubbers_held(steps([(20, 0), (40, 1), (50, 0), (60, 0)])) == 1  # an error ends it, later steps or not
    assert scrubbers_held(steps([(BAND_P95_MS + 1, 0), (20, 0), (20, 0), (20, 0)])) is None
    assert scrubbers_held(steps([(BAND_P95_MS, 0)] * 4)) == 20
    text = " ".join(band_lines(steps([(20, 0), (40, 0), (90, 0), (150, 0)])))
    assert "holds 10 users" in text and "20 users 150 ms" in text
    assert band_lines([{"users": 1, "band_p95_ms": None}]) == []  # no band asked: no line


def test_a_lists_summary_is_checked_as_a_summary_and_keeps_what_was_seen_of_the_job():
    from argand.bench.load_users import Shared

    summary = {"id": "j", "status": "done", "progress": 1.0, "tiles_done": 4, "tiles_total": 4, "priority": 5,
               "frames_total": 2, "frames_url": "/api/jobs/j/frames"}
    assert check_job_view(summary, summary=True) is None
    assert "frames" in check_job_view(summary)  # a job's own view lists its frames
    assert "frames_total" in check_job_view({k: v for k, v in summary.items() if k != "frames_total"}, summary=True)
    assert "carries" in check_job_view(dict(summary, frames=[]), summary=True)
    shared = Shared({"seed": 1, "presets": ["bicube"]})
    shared.see({**summary, "status": "running", "frames": [{"index": 0, "status": "rendering", "png_url": None}]})
    shared.see(summary)  # the list says done; the frames seen earlier stay
    assert shared.jobs["j"]["status"] == "done" and shared.jobs["j"]["frames"][0]["index"] == 0
