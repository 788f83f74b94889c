"""The farm on PostgreSQL (ARGAND_DATABASE_URL): the test starts its own
server from Debian's binaries on a free loopback port, in a temporary folder."""

from __future__ import annotations

import glob
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

from tests.farm.test_farm import Farm, check_frames_against_local, free_port

BIN = sorted(glob.glob("/usr/lib/postgresql/*/bin"))


def as_postgres(*cmd: str) -> list[str]:
    # PostgreSQL refuses to run as root; run it as the postgres user then.
    return ["runuser", "-u", "postgres", "--", *cmd] if os.geteuid() == 0 else list(cmd)


@pytest.fixture
def postgres():
    if not BIN:
        pytest.fail("PostgreSQL server binaries are missing: make setup installs Debian's postgresql (as root)")
    bindir = BIN[-1]
    # (Not under pytest's tmp_path: its parent is private to root, and the
    # server runs as the postgres user.)
    base = Path(tempfile.mkdtemp(prefix="argand-pg-"))
    data = base / "pg"
    data.mkdir()
    if os.geteuid() == 0:
        shutil.chown(base, "postgres")
        shutil.chown(data, "postgres")
    subprocess.run(as_postgres(f"{bindir}/initdb", "-D", str(data), "-U", "postgres", "-A", "trust"), check=True,
                   capture_output=True)
    port = free_port()
    proc = subprocess.Popen(as_postgres(f"{bindir}/postgres", "-D", str(data), "-p", str(port), "-h", "127.0.0.1",
                                        "-k", str(data)), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"postgresql+psycopg://postgres@127.0.0.1:{port}/postgres"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        if subprocess.run([f"{bindir}/pg_isready", "-h", "127.0.0.1", "-p", str(port)], capture_output=True).returncode == 0:
            break
        time.sleep(0.2)
    yield url
    proc.terminate()
    proc.wait(30)
    shutil.rmtree(base, ignore_errors=True)


def test_job_on_postgresql(tmp_path, postgres):
    farm = Farm(tmp_path / "data", workers=2, ARGAND_DATABASE_URL=postgres).start()
    try:
        r = farm.post("/api/jobs", {"scene": "mitchell", "deltas": [0, "pi/18"], "width": 40, "height": 32, "tile": 16})
        assert r.status_code == 201, r.text
        job = farm.wait_job(r.json()["id"], 120)
        assert job["status"] == "done"
        check_frames_against_local(farm, job, "mitchell")
        assert not (farm.data / "argand.db").exists()  # the state lives in PostgreSQL
    finally:
        farm.stop()


def test_a_transaction_left_open_by_a_frozen_client_is_ended_and_its_locks_released(postgres, monkeypatch):
    """A worker frozen (SIGSTOP, a paused VM) or cut off inside a transaction
    would hold its rows locked for as long, and the reaper that gives its
    tiles back would wait on them: the server ends such a session after
    IDLE_IN_TRANSACTION_S (argand.farm.database)."""
    from sqlalchemy import create_engine, text

    from argand.farm import database

    monkeypatch.setattr(database, "IDLE_IN_TRANSACTION_S", 1)
    engine = database.engine_for(postgres)
    with engine.begin() as c:
        c.execute(text("create table held (id int primary key, v int)"))
        c.execute(text("insert into held values (1, 0)"))
    frozen = engine.connect()
    frozen.begin()
    frozen.execute(text("update held set v = 1 where id = 1"))  # the row is locked; then the client stops
    other = create_engine(postgres, connect_args={"options": "-c lock_timeout=10000"})
    try:
        start = time.monotonic()
        with other.begin() as c:
            c.execute(text("update held set v = 2 where id = 1"))
        assert time.monotonic() - start < 5
    finally:
        other.dispose()
        frozen.invalidate()
        database._engines.pop(postgres, None)
        engine.dispose()
