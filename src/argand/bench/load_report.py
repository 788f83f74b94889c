"""The load test's page (load.md), its causes and its chart (load.png)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from argand.bench.load_figures import BAND_P95_MS, FRAME_DOWNLOADS, meets_targets, scrubbers_held

def _ms(v) -> str:
    return "–" if v is None else f"{v:.0f}"


def endpoint_table(stats: dict) -> list[str]:
    lines = ["| endpoint | requests | req/s | p50 ms | p95 ms | p99 ms | max ms | failures |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in stats.items():
        lines.append(f"| `{name}` | {s['requests']} | {s['rps']:.2f} | {_ms(s['p50_ms'])} | {_ms(s['p95_ms'])} | "
                     f"{_ms(s['p99_ms'])} | {_ms(s['max_ms'])} | {s['failures']} |")
    return lines


def band_lines(steps: list[dict]) -> list[str]:
    """Users scrubbing σ and δ of done jobs (GET band.png, a band rendered
    on demand): its p95 at each step, and how many users the farm holds."""
    if not any(s.get("band_p95_ms") is not None for s in steps):
        return []
    held = scrubbers_held(steps)
    per_step = ", ".join(f"{s['users']} users {_ms(s.get('band_p95_ms'))} ms" + (f" ({s['band_failures']} failed)"
                                                                                  if s.get("band_failures") else "")
                         for s in steps)
    return [f"Scrubbing (GET band.png, each a band rendered on demand while both workers render): p95 {per_step}. "
            + (f"The two-worker farm holds {held} users (every user scrubs a share of the time) with band requests "
               f"at p95 ≤ {BAND_P95_MS:.0f} ms and no error." if held else
               f"Even the first step's band requests missed p95 ≤ {BAND_P95_MS:.0f} ms (or failed)."), ""]


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
              *band_lines(report["ramp"]["steps"]),
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

    def pct(*names: str) -> str:
        """The largest share the profile saw among ``names`` (one function
        under each name a profile may know it by, so a JSON written by an
        earlier version still reads)."""
        return f"{100 * max(prof.get(n, 0.0) for n in names):.0f}%"

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
            f"{(_row(report, 'idle farm', 'list, 8 client(s)') or {}).get('rps', 0):.0f} lists/s. "
            "src/argand/api/routes/jobs.py `list_jobs` reads a page in four queries whatever it holds (the jobs "
            "with their scene deferred, their progress in one aggregate, src/argand/farm/progress.py "
            "`jobs_progress`, and their frames' plain columns) into src/argand/api/schemas.py `job_summary`, a view "
            "without the scene and the frames' figures; the job's own view (`job_out`) keeps them"
            + (f". In the steady phase `list_jobs` is in {pct('list_jobs')} of the API's active samples, the views "
               f"{pct('job_out', 'job_view')}, SQLAlchemy's lazy loads {pct('_emit_lazyload')}" if prof else "")
            + (f"; the API is one process, so while a list is built every other request waits for the GIL: frame "
               f"downloads (plain files) reach p99 {_ms(max(d['p99_ms'] for d in downloads))} ms in the steady phase"
               + (f" against {_ms(ramp_low['frame_download_p99_ms'])} ms with {ramp_low['users']} user(s) early in the "
                  "ramp, when the list was short" if ramp_low else "") if downloads else "") + ".")
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
            "src/argand/serve/supervisor.py `start_worker` starts each worker at nice 10 (`WORKER_NICE`), so the "
            "probe's 'workers rendering' is already at nice 10 and the last condition renices nothing new; the "
            "workers still get every cycle the API leaves.")
    sse = next((k for k in conditions if "SSE" in k), None)
    if sse:
        without = {k: v for k, v in conditions["workers rendering"]["rows"].items()}
        with_ = conditions[sse]["rows"]
        worst = max(with_, key=lambda k: with_[k]["max_ms"] / max(without[k]["max_ms"], 1e-9))
        out.append(
            "**The SSE poller** (a latent cause): every open event stream needs the job's progress every 0.5 s. "
            f"With {sse.split(', ')[1]} on a job of 400 frames, the request that suffered most was `{worst}`: "
            f"max {_ms(with_[worst]['max_ms'])} ms against {_ms(without[worst]['max_ms'])} ms without streams "
            f"(p50/p99 {lat(sse, worst)} against {lat('workers rendering', worst)})"
            + (f"; at the steady phase's {report['steady']['users']} users `stream` is only {pct('stream')} of the "
               "API's active samples, so it is not what missed the targets there" if prof else "") + ". "
            "src/argand/api/routes/jobs.py `_Poller` keeps one poller per job, shared by its streams, its tick in "
            "the thread pool (`run_in_threadpool`) rather than on the event loop, and a compact progress query "
            "(counters and frame states) rather than the job's whole view.")
    submit = st.get("POST /api/jobs")
    resume = st.get("POST /api/jobs/{id}/resume")
    if submit:
        out.append(
            f"**Celery dispatch in the request path.** `POST /api/jobs` p50/p99 {_ms(submit['p50_ms'])}/"
            f"{_ms(submit['p99_ms'])} ms"
            + (f", resume {_ms(resume['p50_ms'])}/{_ms(resume['p99_ms'])} ms" if resume else "")
            + ": the request inserts every tile and its messages into the outbox in one transaction (`create_job`)"
            + (f"; `create_job` is in {pct('create_job')} of the API's active samples, `drain` {pct('drain')}"
               if prof else "") + ". "
            "The request answers once the rows are committed: a sender thread drains the outbox "
            "(src/argand/farm/outbox.py `drain` -> src/argand/farm/queue.py `send_messages`, one producer "
            "connection), "
            "and the workers' reaper sends whatever an API left behind.")
    scrape = report.get("metrics_ms") or {}
    if prof and prof.get("metrics", 0.0) >= 0.05 and scrape.get("p50_ms"):
        out.append(
            f"**/metrics is expensive.** One scrape took {_ms(scrape['p50_ms'])} ms at the median (p99 "
            f"{_ms(scrape['p99_ms'])} ms), and the harness's scrapes were {pct('metrics')} of the API's active samples "
            "in the steady phase: a read of the histograms counts and bins every tile and frame (the histograms of render, "
            "assembly and queue-wait times) in SQL, so src/argand/farm/metrics.py `FarmCollector` reads the "
            "histograms again only when the tile and frame counts changed, at most every 5 s.")
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
        # (A smoke run's idle replay can be too short for the workers' CPU
        # clock to move: no ratio then.)
        unloaded = tp["worker_cpu_s_per_frame_unloaded"]
        per_frame = tp["worker_cpu_s_per_frame_loaded"] / unloaded - 1 if unloaded > 0 else float("nan")
        out.append(
            f"**Rendering under load: {100 * tp['share']:.0f}% of the idle farm's rate.** The workers had "
            f"{loaded['workers']:.2f} cores under load against {idle['workers']:.2f} in the idle replay, and a frame "
            f"took {'an unmeasured' if per_frame != per_frame else f'{100 * per_frame:+.0f}%'} worker CPU. The API and the users' process took {loaded['api']:.2f} and "
            f"{loaded['users (locust)']:.2f} cores"
            + (f"; other work on this shared machine {others:.2f} cores under load"
               + (f" and {others_idle:.2f} during the replay" if others_idle is not None else "")
               + ". Here the farm's own cost cannot be told apart from its neighbours'; on a machine of its "
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
        for k, (phase, (s, e)) in enumerate(report["phases_s"].items()):
            ax.axvspan(s, e, color=f"C{k}", alpha=0.07)
            if ax is a:
                ax.text((s + e) / 2, 1.01, phase, transform=ax.get_xaxis_transform(), ha="center", va="bottom",
                        fontsize=7, color=f"C{k}")
        ax.grid(True, alpha=0.3)
    a.set_title(f"argand bench load: the phases shaded (steady: {report['steady']['users']} users)", pad=14)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
