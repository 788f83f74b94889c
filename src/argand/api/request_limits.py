"""The request body limit: an ASGI middleware that answers 413, naming the
limit, for a body above ``max_body_bytes`` (by its Content-Length at once,
or while it arrives when it has none), before any route reads or parses it;
the event streams' slots, and who a client is for them."""

from __future__ import annotations

import hashlib
import hmac
import json


class BodyLimit:
    def __init__(self, app, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def _refuse(self, send) -> None:
        body = json.dumps({"detail": f"the request body is above the limit of {self.max_bytes} bytes "
                                     "(setting ARGAND_MAX_BODY_BYTES)"}).encode()
        await send({"type": "http.response.start", "status": 413,
                    "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                                (b"connection", b"close")]})
        await send({"type": "http.response.body", "body": body})

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = dict(scope.get("headers") or []).get(b"content-length")
        if length is not None:
            try:
                too_big = int(length) > self.max_bytes
            except ValueError:
                too_big = True
            if too_big:
                return await self._refuse(send)
            return await self.app(scope, receive, send)
        if scope.get("method") in ("GET", "HEAD", "OPTIONS"):
            return await self.app(scope, receive, send)
        # No Content-Length (chunked): read the body up to the limit, then replay it.
        chunks, size, more = [], 0, True
        while more:
            message = await receive()
            if message["type"] != "http.request":
                return
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > self.max_bytes:
                return await self._refuse(send)
            more = message.get("more_body", False)
        body = b"".join(chunks)
        sent = False

        async def replay():
            nonlocal sent
            if not sent:
                sent = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return await self.app(scope, replay, send)


class StreamSlots:
    """The event streams (SSE) open at once, per client address and in all:
    a stream holds its connection and a share of the event loop for as long
    as its job runs, so both are bounded (settings max_streams_per_client
    and max_streams; beyond either, a 429 that says which). Used on the
    event loop only (no lock needed)."""

    def __init__(self, per_client: int, total: int) -> None:
        self.per_client, self.total = per_client, total
        self.by_client: dict[str, int] = {}
        self.open = 0

    def take(self, client: str):
        """A slot for ``client``, or HTTPException(429). Returns the function
        that gives it back (idempotent)."""
        from fastapi import HTTPException

        if self.by_client.get(client, 0) >= self.per_client:
            raise HTTPException(429, detail=f"this client ({client}) has {self.per_client} event streams open, the "
                                           "limit (setting ARGAND_MAX_STREAMS_PER_CLIENT); close one first",
                                headers={"Retry-After": "5"})
        if self.open >= self.total:
            raise HTTPException(429, detail=f"the farm serves {self.total} event streams, the limit (setting "
                                           "ARGAND_MAX_STREAMS); retry later or poll GET /api/jobs/{id}",
                                headers={"Retry-After": "5"})
        self.by_client[client] = self.by_client.get(client, 0) + 1
        self.open += 1
        given_back = False

        def give_back() -> None:
            nonlocal given_back
            if given_back:
                return
            given_back = True
            self.open -= 1
            self.by_client[client] -= 1
            if not self.by_client[client]:
                del self.by_client[client]

        return give_back


def client_key(request, token: str | None) -> str:
    """Who a client is, for the per-client limits: the holder of the API
    token when the request carries it (all its holders are one client),
    else the address that connected. That address is a proxy's X-Forwarded-
    For only where the setting forwarded_allow_ips names that proxy (uvicorn
    rewrites the client then); by default a forged header changes nothing."""
    scheme, _, given = request.headers.get("authorization", "").partition(" ")
    given = given.strip()
    if token is not None and scheme.lower() == "bearer" and hmac.compare_digest(given.encode(), token.encode()):
        return "token " + hashlib.sha256(token.encode()).hexdigest()[:12]
    return request.client.host if request.client else "unknown"
