"""The API in process for tests: uvicorn on a free loopback port, in a
thread (one start-and-wait loop for every test module that needs it)."""

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any, Iterator

import uvicorn

from tests.farm.test_farm import free_port


def start(app: Any, timeout: float = 30.0) -> tuple[uvicorn.Server, threading.Thread, str]:
    """Serves ``app`` on a free loopback port; returns (server, thread, base URL)
    once uvicorn says it has started (asserts that it did within ``timeout``)."""
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + timeout
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert server.started, f"uvicorn did not start on port {port} within {timeout} s"
    return server, thread, f"http://127.0.0.1:{port}"


def stop(server: uvicorn.Server, thread: threading.Thread) -> None:
    server.should_exit = True
    thread.join(10)


@contextlib.contextmanager
def served(app: Any) -> Iterator[str]:
    """``with served(app) as url:`` the app is served at ``url`` inside the block."""
    server, thread, url = start(app)
    try:
        yield url
    finally:
        stop(server, thread)
