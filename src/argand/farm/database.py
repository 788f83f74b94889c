"""Engines and sessions per database URL, and the schema's upgrade through
Alembic (``argand serve`` and ``argand api`` upgrade on start; the revisions
are in argand/farm/migrations/versions)."""

from __future__ import annotations

import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from alembic import command
from alembic.config import Config
from sqlalchemy import create_engine, event, literal_column, select
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.orm import Session, sessionmaker

MIGRATIONS = Path(__file__).with_name("migrations")

#: A database across the network must answer in bounded time, or the caller
#: gets an error it can act on (the API a 503, a worker a failed run whose
#: tiles go back) instead of waiting for TCP to give up (15 minutes):
#: seconds to open a connection; seconds an unacknowledged send may wait
#: (a link that stopped carrying packets), which also bounds a query sent
#: into a dead link; keepalives that find a dead idle connection; and the
#: longest statement the server runs.
CONNECT_TIMEOUT_S = 3
SEND_TIMEOUT_S = 4
STATEMENT_TIMEOUT_S = 60
#: A session left idle inside a transaction this long is ended by the server,
#: its locks released: a worker frozen (SIGSTOP, a VM paused) or cut off in
#: the middle of a transaction would otherwise hold its rows locked, and the
#: reaper that gives its tiles back would wait on them for as long.
IDLE_IN_TRANSACTION_S = 20
#: Seconds a request waits for a free connection of the pool.
POOL_TIMEOUT_S = 10

_engines: dict[str, Engine] = {}
_factories: dict[str, sessionmaker] = {}


def _sqlite_engine(url: str) -> Engine:
    database = make_url(url).database
    if database and database != ":memory:":
        Path(database).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, connect_args={"timeout": 60, "check_same_thread": False})

    @event.listens_for(engine, "connect")
    def _pragmas(conn, _record):  # several processes share the file
        cur = conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        # WAL + NORMAL: no fsync per commit (a crash of a process loses
        # nothing; a power cut may roll back the last commits, and those
        # tiles are then simply rendered again).
        cur.execute("PRAGMA synchronous=NORMAL")
        cur.execute("PRAGMA busy_timeout=60000")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.close()

    return engine


def _server_engine(url: str) -> Engine:
    """A database server (PostgreSQL) over the network, with every wait bounded."""
    connect_args = {}
    if make_url(url).get_backend_name() == "postgresql":
        connect_args = {
            "connect_timeout": CONNECT_TIMEOUT_S,
            "tcp_user_timeout": SEND_TIMEOUT_S * 1000,
            "keepalives": 1, "keepalives_idle": SEND_TIMEOUT_S, "keepalives_interval": 1, "keepalives_count": 3,
            "options": f"-c statement_timeout={STATEMENT_TIMEOUT_S * 1000} "
                       f"-c idle_in_transaction_session_timeout={IDLE_IN_TRANSACTION_S * 1000}",
        }
    return create_engine(url, pool_pre_ping=True, pool_timeout=POOL_TIMEOUT_S, connect_args=connect_args)


def engine_for(url: str) -> Engine:
    """One engine per URL and process (the schema is upgrade()'s)."""
    if url not in _engines:
        _engines[url] = _sqlite_engine(url) if url.startswith("sqlite") else _server_engine(url)
    return _engines[url]


@contextmanager
def session_scope(url: str) -> Iterator[Session]:
    """A session committed at the end of the block (rolled back on an error)."""
    factory = _factories.get(url)
    if factory is None:
        factory = _factories[url] = sessionmaker(engine_for(url), expire_on_commit=False)
    with factory() as s:
        try:
            yield s
            s.commit()
        except Exception:
            s.rollback()
            raise


@contextmanager
def in_session(url: str, session: Session | None = None) -> Iterator[Session]:
    """The caller's ``session`` (a route's, argand.api.deps.SessionDep),
    committed at the end of the block so that what follows it (a message
    sent, a folder removed) comes after the change, as with a session of
    its own; or, without one, a new session_scope(url)."""
    if session is None:
        with session_scope(url) as s:
            yield s
    else:
        yield session
        session.commit()


#: The database server's clock as seconds since the epoch, per dialect.
_CLOCK = {"postgresql": "extract(epoch from clock_timestamp())",
          "sqlite": "(julianday('now') - 2440587.5) * 86400.0"}


def clock(conn) -> float:
    """Now, by the database's clock (``conn``: a connection or session).

    Times that one host writes and another compares (heartbeats: is a
    worker alive?) are read from this one clock, so that hosts whose clocks
    disagree by more than the heartbeat timeout neither declare a live
    worker dead nor keep a dead one alive. SQLite runs on the one host
    anyway; another dialect falls back to this host's clock."""
    expression = _CLOCK.get(conn.bind.dialect.name if hasattr(conn, "bind") and conn.bind is not None
                            else conn.dialect.name)
    if expression is None:
        return time.time()
    return float(conn.execute(select(literal_column(expression))).scalar())


def alembic_config(url: str) -> Config:
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    config.attributes["engine"] = engine_for(url)
    return config


def upgrade(url: str, revision: str = "head") -> None:
    """Brings the database at ``url`` to ``revision`` (creates it when empty)."""
    command.upgrade(alembic_config(url), revision)
