"""The render farm with real parts: an embedded Redis, real Celery worker
processes, uvicorn serving the API, a SQLite file, all on loopback."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from argand.render import AOV_CHANNELS, FrameParams, render_frame
from argand.media.frame_files import read_exr
from argand.scene import load_scene

ARGAND = str(Path(sys.executable).with_name("argand"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Farm:
    def __init__(self, data: Path, workers: int = 2, **env: str) -> None:
        self.data, self.workers, self.port = data, workers, free_port()
        # The assembler writes every frame's files, EXR included (the tests
        # read what the workers' tiles made); test_files_on_request.py and
        # test_frame_exr_on_request.py run the defaults.
        env = {"ARGAND_FILES_ON_REQUEST": "false", "ARGAND_EXR_ON_REQUEST": "false", **env}
        self.env = dict(os.environ, ARGAND_HEARTBEAT_INTERVAL_S="0.5", ARGAND_HEARTBEAT_TIMEOUT_S="3", **env)
        self.env.pop("ARGAND_REDIS_URL", None)
        self.proc: subprocess.Popen | None = None

    def start(self) -> "Farm":
        self.data.mkdir(parents=True, exist_ok=True)
        self.log = self.data / f"serve-{self.port}.log"
        with open(self.log, "w") as log:  # (a pipe nobody reads could fill up and block the farm)
            self.proc = subprocess.Popen(
                [ARGAND, "serve", "--workers", str(self.workers), "--port", str(self.port), "--data", str(self.data)],
                env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
            )
        self.url = f"http://127.0.0.1:{self.port}"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            assert self.proc.poll() is None, self.log.read_text()
            try:
                if httpx.get(self.url + "/readyz", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        else:
            raise AssertionError("the farm did not come up")
        if self.workers:
            self.wait_for(lambda: len([w for w in self.get("/api/workers") if w["alive"]]) >= self.workers, 60)
        return self

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()

    def get(self, path: str):
        r = httpx.get(self.url + path, timeout=30)
        r.raise_for_status()
        return r.json()

    def post(self, path: str, json=None) -> httpx.Response:
        return httpx.post(self.url + path, json=json, timeout=60)

    @staticmethod
    def wait_for(cond, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if cond():
                return
            time.sleep(0.2)
        raise AssertionError("timed out")

    def wait_job(self, job_id: str, timeout: float = 180) -> dict:
        self.wait_for(lambda: self.get(f"/api/jobs/{job_id}")["status"] in ("done", "failed", "canceled"), timeout)
        return self.get(f"/api/jobs/{job_id}")


@pytest.fixture
def farm(tmp_path):
    f = Farm(tmp_path / "data").start()
    yield f
    f.stop()


def check_frames_against_local(farm: Farm, job: dict, scene_name: str) -> None:
    scene = load_scene(scene_name)
    for fr in job["frames"]:
        local = render_frame(scene, FrameParams(sigma=fr["sigma"], delta=fr["delta"], width=job["width"], height=job["height"]), workers=1)
        exr = farm.data / "store" / "jobs" / job["id"] / f"frame_{fr['index']:04d}.exr"
        names, pixels = read_exr(exr)
        for i, c in enumerate("RGBA"):
            assert np.array_equal(pixels[..., names.index(c)], local.rgba[..., i]), (fr["index"], c)
        for aov in AOV_CHANNELS:
            assert np.array_equal(pixels[..., names.index(aov)], local.aovs[aov].astype(np.float32)), (fr["index"], aov)
        r = httpx.get(farm.url + fr["png_url"])
        assert r.status_code == 200 and r.content[:4] == b"\x89PNG"
        # The farm counts statuses and hits as it renders; the local render counts the arrays.
        for key in ("certified_share", "status_shares", "hit_share", "escalations", "root_calls"):
            assert fr["figures"][key] == local.figures[key], (fr["index"], key)


def test_job_over_http_matches_local_render(farm):
    r = farm.post("/api/jobs", {"scene": "whitney", "deltas": {"start": 0, "stop": "pi/9", "count": 5}, "width": 48, "height": 40, "tile": 16})
    assert r.status_code == 201, r.text
    job = farm.wait_job(r.json()["id"])
    assert job["status"] == "done" and job["progress"] == 1.0
    assert all(f["certified_share"] is not None for f in job["frames"])
    check_frames_against_local(farm, job, "whitney")
    gif = httpx.get(farm.url + job["animation_url"])
    assert gif.status_code == 200
    import OpenImageIO as oiio

    path = farm.data / "gif.gif"
    path.write_bytes(gif.content)
    inp = oiio.ImageInput.open(str(path))
    n = 0
    while inp.seek_subimage(n, 0):
        n += 1
    inp.close()
    assert n == 5
    # The WebP, made on first request: the same number of frames, the frames' size.
    from PIL import Image

    webp = httpx.get(farm.url + job["webp_url"], timeout=60)
    assert webp.status_code == 200 and webp.headers["content-type"] == "image/webp"
    im = Image.open(__import__("io").BytesIO(webp.content))
    assert im.n_frames == 5 and im.size == (48, 40)
    assert httpx.get(farm.url + job["webp_url"]).content == webp.content  # kept, not made again
    # Workers report their counts with their heartbeats.
    farm.wait_for(lambda: sum(w["tiles_done"] for w in farm.get("/api/workers")) == 5 * 3 * 3, 10)
    assert len(farm.get("/api/workers")) == 2
    check_metrics(httpx.get(farm.url + "/metrics").text, tiles=5 * 3 * 3, frames=5)


def check_metrics(text: str, tiles: int, frames: int) -> None:
    """/metrics after one finished job: its states, and a histogram entry for
    every tile's render and wait, every frame's assembly, and the requests."""
    from prometheus_client.parser import text_string_to_metric_families

    samples = {(s.name, tuple(sorted(s.labels.items()))): s.value
               for family in text_string_to_metric_families(text) for s in family.samples}
    assert samples[("argand_jobs", (("status", "done"),))] == 1
    assert samples[("argand_tiles", (("status", "done"),))] == tiles
    assert samples[("argand_frames_done_total", ())] == frames
    for name, count in (("argand_tile_render_seconds", tiles), ("argand_queue_wait_seconds", tiles),
                        ("argand_frame_assembly_seconds", frames)):
        assert samples[(f"{name}_count", ())] == count and samples[(f"{name}_sum", ())] > 0, name
        assert samples[(f"{name}_bucket", (("le", "+Inf"),))] == count, name
    polls = ("argand_request_seconds_count", (("method", "GET"), ("route", "/api/jobs/{job_id}")))
    assert samples[polls] >= 1


def test_bad_jobs_are_refused_with_the_reason(farm):
    cases = [
        ({"scene": "nope"}, "unknown preset"),
        ({"scene": {"objects": [{"surface": "x^2 + (y"}]}}, "unmatched '('"),
        ({"scene": "bicube", "width": 5000}, "exceeds the limit"),
        ({"scene": "bicube", "width": 100000}, "less than or equal to 8192"),
        ({"scene": "bicube", "deltas": {"start": 0, "stop": 1, "count": 1000}}, "exceed the limit of 720"),
        ({"scene": "bicube", "deltas": {"start": 0, "stop": 1, "count": 100000}}, "less than or equal to 10000"),
        ({"scene": "bicube", "deltas": ["pi/"]}, "cannot read"),
        ({"scene": "bicube", "priority": 42}, "priority"),
        ({"scene": "bicube", "colour": "red"}, "colour"),
    ]
    for body, message in cases:
        r = farm.post("/api/jobs", body)
        assert r.status_code == 422, (body, r.text)
        assert message in r.text, (body, r.text)
    assert farm.get("/api/jobs")["total"] == 0
    v = farm.post("/api/scenes/validate", {"surface": "x^2 + w"}).json()
    assert v["valid"] is False and v["position"] == 6
    assert farm.post("/api/scenes/validate", {"surface": "x^2*z + y^2"}).json() == {"valid": True, "degree": 3}


def tile_rows(farm: Farm, job_id: str, column: str) -> list:
    from sqlalchemy import create_engine, text

    eng = create_engine(f"sqlite:///{farm.data / 'argand.db'}")
    with eng.connect() as c:
        return c.execute(text(f"select {column} from tiles where job_id = :j"), {"j": job_id}).scalars().all()


def tile_renders(farm: Farm, job_id: str) -> list[int]:
    return tile_rows(farm, job_id, "renders")


def test_frames_shared_between_workers_match_local_render(tmp_path):
    """Runs far smaller than a frame: the two workers share every frame, the
    tiles travel through the store's chunk files, and the assembler takes
    its own tiles from memory and the other worker's from the store."""
    f = Farm(tmp_path / "data", ARGAND_BATCH_PIXELS="600").start()
    try:
        r = f.post("/api/jobs", {"scene": "steiner", "deltas": [0, "pi/18", "pi/9"], "width": 128, "height": 96, "tile": 16})
        job = f.wait_job(r.json()["id"], 120)
        assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"] == 3 * 48
        assert all(fr["figures"]["certified_share"] is not None for fr in job["frames"])
        renders = tile_renders(f, job["id"])
        assert len(renders) == 3 * 48 and set(renders) == {1}
        check_frames_against_local(f, job, "steiner")
        assert len(set(tile_rows(f, job["id"], "worker"))) == 2  # both workers rendered tiles
        assert {c for c in tile_rows(f, job["id"], "chunk")} - {None, "frame"}  # through chunk files
        assert not (f.data / "store" / "jobs" / job["id"] / "tiles").exists() or not any(
            (f.data / "store" / "jobs" / job["id"] / "tiles").rglob("*.chunk"))  # dropped once assembled
    finally:
        f.stop()


