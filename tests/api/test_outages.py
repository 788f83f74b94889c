"""A database that does not answer: every route that needs it answers 503
with Retry-After in bounded time (argand.farm.database's connect and send
timeouts, argand.api.outages), never a 500 and never a hang; it answers
again when the database is back. Real uvicorn and Redis; the "database" is
a loopback port where nothing listens, or a listener that never speaks (as
a host behind a cut link looks to a connecting client)."""

from __future__ import annotations

import socket
import time

import httpx
import pytest

from argand.farm.database import CONNECT_TIMEOUT_S
from tests.farm.test_limits import JOB, _serve
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)


@pytest.fixture
def silent_listener():
    """A loopback port that takes connections and never says a word."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen(64)
        yield s.getsockname()[1]


@pytest.mark.parametrize("database", ["refused", "silent"])
def test_routes_answer_503_with_retry_after_when_the_database_does_not_answer(farm_parts, silent_listener,  # noqa: F811
                                                                              database):
    settings, _redis = farm_parts
    if database == "refused":
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]  # closed again: nothing listens there
    else:
        port = silent_listener
    settings = settings.model_copy(update={"database_url": f"postgresql+psycopg://argand:argand@127.0.0.1:{port}/argand"})
    server, thread, url = _serve(settings)
    try:
        with httpx.Client(base_url=url, timeout=30) as c:
            for method, path, body in (("GET", "/api/jobs", None), ("GET", "/api/jobs/0123456789ab", None),
                                       ("POST", "/api/jobs", JOB), ("PATCH", "/api/jobs/0123456789ab", {"priority": 3}),
                                       ("DELETE", "/api/jobs/0123456789ab", None)):
                start = time.monotonic()
                r = c.request(method, path, json=body)
                took = time.monotonic() - start
                assert r.status_code == 503, (method, path, r.status_code, r.text)
                assert r.headers["retry-after"] == "5" and "database does not answer" in r.json()["detail"]
                assert took < 2 * CONNECT_TIMEOUT_S + 1, (method, path, took)
            start = time.monotonic()
            health = c.get("/healthz")
            assert health.status_code == 503 and time.monotonic() - start < 20
            assert [ch["name"] for ch in health.json()["checks"] if not ch["ok"]][0] == "database"
    finally:
        server.should_exit = True
        thread.join(10)
