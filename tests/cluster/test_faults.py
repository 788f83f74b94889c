"""Faults a farm of several hosts meets, each during a running job of 768
tiles (tests/cluster/checks.py says what is checked after each, and the
figures go to build/cluster/figures.json)."""

from __future__ import annotations

import signal
import time

import pytest

from tests.cluster.checks import JOB, Prober, check_job, record, submit, tiles_done, wait_done, wait_tiles
from tests.cluster.harness import PG_PORT, PYTHON, REDIS_PORT

pytestmark = pytest.mark.cluster
TILES = 768


def worker_tiles(cluster, job_id: str, host: str) -> int:
    return cluster.sql("select count(*) from tiles where job_id = :j and worker like :w and status = 'done'",
                       j=job_id, w=f"{host}+%")[0][0]


def both_workers_render(cluster) -> float:
    """After a fault is healed: a new job is rendered by both worker hosts.
    Returns the seconds until each has rendered a tile of it."""
    job_id = submit(cluster, {**JOB, "deltas": {"start": 0, "stop": "pi/9", "count": 24}})
    took = cluster.wait(lambda: all(worker_tiles(cluster, job_id, h) for h in ("w1", "w2")), 60,
                        "both worker hosts render tiles of a new job")
    wait_done(cluster, job_id, 120)
    check_job(cluster, job_id)
    return took


def test_a_job_across_hosts_equals_a_local_render(farm):
    start = time.monotonic()
    job_id = submit(farm)
    with Prober(farm, job_id) as probe:
        wait_done(farm, job_id, 60)
    figures = {"job_s": time.monotonic() - start, **check_job(farm, job_id), **probe.check(2.0)}
    assert figures["claimed_again"] == 0
    assert worker_tiles(farm, job_id, "w1") and worker_tiles(farm, job_id, "w2")
    record("no fault", figures)


def test_a_worker_host_killed_for_good(farm):
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    farm.kill_host("w1")
    killed = time.monotonic()
    with Prober(farm, job_id) as probe:
        wait_done(farm, job_id, 90)
    figures = {"done_after_kill_s": time.monotonic() - killed, **check_job(farm, job_id), **probe.check()}
    record("worker host killed", figures)


def test_a_worker_host_cut_off_from_redis_past_the_visibility_timeout(farm):
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    farm.partition("w1", "db", REDIS_PORT)
    with Prober(farm, job_id) as probe:
        took = wait_done(farm, job_id, 60)
        time.sleep(max(0.0, 20 - took))  # past the visibility timeout (16 s)
        farm.heal("w1")
        back = both_workers_render(farm)
    figures = {"partition_s": 20, "job_s": took, "back_after_heal_s": back, **check_job(farm, job_id), **probe.check()}
    record("worker host cut off from Redis for 20 s", figures)
    assert back < 45  # the stalled consumer is noticed (argand.worker.stall_check) and the worker started again


def test_a_worker_host_cut_off_from_postgresql(farm):
    """The cut-off host holds the reaper's lease when the link goes (it
    still reaches Redis): it must hand it on, or nobody gives its tiles back."""
    import redis

    from argand.worker.heartbeat import REAPER_KEY

    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    with farm.client() as c:
        w1 = max((w for w in c.get("/api/workers").json() if w["host"] == "host-w1" and w["alive"]),
                 key=lambda w: w["heartbeat"])["name"]
    redis.Redis.from_url(farm.redis_url, socket_timeout=5).set(REAPER_KEY, w1, px=5000)
    farm.partition("w1", "db", PG_PORT)
    with Prober(farm, job_id) as probe:
        took = wait_done(farm, job_id, 60)
        time.sleep(max(0.0, 12 - took))
        farm.heal("w1")
        back = both_workers_render(farm)
    figures = {"partition_s": 12, "job_s": took, "back_after_heal_s": back, **check_job(farm, job_id), **probe.check()}
    record("worker host cut off from PostgreSQL for 12 s", figures)


