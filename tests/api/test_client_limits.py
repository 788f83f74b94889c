"""Who a client is, for the per-client event-stream limit, through a real
`argand serve` (uvicorn as the CLI runs it): the address that connected, not
an X-Forwarded-For header, unless the proxy sending it is trusted
(--forwarded-allow-ips / ARGAND_FORWARDED_ALLOW_IPS); and the API token's
holder, whatever its address."""

from __future__ import annotations

import contextlib

import httpx

from tests.farm.test_farm import Farm

TOKEN = "tok-5be1c0a4d9"
PER_CLIENT = 8


def _clients(url: str) -> dict[str, httpx.Client]:
    return {ip: httpx.Client(base_url=url, timeout=30, transport=httpx.HTTPTransport(local_address=ip))
            for ip in ("127.0.0.1", "127.0.0.2", "127.0.0.3")}


def _open(streams: contextlib.ExitStack, client: httpx.Client, path: str, headers: dict | None = None) -> int:
    """Opens an event stream (kept open until ``streams`` closes) and returns its status."""
    r = streams.enter_context(client.stream("GET", path, headers=headers or {}))
    return r.status_code


def test_forged_forwarded_headers_and_tokens_do_not_multiply_a_clients_streams(tmp_path):
    farm = Farm(tmp_path / "data", workers=0, ARGAND_API_TOKEN=TOKEN).start()  # no worker: the job stays queued
    clients = _clients(farm.url)
    auth = {"Authorization": f"Bearer {TOKEN}"}
    try:
        r = clients["127.0.0.1"].post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16},
                                      headers=auth)
        assert r.status_code == 201, r.text
        path = f"/api/jobs/{r.json()['id']}/events"
        with contextlib.ExitStack() as streams:
            assert [_open(streams, clients["127.0.0.1"], path) for _ in range(PER_CLIENT)] == [200] * PER_CLIENT
            # 20 more, each claiming another address: the same client, refused.
            forged = [_open(streams, clients["127.0.0.1"], path, {"X-Forwarded-For": f"10.9.9.{n}"})
                      for n in range(20)]
            assert forged == [429] * 20
            r = clients["127.0.0.1"].get(path, headers={"X-Forwarded-For": "10.9.9.99"})
            assert "this client (127.0.0.1)" in r.json()["detail"]
            # The token's holder is one client, from any address.
            held = [_open(streams, clients[ip], path, auth) for ip in ("127.0.0.2",) * PER_CLIENT + ("127.0.0.3",)]
            assert held == [200] * PER_CLIENT + [429]
            assert _open(streams, clients["127.0.0.3"], path) == 200  # without it, 127.0.0.3 is a client of its own
    finally:
        for c in clients.values():
            c.close()
        farm.stop()


def test_a_trusted_proxys_forwarded_addresses_are_believed(tmp_path):
    farm = Farm(tmp_path / "data", workers=0, ARGAND_FORWARDED_ALLOW_IPS="127.0.0.1").start()
    clients = _clients(farm.url)
    try:
        r = clients["127.0.0.1"].post("/api/jobs", json={"scene": "plucker", "width": 32, "height": 32, "tile": 16})
        path = f"/api/jobs/{r.json()['id']}/events"
        with contextlib.ExitStack() as streams:
            # Through the proxy (127.0.0.1) the clients are the addresses it forwards.
            assert [_open(streams, clients["127.0.0.1"], path, {"X-Forwarded-For": f"10.9.9.{n}"})
                    for n in range(PER_CLIENT + 4)] == [200] * (PER_CLIENT + 4)
            # From an address that is not a trusted proxy, the header is ignored.
            own = [_open(streams, clients["127.0.0.2"], path, {"X-Forwarded-For": f"10.8.8.{n}"})
                   for n in range(PER_CLIENT + 1)]
            assert own == [200] * PER_CLIENT + [429]
    finally:
        for c in clients.values():
            c.close()
        farm.stop()
