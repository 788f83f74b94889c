"""The simulated users of `argand bench load` (Locust), and the process that
runs them: ``python -m argand.bench.load_users CONFIG.json``.

A separate process because Locust patches the standard library for gevent
on import; the harness (argand.bench.load) starts the farm, samples it and
writes the report without that patching.

The users talk to the farm over HTTP only. Every request checks its
response (status code, content type, the fields the front end relies on),
so a wrong answer counts as a failure, not as a fast success. Each request
is written as a row [t, name, ms, ok, bytes, users, error] to the samples
file; the harness computes every figure from those rows.
"""

from __future__ import annotations

import math

import json
import random
import sys
import time
from typing import Any

#: Terminal job states; "paused" is not one (a paused job waits).
ENDED = ("done", "failed", "canceled")
JOB_STATES = ("queued", "running", "paused", "done", "failed", "canceled")
#: Surfaces for the validator: valid ones (with their degree) and broken ones.
VALID_SURFACES = {"x^2 + y^2 + z^2 - 1": 2, "x^3 + y^3 + z^3 - 1": 3, "x^4 - y*z + 2": 4,
                  "(x^2 + y^2 - 1)^3 - x^2*y^3 + z": 6}
BROKEN_SURFACES = ("x^2 + y^", "sin(x) + y", "x ** 2 +", "x^2 + (y")


class Shared:
    """What the users of this process know together: the jobs they have
    seen (ids, states, done frames), and the jobs they submitted."""

    def __init__(self, config: dict) -> None:
        self.config = config
        self.rng = random.Random(config["seed"])
        self.presets: list[str] = config["presets"]
        self.jobs: dict[str, dict] = {}  # id -> last view seen
        self.submitted: list[dict] = []  # {id, t, body}
        self.canceled: list[str] = []  # jobs a user cancelled (they end canceled, by design)
        self.stopping = False

    def see(self, view: dict) -> None:
        """A job's own view (with its frames), or a list's summary (without):
        a summary updates what is known of a job, keeping its frames."""
        known = self.jobs.get(view["id"])
        if "frames" in view or known is None:
            self.jobs[view["id"]] = view
        else:
            self.jobs[view["id"]] = {**known, **view}

    def done_jobs(self) -> list[dict]:
        return [v for v in self.jobs.values() if v["status"] == "done"]

    def any_job(self) -> dict | None:
        return self.rng.choice(list(self.jobs.values())) if self.jobs else None

    def job_body(self) -> dict:
        """A small job: 64..256 pixels a side, 4..24 frames, a random preset
        and delta range."""
        r = self.rng
        side = r.choice((64, 96, 128, 160, 192, 256))
        start = r.uniform(0.0, 0.2)
        return {"scene": r.choice(self.presets), "width": side, "height": side,
                "deltas": {"start": round(start, 4), "stop": round(start + r.uniform(0.05, 0.35), 4),
                           "count": r.randint(4, 24)},
                "priority": r.randint(3, 7)}


def _json(response) -> Any:
    try:
        return response.json()
    except ValueError:
        return None


def check_job_view(view: Any, summary: bool = False) -> str | None:
    """None if the job view (or, with ``summary``, a list's summary: no
    frames, their count and a link instead) has what the front end reads,
    else what is wrong."""
    if not isinstance(view, dict):
        return "not a JSON object"
    keys = ("frames_total", "frames_url") if summary else ("frames",)
    for key in ("id", "status", "progress", "tiles_done", "tiles_total", "priority", *keys):
        if key not in view:
            return f"no {key!r} in the job {'summary' if summary else 'view'}"
    if summary and "frames" in view:
        return "a list's summary carries the job's frames"
    if view["status"] not in JOB_STATES:
        return f"unknown status {view['status']!r}"
    if not (0.0 <= view["progress"] <= 1.0):
        return f"progress {view['progress']} outside [0, 1]"
    if not (0 <= view["tiles_done"] <= view["tiles_total"]):
        return f"tiles_done {view['tiles_done']} outside [0, {view['tiles_total']}]"
    for f in view.get("frames", []):
        if f["status"] == "done" and not (f.get("png_url") and f.get("thumbnail_url")):
            return f"frame {f['index']} is done without png_url/thumbnail_url"
    if view["status"] == "done" and any(f["status"] != "done" for f in view.get("frames", [])):
        return "the job is done but a frame is not"
    return None