def test_a_worker_started_while_its_host_is_cut_off_from_postgresql(farm):
    """A worker (re)started while its host cannot reach the database (the
    watchdog's kill during a partition, a host booting during an outage)
    beats once the link is back. Its first heartbeat used to raise out of
    Celery's worker_ready: the worker then took tasks but never beat, never
    ran its watchdog or stall check, and its host stayed unhealthy for good
    (what failed make test in a clean clone, at random: a restart inside the
    partition of the test above)."""
    farm.stop_proc("w1", "worker", signal.SIGKILL)
    farm.partition("w1", "db", PG_PORT)
    farm.start_worker("w1")
    log = farm.proc("w1", "worker").log
    farm.wait(lambda: "no first heartbeat" in log.read_text(errors="replace"), 60,
              "the worker on w1 started and found no database")
    farm.heal("w1")
    healed = time.monotonic()
    farm.wait(lambda: farm.worker_healthy("w1"), 30, "the worker on w1 is healthy after the heal")
    figures = {"healthy_after_heal_s": time.monotonic() - healed, "back_after_heal_s": both_workers_render(farm)}
    record("worker started while its host is cut off from PostgreSQL", figures)


def test_the_api_cut_off_from_postgresql_answers_503_then_recovers(farm):
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    farm.partition("api", "db", PG_PORT)
    with Prober(farm, job_id) as probe:
        with farm.client(15) as c:
            start = time.monotonic()
            r = c.post("/api/jobs", json=JOB)
            post_s = time.monotonic() - start
        assert r.status_code == 503 and r.headers.get("retry-after"), (r.status_code, r.text)
        time.sleep(12)
        farm.heal("api")
        healed = time.monotonic()
        recovered = farm.wait(lambda: farm._status(f"/api/jobs/{job_id}") == 200, 30, "the API answers again")
        wait_done(farm, job_id, 60)
    figures = {"partition_s": 12, "refused_post_s": post_s, "api_back_after_heal_s": recovered,
               **check_job(farm, job_id), **probe.check()}
    assert probe.check()["answered_503"] > 0
    record("API cut off from PostgreSQL for 12 s", figures)
    assert time.monotonic() - healed < 60


