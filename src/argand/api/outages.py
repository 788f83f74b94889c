"""The answers for a part of the farm that fails under a request: the
database or the broker out of reach is a 503 with Retry-After (the same
request may be sent again later), a full store or database a 507; never a
500, and never a wait longer than the database's bounded timeouts
(argand.farm.database)."""

from __future__ import annotations

import errno

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from kombu.exceptions import OperationalError as BrokerError
from redis.exceptions import ConnectionError as RedisConnectionError
from redis.exceptions import TimeoutError as RedisTimeoutError
from sqlalchemy.exc import DisconnectionError, InterfaceError, OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeout

#: Seconds a client is told to wait before it sends the request again.
RETRY_AFTER_S = 5
FULL = "database or disk is full"


def _answer(status: int, detail: str) -> JSONResponse:
    return JSONResponse({"detail": detail}, status_code=status, headers={"Retry-After": str(RETRY_AFTER_S)})


def _first_line(exc: BaseException) -> str:
    text = str(getattr(exc, "orig", None) or exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:200]


def database_failed(_request: Request, exc: Exception) -> JSONResponse:
    if FULL in str(exc):
        return _answer(507, f"the database cannot be written, its disk is full ({_first_line(exc)}); free space, "
                            "then send the request again")
    return _answer(503, f"the database does not answer ({_first_line(exc)}); send the request again later")


def broker_failed(_request: Request, exc: Exception) -> JSONResponse:
    return _answer(503, f"the broker (Redis) does not answer ({_first_line(exc)}); send the request again later")


def store_failed(_request: Request, exc: OSError) -> JSONResponse:
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return _answer(507, f"the frame store is full ({exc.strerror}); free space, then send the request again")
    raise exc


def add_outage_answers(app: FastAPI) -> None:
    # (Not DBAPIError as a whole: a query the database refuses is a bug, a 500 with its trace in the log.)
    for kind in (OperationalError, InterfaceError, DisconnectionError, PoolTimeout):
        app.add_exception_handler(kind, database_failed)
    for kind in (BrokerError, RedisConnectionError, RedisTimeoutError):
        app.add_exception_handler(kind, broker_failed)
    app.add_exception_handler(OSError, store_failed)