def make_user_class(shared: Shared):
    from locust import HttpUser, between, task

    wait = shared.config["wait_s"]

    class FarmUser(HttpUser):
        """Someone using the farm from the web page or a script: browses the
        list, opens and watches jobs, downloads results, submits now and
        then, and steers their own job."""

        wait_time = between(*wait)

        def on_start(self) -> None:
            self.own: str | None = None  # the job this user submitted and is waiting for
            # Each user comes to render something: their first action is a
            # submission (then the weighted tasks below). Without it a short
            # run (the smoke run's few seconds) could end without a single
            # POST /api/jobs, Locust's task choice being random.
            self.submit()

        # -- helpers ---------------------------------------------------
        def _get_job(self, job_id: str, name: str = "GET /api/jobs/{id}") -> dict | None:
            with self.client.get(f"/api/jobs/{job_id}", name=name, catch_response=True) as r:
                view = _json(r)
                if r.status_code != 200:
                    r.failure(f"status {r.status_code}: {r.text[:200]}")
                    return None
                problem = check_job_view(view)
                if problem or view["id"] != job_id:
                    r.failure(problem or "another job's view")
                    return None
                shared.see(view)
                return view

        def _own_active(self) -> str | None:
            if self.own and shared.jobs.get(self.own, {}).get("status") in ENDED:
                self.own = None
            return self.own

        def _download(self, url: str, name: str, magic: bytes, media: str) -> None:
            with self.client.get(url, name=name, catch_response=True) as r:
                if r.status_code != 200:
                    r.failure(f"status {r.status_code}: {r.text[:200]}")
                elif not r.headers.get("content-type", "").startswith(media):
                    r.failure(f"content-type {r.headers.get('content-type')!r}, expected {media}")
                elif not r.content.startswith(magic):
                    r.failure(f"the body is not a {media} file")

        # -- browsing --------------------------------------------------
        @task(10)
        def browse_list(self) -> None:
            page = 1 if shared.rng.random() < 0.8 else 2
            with self.client.get(f"/api/jobs?page={page}&per_page=20", name="GET /api/jobs", catch_response=True) as r:
                body = _json(r)
                if r.status_code != 200:
                    r.failure(f"status {r.status_code}: {r.text[:200]}")
                    return
                if not isinstance(body, dict) or not isinstance(body.get("jobs"), list) or not isinstance(body.get("total"), int):
                    r.failure("the list has no jobs/total")
                    return
                for view in body["jobs"]:
                    problem = check_job_view(view, summary=True)
                    if problem:
                        r.failure(f"job {view.get('id')}: {problem}")
                        return
                    shared.see(view)

        @task(12)
        def poll_status(self) -> None:
            """Open a job (one's own if one is running) and poll it a few times."""
            job_id = self._own_active() or (shared.any_job() or {}).get("id")
            if job_id is None:
                return
            for _ in range(shared.rng.randint(1, 4)):
                view = self._get_job(job_id)
                if view is None or view["status"] in ENDED:
                    return
                time.sleep(shared.rng.uniform(0.5, 1.5))

        @task(2)
        def watch_events(self) -> None:
            """Hold the job's server-sent events stream, as the job page does,
            until the job ends or the user leaves (after a while)."""
            job_id = self._own_active() or (shared.any_job() or {}).get("id")
            if job_id is None:
                return
            hold = shared.config["sse_hold_s"]
            with self.client.get(f"/api/jobs/{job_id}/events", name="GET /api/jobs/{id}/events", stream=True,
                                 catch_response=True, timeout=60.0) as r:
                if r.status_code != 200 or not r.headers.get("content-type", "").startswith("text/event-stream"):
                    r.failure(f"status {r.status_code}, content-type {r.headers.get('content-type')!r}")
                    return
                start = time.monotonic()  # the user watches for a while once the page is open
                event = None
                seen = 0
                for line in r.iter_lines(decode_unicode=True):
                    if line.startswith("event: "):
                        event = line[7:]
                        continue
                    if not line.startswith("data: "):
                        continue
                    data = json.loads(line[6:])
                    seen += 1
                    if event == "progress" and not {"status", "progress", "tiles_done", "tiles_total"} <= set(data):
                        r.failure(f"a progress event without its fields: {data}")
                        return
                    if event in ("end", "deleted") or time.monotonic() - start > hold or shared.stopping:
                        break
                if seen == 0:
                    r.failure("the stream closed without an event")

        @task(6)
        def frame_png(self) -> None:
            job = self._done_frame_job()
            frames = [f for f in (job or {}).get("frames", []) if f.get("png_url")]
            if frames:
                self._download(shared.rng.choice(frames)["png_url"], "GET frame.png", b"\x89PNG", "image/png")

        @task(6)
        def thumbnail(self) -> None:
            job = self._done_frame_job()
            frames = [f for f in (job or {}).get("frames", []) if f.get("thumbnail_url")]
            if frames:
                self._download(shared.rng.choice(frames)["thumbnail_url"], "GET thumbnail.png", b"\x89PNG", "image/png")

        @task(2)
        def animation(self) -> None:
            done = [j for j in shared.done_jobs() if j.get("animation_url")]
            if done:
                self._download(shared.rng.choice(done)["animation_url"], "GET animation.gif", b"GIF8", "image/gif")

        @task(4)
        def scrub_band(self) -> None:
            """A user dragging the σ and δ sliders of a done job: any band
            of the band rule, rendered on demand by the API."""
            done = shared.done_jobs()
            if done:
                job = shared.rng.choice(done)
                sigma = shared.rng.uniform(0.0, math.pi)
                delta = shared.rng.uniform(0.0, math.pi - sigma)
                self._download(f"/api/jobs/{job['id']}/band.png?sigma={sigma!r}&delta={delta!r}", "GET band.png",
                               b"\x89PNG", "image/png")

        def _done_frame_job(self) -> dict | None:
            # (Seen in full, not only in a list; a view seen while the job
            # ran may still list frames then not done: their URLs are None.)
            done = [j for j in shared.done_jobs() if j.get("frames")]
            return shared.rng.choice(done) if done else None

        # -- submitting and steering -----------------------------------
        @task(2)
        def submit(self) -> None:
            """A user waits for their job before submitting another."""
            if self._own_active() or shared.stopping:
                return
            body = shared.job_body()
            with self.client.post("/api/jobs", json=body, name="POST /api/jobs", catch_response=True) as r:
                view = _json(r)
                if r.status_code != 201:
                    r.failure(f"status {r.status_code}: {r.text[:200]}")
                    return
                problem = check_job_view(view)
                if problem or len(view["frames"]) != body["deltas"]["count"]:
                    r.failure(problem or f"{len(view['frames'])} frames, asked for {body['deltas']['count']}")
                    return
            shared.see(view)
            shared.submitted.append({"id": view["id"], "t": time.time(), "body": body})
            self.own = view["id"]

        @task(1)
        def steer(self) -> None:
            """Now and then: cancel, pause and resume, or re-prioritise one's job."""
            job_id = self._own_active()
            if job_id is None:
                return
            roll = shared.rng.random()
            if roll < 0.25:
                with self.client.post(f"/api/jobs/{job_id}/cancel", name="POST /api/jobs/{id}/cancel", catch_response=True) as r:
                    view = _json(r)
                    if r.status_code != 200 or not isinstance(view, dict) or view.get("status") not in ("canceled", "done"):
                        r.failure(f"status {r.status_code}, job {view.get('status') if isinstance(view, dict) else view}")
                        return
                shared.see(view)
                if view["status"] == "canceled":
                    shared.canceled.append(job_id)
                self.own = None
            elif roll < 0.6:
                with self.client.post(f"/api/jobs/{job_id}/pause", name="POST /api/jobs/{id}/pause", catch_response=True) as r:
                    view = _json(r)
                    if r.status_code != 200 or not isinstance(view, dict) or view.get("status") not in ("paused",) + ENDED:
                        r.failure(f"status {r.status_code}, job {view.get('status') if isinstance(view, dict) else view}")
                        return
                try:
                    time.sleep(shared.rng.uniform(0.5, 2.0))
                finally:  # a user stopped mid-pause still resumes their job
                    with self.client.post(f"/api/jobs/{job_id}/resume", name="POST /api/jobs/{id}/resume",
                                          catch_response=True) as r:
                        view = _json(r)
                        if r.status_code != 200 or not isinstance(view, dict) or view.get("status") not in ("queued", "running") + ENDED:
                            r.failure(f"status {r.status_code}, job {view.get('status') if isinstance(view, dict) else view}")
                        else:
                            shared.see(view)
            else:
                priority = shared.rng.randint(0, 9)
                with self.client.patch(f"/api/jobs/{job_id}", json={"priority": priority}, name="PATCH /api/jobs/{id}",
                                       catch_response=True) as r:
                    view = _json(r)
                    if r.status_code != 200 or not isinstance(view, dict) or view.get("priority") != priority:
                        r.failure(f"status {r.status_code}, priority {view.get('priority') if isinstance(view, dict) else view}")
                        return
                shared.see(view)

        @task(2)
        def validate(self) -> None:
            if shared.rng.random() < 0.7:
                surface = shared.rng.choice(list(VALID_SURFACES))
                expect = {"valid": True, "degree": VALID_SURFACES[surface]}
            else:
                surface, expect = shared.rng.choice(BROKEN_SURFACES), {"valid": False}
            with self.client.post("/api/scenes/validate", json={"surface": surface}, name="POST /api/scenes/validate",
                                  catch_response=True) as r:
                body = _json(r)
                if r.status_code != 200 or not isinstance(body, dict):
                    r.failure(f"status {r.status_code}: {r.text[:200]}")
                elif any(body.get(k) != v for k, v in expect.items()):
                    r.failure(f"{surface!r}: {body}, expected {expect}")
                elif not expect["valid"] and "position" not in body:
                    r.failure(f"{surface!r}: an error without its position")

    return FarmUser


