"""The API's listening socket, taken before anything else starts, so that a
port in use is said plainly (with what to do) and nothing is announced or
started on a port that someone else holds."""

from __future__ import annotations

import errno
import socket


class PortTaken(RuntimeError):
    """The API cannot listen on the asked address and port."""


def listen_on(host: str, port: int) -> socket.socket:
    """A socket listening on ``host:port`` (not inherited by child
    processes), to hand to uvicorn; PortTaken, saying what to do, if the
    port is in use or the address cannot be bound."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn: a port in TIME_WAIT is free
        sock.bind((host, port))
        sock.listen(2048)
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise PortTaken(
                f"port {port} on {host} is already in use (another argand serve, or another program). "
                f"Stop that one, or use another port: argand serve --port {port + 1} "
                f"(make run PORT={port + 1}; ARGAND_PORT={port + 1})") from None
        raise PortTaken(f"cannot listen on {host}:{port}: {exc.strerror or exc}; "
                        "choose another --host or --port") from None
    return sock
