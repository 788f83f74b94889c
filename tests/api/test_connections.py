"""Connections that never finish their headers are closed (uvicorn alone
keeps them open for good), idle keep-alive ones too, and the API goes on
answering while they are held. Real uvicorn with the API's own options
(argand.api.app.uvicorn_options), real sockets on loopback."""

from __future__ import annotations

import socket
import threading
import time

import httpx
import uvicorn

from argand.api import connections
from argand.api.app import create_app, uvicorn_options
from tests.farm.test_farm import free_port
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)


def closed_by_server(sock: socket.socket, within: float) -> bool:
    """The server closes ``sock`` within ``within`` seconds (what it still
    sends before, the rest of a response, is read and dropped)."""
    deadline = time.monotonic() + within
    while (left := deadline - time.monotonic()) > 0:
        sock.settimeout(left)
        try:
            if sock.recv(65536) == b"":
                return True
        except (TimeoutError, socket.timeout):
            return False
        except ConnectionResetError:
            return True
    return False


def test_stalled_headers_are_timed_out_and_the_api_keeps_answering(farm_parts, monkeypatch):  # noqa: F811
    settings, _redis = farm_parts
    monkeypatch.setattr(connections, "HEADER_TIMEOUT_S", 1.0)
    port = free_port()
    options = dict(uvicorn_options(settings), host="127.0.0.1", port=port)
    server = uvicorn.Server(uvicorn.Config(create_app(settings), **options))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert server.started
    stalled = []
    try:
        for _ in range(50):  # half a request each, never finished
            s = socket.create_connection(("127.0.0.1", port))
            s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            stalled.append(s)
        assert httpx.get(f"http://127.0.0.1:{port}/readyz", timeout=10).status_code == 200
        start = time.monotonic()
        assert all(closed_by_server(s, 8.0) for s in stalled)
        assert time.monotonic() - start < 9.0  # (1 s, and a loaded machine's slack)
        # A keep-alive connection: its first request is answered, a second one left half-sent is closed.
        s = socket.create_connection(("127.0.0.1", port))
        stalled.append(s)
        s.sendall(b"GET /readyz HTTP/1.1\r\nHost: x\r\n\r\n")
        s.settimeout(10)
        assert s.recv(65536).startswith(b"HTTP/1.1 ")  # answered (its status is /readyz's business)
        s.sendall(b"GET /readyz HTTP/1.1\r\n")
        assert closed_by_server(s, 5.0)
    finally:
        for s in stalled:
            s.close()
        server.should_exit = True
        thread.join(10)