def run(config: dict) -> dict:
    """Runs the users through ``config["schedule"]`` ([seconds, users] steps)
    and writes the request rows to ``config["samples"]``. Returns what the
    users submitted and cancelled."""
    import gevent
    from locust.env import Environment

    shared = Shared(config)
    user_class = make_user_class(shared)
    env = Environment(user_classes=[user_class], host=config["url"])
    users_now = [0]
    rows: list[list] = []

    def on_request(request_type, name, response_time, response_length, exception=None, **_kw):
        rows.append([round(time.time(), 3), name, round(response_time, 2), 0 if exception else 1, response_length or 0,
                     users_now[0], None if exception is None else str(exception)[:300]])

    env.events.request.add_listener(on_request)
    runner = env.create_local_runner()
    # Users see the jobs already on the farm (a ramp's leftovers, a steady
    # phase's predecessor), as a browser opening the page would.
    for view in config.get("known_jobs", []):
        shared.see(view)
    phases = []
    for seconds, users in config["schedule"]:
        users_now[0] = users
        phases.append({"t": time.time(), "users": users})
        runner.start(users, spawn_rate=max(1, users))
        gevent.sleep(seconds)
    shared.stopping = True
    gevent.sleep(0.5)
    runner.stop()
    runner.quit()
    phases.append({"t": time.time(), "users": 0})
    with open(config["samples"], "w") as fh:
        json.dump(rows, fh)
    return {"submitted": shared.submitted, "canceled": shared.canceled, "phases": phases,
            # an exception in a user's code is a failure too (Locust keeps it apart)
            "exceptions": [{"count": e["count"], "msg": e["msg"], "traceback": e["traceback"][-1500:]}
                           for e in runner.exceptions.values()]}


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python -m argand.bench.load_users CONFIG.json", file=sys.stderr)
        return 2
    with open(argv[1]) as fh:
        config = json.load(fh)
    result = run(config)
    with open(config["result"], "w") as fh:
        json.dump(result, fh)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
