"""`argand serve`, the supervisor: Redis (embedded or external), the schema
upgraded, N worker processes (`argand worker`) and the API (uvicorn) in the
foreground; Ctrl-C stops everything. The settings travel to the workers as
their environment (Settings.environment); this process's own are passed
explicitly.

* A lock on the data folder (``farm.lock``) refuses a second farm on it;
  holding it proves that the farm that served the folder before is gone
  (its workers die with it), so whatever its workers held is declared dead
  at once (argand.farm.workers.declare_dead), not after heartbeat_timeout_s.
* SIGTERM is handled as SIGINT: the API drains, the children are stopped,
  the exit status is 0.
* A worker's environment is this process's without the ARGAND_* variables
  (the API token among them), plus the settings a worker needs.
* A worker or the embedded Redis that dies is started again, after a
  backoff (1 s, doubling to 30 s; back to 1 s once it has lived a minute).
* The children die with this process (PR_SET_PDEATHSIG), even on kill -9."""

from __future__ import annotations

import fcntl
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from argand.farm.database import upgrade
from argand.farm.settings import Settings
from argand.farm.workers import BOOT_MARK, declare_dead, identities_of
from argand.serve.embedded_redis import EmbeddedRedis, dying_with_parent
from argand.serve.job_log import JobLog
from argand.serve.ports import listen_on

BACKOFF_S = (1.0, 30.0)
STEADY_S = 60.0


class FarmLocked(RuntimeError):
    """Another `argand serve` holds this data folder."""


def lock_data_dir(path: Path):
    """Holds ``path/farm.lock`` (an exclusive flock) for this process's
    life; returns the open file (keep it). Raises FarmLocked."""
    path.mkdir(parents=True, exist_ok=True)
    f = open(path / "farm.lock", "a+")  # noqa: SIM115 - held until exit
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        f.seek(0)
        holder = f.read().strip() or "another process"
        f.close()
        raise FarmLocked(f"another farm (pid {holder}) serves the data folder {path}; stop it first, "
                         "or give this one its own --data") from None
    f.truncate(0)
    f.write(str(os.getpid()))
    f.flush()
    return f


def worker_command(name: str) -> list[str]:
    return [sys.executable, "-m", "argand.cli", "worker", "--name", name]


#: The workers' niceness above the API's: renders take every cycle the API leaves,
#: and a request does not wait behind them for the CPU.
WORKER_NICE = 10


def start_worker(settings: Settings, name: str) -> subprocess.Popen:
    """A worker that dies with the supervisor and runs below the API."""
    return subprocess.Popen(dying_with_parent(worker_command(name), WORKER_NICE), env=settings.child_environment())


def slot_names(count: int) -> list[str]:
    return [f"w{i + 1}@{os.uname().nodename}" for i in range(count)]


def earlier_workers_pattern() -> str:
    """The identities this folder's earlier `argand serve` gave its workers on
    this host: w1+<boot>@host, w1.2+<boot>@host (restarts), and w1@host
    (before boot ids)."""
    return rf"w\d+(\.\d+)?(\{BOOT_MARK}[0-9a-f]+)?@{re.escape(os.uname().nodename)}"


