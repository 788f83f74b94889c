"""`argand serve` supervises: a worker or Redis killed with -9 is
started again and the farm finishes work; /healthz says what is wrong (503);
a second farm on the same data folder is refused; the children die with the
supervisor. Real processes throughout."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import httpx
import pytest

from argand.farm.workers import given_name
from tests.farm.test_farm import ARGAND, Farm


def _children(pid: int) -> dict[int, str]:
    """Live direct children of ``pid``: pid -> command line."""
    out = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                out[int(stat.parent.name)] = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, IndexError, ValueError):
            pass
    return out


def _alive(pid: int) -> bool:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return fields[0] != "Z"
    except OSError:
        return False


@pytest.fixture
def farm1(tmp_path):
    f = Farm(tmp_path / "data", workers=1).start()
    yield f
    f.stop()


def _submit_and_finish(farm: Farm) -> dict:
    r = farm.post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16})
    assert r.status_code == 201, r.text
    job = farm.wait_job(r.json()["id"], 120)
    assert job["status"] == "done" and job["tiles_done"] == job["tiles_total"]
    return job


def test_a_killed_worker_and_a_killed_redis_are_started_again(farm1):
    farm = farm1
    health = httpx.get(farm.url + "/healthz", timeout=10)
    assert health.status_code == 200 and {c["name"]: c["ok"] for c in health.json()["checks"]} == {
        "database": True, "redis": True, "store": True, "workers": True, "outbox": True}
    [w] = farm.get("/api/workers")
    os.kill(w["pid"], signal.SIGKILL)
    # A new worker in the slot's next name (w1 -> w1.2), each process with a
    # boot id of its own; the killed one's row counts as alive until its last
    # heartbeat is older than the heartbeat timeout.
    farm.wait_for(lambda: {given_name(x["name"]) for x in farm.get("/api/workers") if x["alive"]}
                  == {given_name(w["name"]).replace("@", ".2@", 1)}, 60)
    assert all(x["pid"] != w["pid"] for x in farm.get("/api/workers") if x["alive"])
    _submit_and_finish(farm)
    [redis_pid] = [p for p, cmd in _children(farm.proc.pid).items() if "redis-server" in cmd]
    os.kill(redis_pid, signal.SIGKILL)
    farm.wait_for(lambda: any("redis-server" in c and p != redis_pid for p, c in _children(farm.proc.pid).items()), 30)
    farm.wait_for(lambda: httpx.get(farm.url + "/healthz", timeout=10).status_code == 200, 60)
    _submit_and_finish(farm)
    assert "started again" in farm.log.read_text()


def test_a_second_farm_on_the_same_folder_is_refused(farm1):
    r = subprocess.run([ARGAND, "serve", "--workers", "0", "--port", "1", "--data", str(farm1.data)],
                       env=farm1.env, capture_output=True, text=True, timeout=60)
    out = " ".join((r.stdout + r.stderr).split())
    assert r.returncode == 2 and "another farm" in out and str(farm1.proc.pid) in out, out
    assert httpx.get(farm1.url + "/healthz", timeout=10).status_code == 200  # the first is untouched


def test_the_children_die_with_the_supervisor(farm1):
    children = _children(farm1.proc.pid)
    assert any("redis-server" in c for c in children.values()) and any(" worker " in c for c in children.values())
    farm1.proc.kill()
    farm1.proc.wait()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_alive(p) for p in children):
        time.sleep(0.2)
    assert not [c for p, c in children.items() if _alive(p)]


def test_healthz_is_503_without_a_live_worker_and_readyz_is_200(tmp_path):
    farm = Farm(tmp_path / "data", workers=0).start()
    try:
        r = httpx.get(farm.url + "/healthz", timeout=10)
        assert r.status_code == 503 and r.json()["status"] == "unavailable"
        workers = next(c for c in r.json()["checks"] if c["name"] == "workers")
        assert not workers["ok"] and "no worker sent a heartbeat" in workers["error"]
        assert httpx.get(farm.url + "/readyz", timeout=10).status_code == 200
    finally:
        farm.stop()


def test_a_killed_worker_is_counted_dead_at_once_not_after_the_heartbeat_timeout(tmp_path):
    farm = Farm(tmp_path / "data", workers=1)
    farm.env["ARGAND_HEARTBEAT_TIMEOUT_S"] = "15"
    farm.start()
    try:
        [w] = farm.get("/api/workers")
        os.kill(w["pid"], signal.SIGKILL)
        killed = time.monotonic()
        # The supervisor saw it end: neither /api/workers nor /healthz counts it, well before 15 s.
        farm.wait_for(lambda: not any(x["alive"] for x in farm.get("/api/workers") if x["name"] == w["name"]), 5)
        assert time.monotonic() - killed < 5
        _submit_and_finish(farm)
    finally:
        farm.stop()
