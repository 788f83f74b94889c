"""The cluster's fixtures: one cluster for the whole run (its hosts started
once), brought back to health before each test (faults healed, the workers
of every worker host running and healthy), and every test bounded in time
(a test past its limit fails, and the cluster is still torn down)."""

from __future__ import annotations

import signal

import pytest

from tests.cluster.harness import WORKER_HOSTS, Cluster, remove_stale, unavailable

REASON = unavailable()
if REASON:
    pytest.skip(f"cluster tests skipped: {REASON}", allow_module_level=True)

#: The farm's knobs in the cluster: heartbeats and time limits short enough
#: that the faults play out in seconds (the visibility timeout is twice the
#: hard time limit: 16 s), and one tile per message so that a job is many
#: messages on the network. The assemblers write every frame's EXR (the
#: checks read what the workers' tiles made).
CLUSTER_ENV = {
    # The assembler writes every frame's files from the workers' pixels
    # (check_job compares those with a local render).
    "ARGAND_FILES_ON_REQUEST": "false",
    "ARGAND_EXR_ON_REQUEST": "false",
    "ARGAND_HEARTBEAT_INTERVAL_S": "0.5",
    "ARGAND_HEARTBEAT_TIMEOUT_S": "4",
    "ARGAND_TILE_SOFT_TIME_LIMIT_S": "6",
    "ARGAND_TILE_HARD_TIME_LIMIT_S": "8",
    "ARGAND_BATCH_PIXELS": "256",
}
#: Seconds one test may take, its cluster's start not counted.
TEST_LIMIT_S = 150


class ClusterTimeLimit(Exception):
    pass


@pytest.fixture(autouse=True)
def time_limit():
    def expire(*_args):
        raise ClusterTimeLimit(f"the test ran past {TEST_LIMIT_S} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(TEST_LIMIT_S)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="session")
def cluster():
    def terminate(*_args):  # a SIGTERM to pytest still tears the cluster down
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, terminate)
    remove_stale()
    c = Cluster(env=CLUSTER_ENV)
    signal.alarm(180)
    try:
        c.start()
        signal.alarm(0)
        yield c
    finally:
        signal.alarm(0)
        c.close()
        signal.signal(signal.SIGTERM, previous)


@pytest.fixture
def farm(cluster, request):
    """The cluster, healthy: faults healed, every service and worker up."""
    cluster.heal()
    for name, start in (("postgres", cluster.start_postgres), ("redis", cluster.start_redis),
                        ("api", cluster.start_api)):
        host = "api" if name == "api" else "db"
        if cluster.proc(host, name).popen.poll() is not None:
            start()
    for host in WORKER_HOSTS:
        if cluster.proc(host, "worker").popen.poll() is not None:
            cluster.start_worker(host)
    try:
        for host in WORKER_HOSTS:
            cluster.wait(lambda: cluster.worker_healthy(host), 60, f"the worker on {host} is healthy")
    except AssertionError as exc:
        raise AssertionError(f"{exc}\n{cluster.diagnosis()}") from None
    yield cluster
    if request.node.rep_call.failed if hasattr(request.node, "rep_call") else False:
        print(cluster.diagnosis())


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_makereport(item, call):
    report = yield
    setattr(item, f"rep_{report.when}", report)
    return report
