"""Clients behind a reverse proxy, across hosts: two client machines reach
the API only through the proxy host (tests/cluster/proxies.py, setting
X-Forwarded-For as nginx does). The per-client limit on event streams (8)
must count each client, not the proxy: with the API trusting that proxy's
forwarded address (ARGAND_FORWARDED_ALLOW_IPS, --forwarded-allow-ips),
each client gets its own 8 and its ninth is a 429 that names it; without
that setting every client behind the proxy is the proxy, one client."""

from __future__ import annotations

import contextlib

import httpx
import pytest

from tests.cluster.checks import submit
from tests.cluster.harness import TOKEN

pytestmark = pytest.mark.cluster
PER_CLIENT = 8  # the default of max_streams_per_client


def _viewer(cluster, host: str) -> httpx.Client:
    """A viewer on client machine ``host``, through the proxy, without the
    API token (a holder of the token is one client wherever it is)."""
    return httpx.Client(base_url=cluster.proxy_url, timeout=30, trust_env=False,
                        transport=httpx.HTTPTransport(local_address=cluster.ip(host)))


def _open(streams: contextlib.ExitStack, client: httpx.Client, path: str, headers: dict | None = None):
    """An event stream, kept open until ``streams`` closes; its response."""
    return streams.enter_context(client.stream("GET", path, headers=headers or {}))


def _restart_api(cluster, env: dict[str, str] | None = None) -> None:
    cluster.stop_proc("api", "api")
    cluster.start_api(env)


@pytest.fixture
def paused_job(farm):
    """A job that stays unended (paused) for as long as the test, so its
    event streams stay open; the proxy running."""
    if not any(p.name == "http-proxy" and p.popen.poll() is None for p in farm.procs):
        farm.start_proxy()
    job_id = submit(farm)
    with farm.client() as c:
        r = c.post(f"/api/jobs/{job_id}/pause")
        assert r.status_code == 200, r.text
    yield job_id
    with farm.client() as c:
        c.post(f"/api/jobs/{job_id}/cancel")


def test_an_untrusted_proxy_is_one_client(farm, paused_job):
    # The API as the farm runs it: no ARGAND_FORWARDED_ALLOW_IPS, so X-Forwarded-For is not believed.
    path = f"/api/jobs/{paused_job}/events"
    with _viewer(farm, "c1") as c1, _viewer(farm, "c2") as c2, contextlib.ExitStack() as streams:
        opened = [_open(streams, c, path).status_code for c in (c1, c2) * (PER_CLIENT // 2)]
        assert opened == [200] * PER_CLIENT
        ninth = _open(streams, c2, path)
        ninth.read()
        assert ninth.status_code == 429, ninth.status_code
        assert f"this client ({farm.ip('proxy')})" in ninth.json()["detail"], ninth.text


def test_a_trusted_proxy_counts_each_client_behind_it(farm, paused_job):
    _restart_api(farm, {"ARGAND_FORWARDED_ALLOW_IPS": farm.ip("proxy")})
    path = f"/api/jobs/{paused_job}/events"
    try:
        _trusted(farm, path)
    finally:
        _restart_api(farm)  # as the other tests have it


def _trusted(farm, path: str) -> None:
    with _viewer(farm, "c1") as c1, _viewer(farm, "c2") as c2, contextlib.ExitStack() as streams:
        assert [_open(streams, c1, path).status_code for _ in range(PER_CLIENT)] == [200] * PER_CLIENT
        assert [_open(streams, c2, path).status_code for _ in range(PER_CLIENT)] == [200] * PER_CLIENT
        for client, host in ((c1, "c1"), (c2, "c2")):
            ninth = _open(streams, client, path)
            ninth.read()
            assert ninth.status_code == 429 and ninth.headers.get("retry-after"), (ninth.status_code, ninth.text)
            assert f"this client ({farm.ip(host)})" in ninth.json()["detail"], ninth.text
        # A client's own X-Forwarded-For is replaced by the proxy: c1 cannot pass for another.
        forged = _open(streams, c1, path, {"X-Forwarded-For": farm.ip("c2").rsplit(".", 1)[0] + ".99"})
        assert forged.status_code == 429
        # Behind the proxy, the token's holder is still one client of its own.
        auth = {"Authorization": f"Bearer {TOKEN}"}
        assert _open(streams, c1, path, auth).status_code == 200
