"""Two small proxies the cluster harness runs inside its hosts (standard
library only, run as a script: ``python proxies.py delay|http ...``).

* ``delay``: a TCP forwarder that holds every byte a host sends for a
  fixed time before passing it on, in order (what ``tc qdisc ... netem
  delay`` does to a link's outgoing packets; this machine's kernel has no
  sch_netem). The harness redirects a worker host's connections to Redis
  and PostgreSQL through it with an nftables ``redirect`` in that host's
  own namespace, so the worker's configuration is untouched: every request
  it sends, and every acknowledgement its protocols wait for, arrives that
  much later. Its own connections onward carry a firewall mark so that the
  redirect does not catch them again.
* ``http``: a reverse proxy for HTTP/1.1 in front of the API, as nginx with
  ``proxy_set_header X-Forwarded-For $remote_addr`` is: each request's
  head gets ``X-Forwarded-For`` set to the address that connected to the
  proxy (a client's own X-Forwarded-For, Forwarded or X-Real-IP is
  dropped); bodies (by Content-Length) and responses (streamed event
  streams included) pass through as they come."""

from __future__ import annotations

import argparse
import asyncio
import socket
import sys
import time

#: The firewall mark on the delay proxy's own connections onward (the
#: harness's redirect rule leaves marked packets alone).
MARK = 0x2A7
#: The longest request head the http proxy reads.
MAX_HEAD = 64 * 1024


async def _open_upstream(host: str, port: int, mark: int | None = None):
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if mark is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_MARK, mark)
    sock.setblocking(False)
    await asyncio.wait_for(asyncio.get_running_loop().sock_connect(sock, (host, port)), 10)
    return await asyncio.open_connection(sock=sock)


#: Chunks the delay proxy held (about one per request the host sent): its log says how many.
HELD = {"chunks": 0}


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, delay_s: float = 0.0) -> None:
    """Copies ``reader`` to ``writer``, each chunk ``delay_s`` after it was
    read (order kept, chunks in flight meanwhile), then half-closes."""
    queue: asyncio.Queue = asyncio.Queue()

    async def read() -> None:
        try:
            while chunk := await reader.read(65536):
                HELD["chunks"] += delay_s > 0
                queue.put_nowait((time.monotonic() + delay_s, chunk))
        except (ConnectionError, OSError):
            pass
        queue.put_nowait((time.monotonic() + delay_s, b""))

    reading = asyncio.create_task(read())
    try:
        while True:
            due, chunk = await queue.get()
            wait = due - time.monotonic()
            if wait > 0:
                await asyncio.sleep(wait)
            if not chunk:
                if writer.can_write_eof():
                    writer.write_eof()
                break
            writer.write(chunk)
            await writer.drain()
    except (ConnectionError, OSError):
        pass
    finally:
        reading.cancel()


async def _close(*writers: asyncio.StreamWriter) -> None:
    for w in writers:
        w.close()
    for w in writers:
        try:
            await w.wait_closed()
        except (ConnectionError, OSError):
            pass


def delay_proxy(upstream: tuple[str, int], delay_s: float):
    async def handle(reader, writer) -> None:
        try:
            up_reader, up_writer = await _open_upstream(*upstream, mark=MARK)
        except (OSError, asyncio.TimeoutError):
            await _close(writer)
            return
        await asyncio.gather(_pipe(reader, up_writer, delay_s), _pipe(up_reader, writer))
        await _close(writer, up_writer)

    return handle


DROPPED = (b"x-forwarded-for", b"forwarded", b"x-real-ip")


def _rewrite_head(head: bytes, client: str) -> tuple[bytes, int | None, bool]:
    """The request head with X-Forwarded-For set to ``client``; its
    Content-Length (None without one) and whether its body is chunked."""
    lines = head.split(b"\r\n")
    kept, length, chunked = [lines[0]], None, False
    for line in lines[1:]:
        if not line:
            continue
        name, _, value = line.partition(b":")
        key = name.strip().lower()
        if key in DROPPED:
            continue
        if key == b"content-length":
            length = int(value.strip())
        if key == b"transfer-encoding" and b"chunked" in value.lower():
            chunked = True
        kept.append(line)
    kept.append(b"X-Forwarded-For: " + client.encode())
    return b"\r\n".join(kept) + b"\r\n\r\n", length, chunked


def http_proxy(upstream: tuple[str, int]):
    async def handle(reader, writer) -> None:
        client = writer.get_extra_info("peername")[0]
        try:
            up_reader, up_writer = await _open_upstream(*upstream)
        except (OSError, asyncio.TimeoutError):
            writer.write(b"HTTP/1.1 502 Bad Gateway\r\ncontent-length: 0\r\nconnection: close\r\n\r\n")
            await _close(writer)
            return
        responses = asyncio.create_task(_pipe(up_reader, writer))
        try:
            while True:
                try:
                    head = await reader.readuntil(b"\r\n\r\n")
                except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
                    break
                head, length, chunked = _rewrite_head(head, client)
                up_writer.write(head)
                if chunked:  # not parsed: the rest of the connection passes as it is
                    await _pipe(reader, up_writer)
                    break
                if length:
                    up_writer.write(await reader.readexactly(length))
                await up_writer.drain()
            if up_writer.can_write_eof():
                up_writer.write_eof()
            await responses
        except (ConnectionError, OSError, asyncio.IncompleteReadError):
            responses.cancel()
        finally:
            await _close(writer, up_writer)

    return handle


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kind", choices=("delay", "http"))
    parser.add_argument("--listen", required=True, help="ADDRESS:PORT")
    parser.add_argument("--to", required=True, help="ADDRESS:PORT of the upstream")
    parser.add_argument("--delay-ms", type=float, default=0.0, help="delay: what the host sends is held this long")
    args = parser.parse_args(argv)
    listen_host, listen_port = args.listen.rsplit(":", 1)
    to_host, to_port = args.to.rsplit(":", 1)
    upstream = (to_host, int(to_port))
    handle = delay_proxy(upstream, args.delay_ms / 1000) if args.kind == "delay" else http_proxy(upstream)

    async def serve() -> None:
        server = await asyncio.start_server(handle, listen_host, int(listen_port), reuse_address=True,
                                            limit=MAX_HEAD)  # readuntil's bound on a request head
        print(f"{args.kind} proxy on {args.listen} -> {args.to}", file=sys.stderr, flush=True)
        async with server:
            if args.kind == "delay":
                asyncio.create_task(report())
            await server.serve_forever()

    async def report() -> None:
        told = 0
        while True:
            await asyncio.sleep(1)
            if HELD["chunks"] != told:
                told = HELD["chunks"]
                print(f"{time.monotonic():.1f} held {told} chunks", file=sys.stderr, flush=True)

    asyncio.run(serve())


if __name__ == "__main__":
    main()