def test_killed_worker_loses_no_tile_and_renders_none_twice(tmp_path):
    # Small runs, so that the victim holds tiles of a frame that others finish.
    farm = Farm(tmp_path / "data", ARGAND_BATCH_PIXELS="1500").start()
    try:
        _killed_worker(farm)
    finally:
        farm.stop()


def _killed_worker(farm: Farm) -> None:
    # A scene heavy enough (a refracting sphere around Whitney's umbrella)
    # that the kill lands in the middle of the job, which is checked.
    n = 24
    r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": {"start": 0, "stop": "pi/9", "count": n},
                                "width": 160, "height": 160, "tile": 16})
    job_id = r.json()["id"]
    deadline = time.monotonic() + 60
    while (seen := farm.get(f"/api/jobs/{job_id}"))["tiles_done"] < 20 and time.monotonic() < deadline:
        time.sleep(0.02)
    victim = farm.get("/api/workers")[0]
    os.kill(victim["pid"], signal.SIGKILL)
    assert seen["status"] == "running" and 20 <= seen["tiles_done"] < n * 100, seen["tiles_done"]
    assert farm.get(f"/api/jobs/{job_id}")["status"] == "running"  # the kill came before the end
    job = farm.wait_job(job_id, 240)
    assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"] == n * 100
    renders = tile_renders(farm, job_id)
    assert len(renders) == n * 100 and set(renders) == {1}
    check_frames_against_local(farm, job, "whitney-in-sphere")


