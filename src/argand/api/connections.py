"""Bounds on the connections the API serves, so that slow or stalled
clients cannot hold the process's file descriptors:

* a connection must finish a request's headers within ``HEADER_TIMEOUT_S``
  of opening (or of its previous response): uvicorn times out only idle
  keep-alive connections, so one that sends half a request line used to
  stay open for good (20,000 of them exhausted the file limit and /healthz
  was refused);
* an idle keep-alive connection is closed after ``KEEP_ALIVE_S``;
* beyond ``MAX_CONNECTIONS`` connections and requests at once, uvicorn
  answers 503 at once instead of taking more.

:func:`bounded_protocol` wraps uvicorn's HTTP protocol class (httptools or
h11, whichever uvicorn picks) with the header timeout."""

from __future__ import annotations

import asyncio

HEADER_TIMEOUT_S = 10.0
KEEP_ALIVE_S = 5
MAX_CONNECTIONS = 1000


def bounded_protocol(base: type) -> type:
    """``base`` (a uvicorn HTTP protocol class) with the header timeout."""

    class HeaderTimeout(base):
        _header_timer: asyncio.TimerHandle | None = None

        def _arm(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
            self._header_timer = self.loop.call_later(HEADER_TIMEOUT_S, self._headers_late)

        def _headers_late(self) -> None:
            # No request in progress: the client has not finished the headers of one since it was armed.
            if (self.cycle is None or self.cycle.response_complete) and not self.transport.is_closing():
                self.transport.close()

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            self._arm()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._arm()

        def connection_lost(self, exc) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
            super().connection_lost(exc)

    HeaderTimeout.__name__ = f"HeaderTimeout{base.__name__}"
    return HeaderTimeout


def http_protocol() -> type:
    """uvicorn's HTTP protocol of choice (httptools when installed), bounded."""
    try:
        from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol as base
    except ImportError:
        from uvicorn.protocols.http.h11_impl import H11Protocol as base
    return bounded_protocol(base)


def connection_options() -> dict:
    """uvicorn.Config's options for these bounds."""
    return {"http": http_protocol(), "timeout_keep_alive": KEEP_ALIVE_S, "limit_concurrency": MAX_CONNECTIONS}