def stop_all(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()


def restart_name(name: str) -> str:
    """w1@host -> w1.2@host -> w1.3@host: each start of a worker slot its own name."""
    base, _, host = name.partition("@")
    slot, _, n = base.partition(".")
    return f"{slot}.{int(n or 1) + 1}@{host}"


class _Restarts:
    """One child's backoff: the delay before its next start."""

    def __init__(self) -> None:
        self.delay, self.started, self.due = BACKOFF_S[0], time.monotonic(), None

    def dead(self, now: float) -> bool:
        """True when the dead child is due to be started again."""
        if self.due is None:
            if now - self.started > STEADY_S:
                self.delay = BACKOFF_S[0]
            self.due = now + self.delay
            self.delay = min(self.delay * 2, BACKOFF_S[1])
        return now >= self.due

    def restarted(self, now: float) -> None:
        self.started, self.due = now, None


class Supervisor(threading.Thread):
    """Starts again what dies: the workers and the embedded Redis."""

    def __init__(self, settings: Settings, redis: EmbeddedRedis | None, procs: list[subprocess.Popen],
                 names: list[str], announce=print) -> None:
        super().__init__(name="argand-supervisor", daemon=True)
        self.settings, self.redis, self.procs, self.names, self.announce = settings, redis, procs, names, announce
        self.stop = threading.Event()
        self._redis = _Restarts()
        self._workers = [_Restarts() for _ in procs]
        self._declared: set[int] = set()  # pids of the workers already declared dead

    def run(self) -> None:
        while not self.stop.wait(0.5):
            now = time.monotonic()
            if self.redis is not None and (self.redis.proc is None or self.redis.proc.poll() is not None):
                if self._redis.dead(now):
                    try:
                        self.redis.start()
                        self.announce("Redis died and was started again")
                    except RuntimeError as exc:
                        self.announce(f"Redis did not start again: {exc}")
                    self._redis.restarted(time.monotonic())
            for i, p in enumerate(self.procs):
                if p.poll() is not None and p.pid not in self._declared:
                    self._declare_dead(p, self.names[i])
                if p.poll() is not None and self._workers[i].dead(now) and not self.stop.is_set():
                    # A new name: the dead one's tiles stay claimed under its old
                    # name until the reaper sees its heartbeats stop, which a
                    # successor beating under the same name would hide.
                    old, self.names[i] = self.names[i], restart_name(self.names[i])
                    self.procs[i] = start_worker(self.settings, self.names[i])
                    self._workers[i].restarted(time.monotonic())
                    self.announce(f"worker {old} exited with {p.returncode}; started {self.names[i]} in its place")


    def _declare_dead(self, proc: subprocess.Popen, name: str) -> None:
        """A worker process that ended beats no more: counted dead at once
        (/healthz, /api/workers, and its tiles given back by the reaper's
        next round), not after heartbeat_timeout_s."""
        try:
            declare_dead(self.settings, identities_of(name))
            self._declared.add(proc.pid)
        except Exception as exc:  # the database is busy or away: the next round tries again
            self.announce(f"worker {name} exited; could not mark it dead yet: {type(exc).__name__}")


def serve(settings: Settings, workers: int, announce=print) -> None:
    import uvicorn

    from argand.api.app import create_app, uvicorn_options

    lock = lock_data_dir(settings.data_path)
    try:
        listening = listen_on(settings.host, settings.port)  # PortTaken before anything starts
    except BaseException:
        lock.close()
        raise
    # SIGTERM (docker stop, systemd, kill) as Ctrl-C: uvicorn drains and
    # re-raises it once done, and the cleanup below runs.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    redis = None
    if settings.redis_url is None:
        redis = EmbeddedRedis(settings.redis_socket).start()
        settings = settings.model_copy(update={"redis_url": redis.url})
    upgrade(settings.sqlalchemy_url)  # before the workers and the API use it
    # The lock is ours: the farm that held it before is gone, and its workers with it.
    earlier = declare_dead(settings, earlier_workers_pattern())
    if earlier:
        announce(f"the workers of this folder's previous run ({', '.join(sorted(earlier))}) are gone: "
                 "their work is given back")
    names = slot_names(workers)
    procs = [start_worker(settings, n) for n in names]
    supervisor = Supervisor(settings, redis, procs, names, announce)
    supervisor.start()
    job_log = JobLog(settings, announce)
    try:
        if os.geteuid() == 0:
            announce("note: running as root; the workers accept JSON messages only (never pickle), "
                     "but a farm is better run as an ordinary user")
        announce(f"{workers} worker(s), data in {settings.data_path}, API docs at /docs; Ctrl-C stops the farm")
        announce(f"Argand is serving on http://{settings.host}:{settings.port}/")
        job_log.start()
        server = uvicorn.Server(uvicorn.Config(create_app(settings), **uvicorn_options(settings)))
        try:
            server.run(sockets=[listening])
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM, re-raised by uvicorn once it drained: a clean stop
            pass
    finally:
        job_log.stop.set()
        listening.close()
        supervisor.stop.set()
        supervisor.join(5)
        stop_all(supervisor.procs)
        if redis:
            redis.stop()
        lock.close()