def test_cancel_stops_rendering_and_retry_finishes_the_job(farm):
    r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": {"start": 0, "stop": "pi/9", "count": 48},
                                "width": 160, "height": 160, "tile": 16})
    job_id = r.json()["id"]
    farm.wait_for(lambda: farm.get(f"/api/jobs/{job_id}")["tiles_done"] >= 5, 60)
    running = farm.get(f"/api/jobs/{job_id}")
    assert running["status"] == "running" and 0 < running["progress"] < 1
    assert running["eta_s"] is None or running["eta_s"] > 0
    assert farm.post(f"/api/jobs/{job_id}/cancel").json()["status"] == "canceled"
    time.sleep(1)  # a run in flight stops at its next tile
    done = farm.get(f"/api/jobs/{job_id}")["tiles_done"]
    time.sleep(2)
    assert farm.get(f"/api/jobs/{job_id}")["tiles_done"] == done < 48 * 100
    # Retry takes a cancelled job up where it stopped: nothing is lost, nothing rendered twice.
    assert farm.post(f"/api/jobs/{job_id}/retry").json()["status"] == "running"
    job = farm.wait_job(job_id)
    assert job["status"] == "done" and job["tiles_done"] == 48 * 100 and job["eta_s"] in (None, 0, 0.0)
    assert sorted(set(tile_renders(farm, job_id))) == [1]
    assert farm.post(f"/api/jobs/{job_id}/retry").json()["status"] == "done"  # nothing to retry
    # Downloads: the EXR as stored, the thumbnail a small copy of the PNG.
    import OpenImageIO as oiio

    frame = job["frames"][7]
    exr = httpx.get(farm.url + frame["exr_url"])
    assert exr.status_code == 200 and exr.headers["content-type"] == "image/x-exr"
    assert exr.content == (farm.data / "store" / "jobs" / job_id / "frame_0007.exr").read_bytes()
    png, thumb = (httpx.get(farm.url + frame[k]) for k in ("png_url", "thumbnail_url"))
    assert thumb.status_code == 200 and thumb.headers["content-type"] == "image/png"
    (farm.data / "p.png").write_bytes(png.content)
    (farm.data / "t.png").write_bytes(thumb.content)
    full = oiio.ImageBuf(str(farm.data / "p.png")).get_pixels(oiio.UINT8)
    small = oiio.ImageBuf(str(farm.data / "t.png")).get_pixels(oiio.UINT8)
    step = max(1, 160 // 160)  # the thumbnail keeps every step-th pixel, step = max(w, h) // 160
    assert np.array_equal(small, full[::step, ::step])
    assert httpx.get(farm.url + f"/api/jobs/{job_id}/frames/99/thumbnail.png").status_code == 404
    # The job list is paged; the API describes itself.
    for n in range(2):
        farm.post("/api/jobs", {"scene": "plucker", "deltas": [0.0], "width": 16, "height": 16})
    first, second = farm.get("/api/jobs?per_page=2&page=1"), farm.get("/api/jobs?per_page=2&page=2")
    assert first["total"] == second["total"] == 3 and len(first["jobs"]) == 2 and len(second["jobs"]) == 1
    assert second["jobs"][0]["id"] == job_id  # newest first
    assert httpx.get(farm.url + "/api/jobs?per_page=500").status_code == 422
    paths = farm.get("/openapi.json")["paths"]
    assert {"/api/jobs", "/api/jobs/{job_id}", "/api/jobs/{job_id}/events", "/api/workers", "/metrics"} <= set(paths)
    assert httpx.get(farm.url + "/docs").status_code == 200


def test_restart_keeps_jobs_and_resumes_queued_work(tmp_path):
    data = tmp_path / "data"
    f = Farm(data, workers=0).start()  # no workers: the work stays queued in Redis
    r = f.post("/api/jobs", {"scene": "steiner", "deltas": [0, "pi/18"], "width": 32, "height": 32, "tile": 16})
    job_id = r.json()["id"]
    assert f.get(f"/api/jobs/{job_id}")["status"] == "queued"
    f.stop()  # stops the API and the embedded Redis (AOF on disk)
    g = Farm(data, workers=2).start()  # a fresh Redis process on the same files, and workers
    try:
        job = g.wait_job(job_id, 120)
        assert job["status"] == "done"
        check_frames_against_local(g, job, "steiner")
    finally:
        g.stop()
    h = Farm(data, workers=0).start()  # restart again: jobs and frames are still there
    try:
        job = h.get(f"/api/jobs/{job_id}")
        assert job["status"] == "done" and len(job["frames"]) == 2
        assert httpx.get(h.url + job["frames"][1]["png_url"]).status_code == 200
    finally:
        h.stop()


def test_pause_resume_priority_events_delete(farm):
    r = farm.post("/api/jobs", {"scene": "whitney-in-sphere", "deltas": {"start": 0, "stop": "pi/9", "count": 12},
                                "width": 192, "height": 192, "tile": 16, "priority": 3})
    job_id = r.json()["id"]
    # The workers render at a lower priority than the API (serve's own process) answers.
    import psutil

    serve = psutil.Process(farm.proc.pid)
    workers = [p for p in serve.children(recursive=True) if p.cmdline()[1:4] == ["-m", "argand.cli", "worker"]]
    assert len(workers) >= 2 and {p.nice() for p in workers} == {min(19, serve.nice() + 10)}
    assert farm.post(f"/api/jobs/{job_id}/pause").json()["status"] == "paused"
    time.sleep(1.5)  # a tile in flight may finish
    held = farm.get(f"/api/jobs/{job_id}")["tiles_done"]
    time.sleep(1.5)
    assert farm.get(f"/api/jobs/{job_id}")["tiles_done"] == held < 12 * 144
    patched = httpx.patch(farm.url + f"/api/jobs/{job_id}", json={"priority": 8})
    assert patched.status_code == 200 and patched.json()["priority"] == 8
    assert httpx.patch(farm.url + f"/api/jobs/{job_id}", json={"priority": 11}).status_code == 422
    assert farm.post(f"/api/jobs/{job_id}/resume").json()["status"] in ("running", "queued")
    # Server-sent events until the end of the job.
    events = []
    with httpx.stream("GET", farm.url + f"/api/jobs/{job_id}/events", timeout=120) as stream:
        for line in stream.iter_lines():
            if line.startswith("event: "):
                events.append(line.removeprefix("event: "))
            if events and events[-1] == "end":
                break
    assert events[0] == "progress" and events[-1] == "end" and events.count("progress") >= 2
    job = farm.get(f"/api/jobs/{job_id}")
    assert job["status"] == "done" and job["tiles_done"] == 12 * 144
    assert farm.get("/api/jobs?status=done")["total"] == 1
    assert farm.get("/api/jobs?status=failed")["total"] == 0
    assert [p["name"] for p in farm.get("/api/presets")][:2] == ["whitney", "plucker"]
    assert httpx.delete(farm.url + f"/api/jobs/{job_id}").status_code == 204
    assert httpx.get(farm.url + f"/api/jobs/{job_id}").status_code == 404
    assert not (farm.data / "store" / "jobs" / job_id).exists()
