"""A full disk under the API: a PATCH (SQLite: "database or disk is full")
a frame's first PNG and the first animation.mp4 (ENOSPC) answer 507 with the
reason, not 500 (and publish no cut file),
and /healthz says the store is below its free-space floor. The disk is a
small tmpfs mounted by the test (root only: without root no full disk can be
made on purpose), holding the data folder; Redis is a real embedded one."""

from __future__ import annotations

import errno
import os
import subprocess

import httpx
import pytest

from argand.farm import tile_work
from argand.farm.database import upgrade
from argand.farm.settings import Settings
from argand.serve.embedded_redis import EmbeddedRedis
from tests.farm.test_limits import _serve
from tests.farm.test_work import submit


@pytest.fixture
def small_disk(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs (a disk to fill) needs root")
    mount = tmp_path / "disk"
    mount.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=24m", "tmpfs", str(mount)], check=True)
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def fill(folder) -> None:
    """Writes a file until the disk is full (unbuffered: a buffered file's
    close would try the rest of its buffer again, and raise)."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        while True:
            os.write(fd, b"\0" * (1 << 16))
    except OSError as exc:
        assert exc.errno == errno.ENOSPC, exc
    finally:
        os.close(fd)


def test_a_full_disk_answers_507_not_500(tmp_path, small_disk):
    redis_server = EmbeddedRedis(tmp_path / "redis" / "redis.sock").start()
    try:
        settings = Settings(data_dir=small_disk / "data", redis_url=redis_server.url, min_free_bytes=0)
        upgrade(settings.sqlalchemy_url)
        job_id = submit(settings, "steiner", [0.0, 0.1], 32, 32, 16)
        for frame in (0, 1):  # (a run may render the next frame's tiles with its own)
            assert tile_work.run_tiles(settings, job_id, frame, list(range(4)), "w") in ("rendered", "taken or done")
        settings = settings.model_copy(update={"min_free_bytes": 1 << 20})
        server, thread, url = _serve(settings)
        try:
            with httpx.Client(base_url=url, timeout=60) as c:
                assert c.get(f"/api/jobs/{job_id}").json()["status"] == "done"
                fill(small_disk)
                r = c.patch(f"/api/jobs/{job_id}", json={"priority": 7})
                assert r.status_code == 507 and "disk is full" in r.json()["detail"], (r.status_code, r.text)
                # A frame's first PNG (decided from the root field, written
                # now): OpenImageIO's PNG writer reports no error on a full
                # disk, and a cut file must not be published.
                r = c.get(f"/api/jobs/{job_id}/frames/1.png")
                assert r.status_code == 507 and "full" in r.json()["detail"], (r.status_code, r.text[:300])
                assert not (settings.store_path / "jobs" / job_id / "frame_0001.png").exists()
                r = c.get(f"/api/jobs/{job_id}/animation.mp4")
                assert r.status_code == 507 and "full" in r.json()["detail"], (r.status_code, r.text[:300])
                health = c.get("/healthz")
                assert health.status_code == 503
                (store,) = [ch for ch in health.json()["checks"] if ch["name"] == "store"]
                assert not store["ok"] and "free" in store["error"]
                (small_disk / "filler").unlink()
                assert c.patch(f"/api/jobs/{job_id}", json={"priority": 7}).status_code == 200
                assert c.get(f"/api/jobs/{job_id}/animation.mp4").status_code == 200
                png = c.get(f"/api/jobs/{job_id}/frames/1.png")
                assert png.status_code == 200 and png.content.endswith(b"IEND\xaeB`\x82")
        finally:
            server.should_exit = True
            thread.join(10)
    finally:
        redis_server.stop()
