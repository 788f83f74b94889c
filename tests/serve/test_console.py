"""What `argand serve` says on its console: a port in use is refused
before anything starts, saying what to do; no Celery banner or root
warnings; the URL last and plain; then one line per job event, with its
time. Real processes (argand serve, its Redis and workers), and the job
log's reads on a real SQLite file."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import time

import pytest

from argand.farm import control, tile_work
from argand.serve.job_log import JobLog
from tests.farm.test_farm import ARGAND, Farm
from tests.farm.test_work import farm_parts, submit  # noqa: F401  (the fixture)
from tests.web.browser import REPO

EVENT = r"\d\d:\d\d:\d\d  job {id} \(plucker, {n} frames? 32x32\) {what}"


@pytest.fixture
def taken_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


def test_a_taken_port_is_refused_before_anything_starts(taken_port, tmp_path):
    started = time.monotonic()
    r = subprocess.run([ARGAND, "serve", "--workers", "1", "--port", str(taken_port), "--data", str(tmp_path / "data")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "serving on" not in r.stdout + r.stderr  # nothing announced
    assert f"port {taken_port} on 127.0.0.1 is already in use" in r.stderr
    assert f"argand serve --port {taken_port + 1}" in r.stderr and f"make run PORT={taken_port + 1}" in r.stderr
    assert [f.name for f in (tmp_path / "data").iterdir()] == ["farm.lock"]  # nothing started: no Redis, no database
    assert time.monotonic() - started < 30
    env_api = {"ARGAND_REDIS_URL": "redis://127.0.0.1:1/0"}
    r = subprocess.run([ARGAND, "api", "--port", str(taken_port), "--data", str(tmp_path / "api")],
                       capture_output=True, text=True, timeout=60, env={**os.environ, **env_api})
    assert r.returncode == 2 and f"argand api --port {taken_port + 1}" in r.stderr, r.stderr


def test_make_run_passes_port():
    # (Under `make test` the outer make's MAKEFLAGS reach this one, which then
    # prints its directory: the command is the last line that is not that.)
    r = subprocess.run(["make", "--no-print-directory", "-n", "run", "PORT=8001"], capture_output=True, text=True,
                       cwd=REPO, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stdout.splitlines() if not line.startswith("make[")]
    assert "argand serve --workers 2 --port 8001" in lines[-1], r.stdout


def _log_lines(farm: Farm) -> list[str]:
    return farm.log.read_text().splitlines()


def _wait_line(farm: Farm, pattern: str, timeout: float = 30) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for line in _log_lines(farm):
            if re.fullmatch(pattern, line):
                return line
        time.sleep(0.2)
    raise AssertionError(f"no line {pattern!r} in:\n" + farm.log.read_text())


def test_the_console_shows_the_url_last_then_one_line_per_job_event(tmp_path):
    farm = Farm(tmp_path / "data", workers=2).start()
    try:
        lines = _log_lines(farm)
        text = "\n".join(lines)
        assert lines[-1] == f"Argand is serving on http://127.0.0.1:{farm.port}/", text
        assert len(lines) <= 3, text
        for noise in ("superuser", "SecurityWarning", "[config]", "[queues]", "celery@", "transport:"):
            assert noise not in text, text
        job = farm.post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16,
                                           "deltas": [0, 0.1]}).json()
        _wait_line(farm, EVENT.format(id=job["id"], n=2, what="submitted"))
        assert farm.wait_job(job["id"], 120)["status"] == "done"
        _wait_line(farm, EVENT.format(id=job["id"], n=2, what=r"done in \d+\.\d s"))
        # A line per event and nothing else: submitted, (running,) done.
        assert len(_log_lines(farm)) in (len(lines) + 2, len(lines) + 3), farm.log.read_text()
    finally:
        farm.stop()


def test_the_job_log_has_a_line_per_change_of_state(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    lines: list[str] = []
    log = JobLog(settings, lines.append)
    time.sleep(0.01)
    job_id = submit(settings, "plucker", [0.0, 0.1], 32, 32, 16)
    log.poll()
    assert len(lines) == 1 and re.fullmatch(EVENT.format(id=job_id, n=2, what="submitted"), lines[0]), lines
    log.poll()
    assert len(lines) == 1  # nothing changed, nothing said
    assert tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], "w-log") == "rendered"
    control.set_job_status(settings, job_id, "pause")
    log.poll()
    assert [re.sub(r"^\S+  ", "", line) for line in lines[1:]] == [f"job {job_id} (plucker, 2 frames 32x32) paused"], lines
    control.set_job_status(settings, job_id, "cancel")
    log.poll()
    assert lines[-1].endswith(f"job {job_id} (plucker, 2 frames 32x32) canceled")
    control.set_job_status(settings, job_id, "retry")
    log.poll()
    assert lines[-1].endswith(f"job {job_id} (plucker, 2 frames 32x32) running again"), lines
    for _ in range(settings.max_tile_attempts):
        why, claimed = tile_work.claim(settings, job_id, 1, [0], "w-log", None)
        tile_work.release(settings, job_id, 1, "w-log", claimed, resend=True, reason="RuntimeError: broken")
    log.poll()
    assert re.search(r"\) failed: tile 1/0 failed 2 times \(RuntimeError: broken\)$", lines[-1]), lines
    assert len(lines) == 5
    # A job followed while it may change, then deleted: said so.
    other = submit(settings, "plucker", [0.0], 32, 32, 16)
    log.poll()
    control.delete_job(settings, other)
    log.poll()
    assert lines[-2].endswith("submitted") and lines[-1].endswith(f"job {other} deleted") and len(lines) == 7, lines