def test_the_api_cut_off_from_redis_keeps_taking_jobs(farm):
    first = submit(farm)
    wait_tiles(farm, first, TILES // 5)
    farm.partition("api", "db", REDIS_PORT)
    with Prober(farm, first) as probe:
        start = time.monotonic()
        second = submit(farm)  # written to the outbox; the reaper in a worker sends it
        post_s = time.monotonic() - start
        time.sleep(10)
        farm.heal("api")
        healed = time.monotonic()
        wait_done(farm, first, 60)
        wait_done(farm, second, 60)
    figures = {"partition_s": 10, "accepted_post_s": post_s, "second_done_after_heal_s": time.monotonic() - healed,
               **check_job(farm, first), **probe.check()}
    check_job(farm, second)
    record("API cut off from Redis for 10 s", figures)


def test_redis_killed_and_restarted_under_load(farm):
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    farm.stop_proc("db", "redis", signal.SIGKILL)
    with Prober(farm, job_id) as probe:
        time.sleep(3)
        farm.start_redis()
        restarted = time.monotonic()
        wait_done(farm, job_id, 90)
    figures = {"down_s": 3, "done_after_restart_s": time.monotonic() - restarted, **check_job(farm, job_id),
               **probe.check()}
    record("Redis killed, restarted after 3 s (AOF)", figures)


def test_postgresql_restarted_under_load(farm):
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    farm.stop_proc("db", "postgres", signal.SIGINT)  # a fast shutdown: every session cut
    with Prober(farm, job_id) as probe:
        time.sleep(3)
        farm.start_postgres()
        restarted = time.monotonic()
        wait_done(farm, job_id, 90)
    figures = {"down_s": 3, "done_after_restart_s": time.monotonic() - restarted, **check_job(farm, job_id),
               **probe.check()}
    record("PostgreSQL restarted (down 3 s)", figures)


def redis_round_trip_ms(cluster, host: str, pings: int = 20) -> float:
    """The median time of a PING to Redis from ``host`` over a new connection."""
    code = ("import socket, statistics, sys, time\n"
            f"s = socket.create_connection(('{cluster.ip('db')}', {REDIS_PORT}), 10)\n"
            "times = []\n"
            f"for _ in range({pings}):\n"
            "    t = time.monotonic(); s.sendall(b'PING\\r\\n'); s.recv(64); times.append(time.monotonic() - t)\n"
            "print(1000 * statistics.median(times))\n")
    r = cluster.exec(host, PYTHON, "-c", code)
    assert r.returncode == 0, r.stderr
    return float(r.stdout)


def test_a_slow_lossy_worker_link_for_a_whole_job(farm):
    """200 ms more on everything w1 sends to Redis and PostgreSQL, and 5% of
    its link's packets lost, from before the jobs until they are done (the
    worker on w1 started again behind the slow link, so that every one of
    its connections is slow).

    First a job shared with w2, under the cluster's short time limits: a
    run of one tile on that link takes about as long as the hard limit
    (8 s here; 150 s by default), so the watchdog may end w1's worker in a
    run and its tiles go to w2 (counted: ``w1_restarts``). Then a small job
    on w1 alone, with time limits of 60/80 s, every tile over the slow link:
    what the link costs a tile."""
    before_ms = redis_round_trip_ms(farm, "w1")
    farm.stop_proc("w1", "worker")
    try:
        farm.slow_link("w1", delay_ms=200, loss_percent=5)
        after_ms = redis_round_trip_ms(farm, "w1")
        assert after_ms >= 190, after_ms
        farm.start_worker("w1")
        farm.wait(lambda: farm.worker_healthy("w1"), 90, "the worker on w1 (slow link) is healthy")
        seen = set(farm.sql("select name from workers where host = 'host-w1'"))
        start = time.monotonic()
        job_id = submit(farm)
        with Prober(farm, job_id) as probe:
            wait_done(farm, job_id, 120)
        figures = {"delay_ms": 200, "loss_percent": 5, "redis_round_trip_ms_before": before_ms,
                   "redis_round_trip_ms_slow": after_ms, "job_s": time.monotonic() - start,
                   "w1_tiles": worker_tiles(farm, job_id, "w1"), **check_job(farm, job_id), **probe.check(),
                   "w1_restarts": len(set(farm.sql("select name from workers where host = 'host-w1'")) - seen)}
        # w1 alone, with time limits that a slow link's run fits in: 4 tiles of 32x32.
        farm.stop_proc("w2", "worker")
        farm.stop_proc("w1", "worker")
        farm.start_worker("w1", env={"ARGAND_TILE_SOFT_TIME_LIMIT_S": "60", "ARGAND_TILE_HARD_TIME_LIMIT_S": "80"})
        farm.wait(lambda: farm.worker_healthy("w1"), 90, "the worker on w1 (slow link, long limits) is healthy")
        start = time.monotonic()
        alone = submit(farm, {"scene": "whitney", "width": 64, "height": 64, "tile": 32})
        wait_done(farm, alone, 100)
        figures["w1_alone_s_per_tile"] = (time.monotonic() - start) / 4
        assert worker_tiles(farm, alone, "w1") == check_job(farm, alone)["tiles"] == 4
        record("200 ms delay and 5% packet loss on a worker host's link", figures)
    finally:
        farm.stop_proc("w1", "worker", signal.SIGKILL)  # the next test starts it (and w2) on a healed link
        farm.heal("w1")


def w1_rows(farm) -> list[dict]:
    """The farm's worker rows of host-w1 (GET /api/workers)."""
    with farm.client() as c:
        return [w for w in c.get("/api/workers").json() if w["host"] == "host-w1"]


def test_a_worker_host_whose_clock_is_30_s_behind(farm):
    """Heartbeats are written and judged by the database's clock: a worker
    host whose wall clock is 30 s behind (twice the heartbeat timeout and
    more) is neither declared dead by a reaper on another host nor has its
    tiles taken away, and the farm sees it alive."""
    import redis

    from argand.worker.heartbeat import REAPER_KEY

    before = {w["name"] for w in w1_rows(farm)}  # the identities of w1 so far (the running one among them)
    farm.stop_proc("w1", "worker", signal.SIGKILL)
    farm.start_worker("w1", clock_offset_s=-30)
    try:
        farm.wait(lambda: farm.worker_healthy("w1"), 60, "the worker on w1 (clock 30 s behind) is healthy")
        # The reaper runs on w2, the host with the right time, judging w1's heartbeats.
        with farm.client() as c:  # (the newest identity of w2: one killed by an earlier test may still count as alive)
            w2 = max((w for w in c.get("/api/workers").json() if w["host"] == "host-w2" and w["alive"]),
                     key=lambda w: w["heartbeat"])["name"]
        redis.Redis.from_url(farm.redis_url, socket_timeout=5).set(REAPER_KEY, w2, px=5000)
        job_id = submit(farm)
        with Prober(farm, job_id) as probe:
            took = wait_done(farm, job_id, 90)
        figures = {"clock_offset_s": -30, "job_s": took, "w1_tiles": worker_tiles(farm, job_id, "w1"),
                   **check_job(farm, job_id), **probe.check()}
        # The process killed above counts as alive until its last heartbeat
        # is heartbeat_timeout_s old, then keeps a dead row until the
        # reaper's next round deletes it: the property is that, once that
        # much time has passed, the one w1 identity alive is a new one (the
        # process 30 s behind, or one its restart loop started).
        seen: list[list[dict]] = []

        def only_a_new_w1_alive() -> bool:
            seen.append(w1_rows(farm))
            alive = [w["name"] for w in seen[-1] if w["alive"]]
            return len(alive) == 1 and alive[0] not in before

        try:
            farm.wait(only_a_new_w1_alive, 30, "one worker of host-w1 alive, a new one")
        except AssertionError as exc:
            raise AssertionError(f"{exc}; before: {sorted(before)}; last rows: {seen[-1:]}") from None
        assert figures["claimed_again"] == 0 and figures["w1_tiles"] > 0, figures
        record("worker host's clock 30 s behind", figures)
    finally:
        farm.stop_proc("w1", "worker", signal.SIGKILL)  # the next test starts it with the right time


def test_a_worker_host_frozen_past_the_heartbeat_timeout(farm):
    """Every process of a worker host stopped (SIGSTOP) while it renders,
    until the job is done without it, then continued: the stale worker
    writes nothing into the finished job (check_job: no tile file left, every
    tile counted once) and takes work again."""
    job_id = submit(farm)
    wait_tiles(farm, job_id, TILES // 5)
    held = 0
    for _ in range(50):  # frozen while it holds a tile (not between two messages)
        farm.signal_host("w1", signal.SIGSTOP)
        held = farm.sql("select count(*) from tiles where job_id = :j and status = 'running' and worker like 'w1+%'",
                        j=job_id)[0][0]
        if held:
            break
        farm.signal_host("w1", signal.SIGCONT)
        time.sleep(0.02)
    assert held, "the worker on w1 never held a tile when frozen"
    try:
        with Prober(farm, job_id) as probe:
            took = wait_done(farm, job_id, 60)
            time.sleep(max(0.0, 8 - took))  # past twice the heartbeat timeout
    finally:
        farm.signal_host("w1", signal.SIGCONT)
    time.sleep(2)  # the stale run's next look at its job
    figures = {"frozen_s": max(8.0, took), "job_s": took, "tiles_held_when_frozen": held, **check_job(farm, job_id),
               **probe.check()}
    assert figures["claimed_again"] >= held  # what it held was given to the other host
    figures["back_after_continue_s"] = both_workers_render(farm)
    record("worker host frozen (SIGSTOP) past the heartbeat timeout", figures)


def test_the_same_job_on_one_worker_host_and_on_two(farm):
    """Scaling across hosts, each worker host pinned to a core of its own:
    the same job on w1 alone, then on both, which share it. What the farm and the network
    add per tile is the one-host time less a local render of the same
    frames, over the tiles."""
    from tests.cluster.checks import local_frame

    farm.stop_proc("w2", "worker", signal.SIGKILL)
    start = time.monotonic()
    one = submit(farm)
    wait_done(farm, one, 120)
    one_s = time.monotonic() - start
    check_job(farm, one)
    farm.start_worker("w2")
    farm.wait(lambda: farm.worker_healthy("w2"), 60, "the worker on w2 is healthy")
    start = time.monotonic()
    two = submit(farm)
    wait_done(farm, two, 120)
    two_s = time.monotonic() - start
    check_job(farm, two)
    frames = farm.sql("select sigma, delta from frames where job_id = :j", j=two)
    local_frame.cache_clear()
    start = time.monotonic()
    for f in frames:
        local_frame("whitney", f.sigma, f.delta, JOB["width"], JOB["height"])
    local_s = time.monotonic() - start
    figures = {"one_host_s": one_s, "two_hosts_s": two_s, "speed_up": one_s / two_s, "local_render_s": local_s,
               "added_per_tile_ms": 1000 * (one_s - local_s) / TILES}
    record("one worker host against two", figures)
    # The two hosts share the job (the speed-up itself is a figure: on a shared
    # 2-core machine it moves with everything else that runs).
    shares = [worker_tiles(farm, two, host) / TILES for host in ("w1", "w2")]
    assert min(shares) > 0.25, (shares, figures)
