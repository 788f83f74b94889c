"""Job state in SQL (SQLAlchemy 2): the source of truth for jobs, frames and
tiles. Celery only carries work."""

from __future__ import annotations

import json
import time
from contextlib import contextmanager
from typing import Iterator

from sqlalchemy import JSON, Float, ForeignKey, Index, Integer, String, Text, create_engine, event, inspect, text
from sqlalchemy.engine import Engine
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column, relationship, sessionmaker

JOB_STATES = ("queued", "running", "paused", "done", "failed", "canceled")


class Base(DeclarativeBase):
    pass


class Job(Base):
    __tablename__ = "jobs"
    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    status: Mapped[str] = mapped_column(String(16), default="queued", index=True)
    scene_name: Mapped[str] = mapped_column(String(200))
    scene: Mapped[dict] = mapped_column(JSON)
    sigma: Mapped[float] = mapped_column(Float, default=0.0)
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    tile: Mapped[int] = mapped_column(Integer)
    method: Mapped[str] = mapped_column(String(16), default="auto")
    priority: Mapped[int] = mapped_column(Integer, default=5)
    created: Mapped[float] = mapped_column(Float, default=time.time)
    started: Mapped[float | None] = mapped_column(Float, nullable=True)
    finished: Mapped[float | None] = mapped_column(Float, nullable=True)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    frames: Mapped[list["Frame"]] = relationship(back_populates="job", cascade="all, delete-orphan", order_by="Frame.index")


class Frame(Base):
    __tablename__ = "frames"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    index: Mapped[int] = mapped_column(Integer)
    sigma: Mapped[float] = mapped_column(Float)
    delta: Mapped[float] = mapped_column(Float)
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued|rendering|assembling|done
    tiles_total: Mapped[int] = mapped_column(Integer)
    #: Tiles counted done (incremented in the transaction that completes them).
    tiles_done: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    finished: Mapped[float | None] = mapped_column(Float, nullable=True)
    figures: Mapped[dict | None] = mapped_column(JSON, nullable=True)
    assembler: Mapped[str | None] = mapped_column(String(200), nullable=True)
    assembling_since: Mapped[float | None] = mapped_column(Float, nullable=True)
    job: Mapped[Job] = relationship(back_populates="frames")


class Tile(Base):
    __tablename__ = "tiles"
    __table_args__ = (Index("ix_tiles_key", "job_id", "frame_index", "tile_index", unique=True),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    frame_index: Mapped[int] = mapped_column(Integer, index=True)
    tile_index: Mapped[int] = mapped_column(Integer)
    status: Mapped[str] = mapped_column(String(16), default="queued", index=True)  # queued|running|done|failed
    worker: Mapped[str | None] = mapped_column(String(200), nullable=True)
    started: Mapped[float | None] = mapped_column(Float, nullable=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    renders: Mapped[int] = mapped_column(Integer, default=0)  # completed renders written (must end at 1)
    seconds: Mapped[float | None] = mapped_column(Float, nullable=True)
    #: The store file holding the tile's AOVs (the tiles a worker finished
    #: between two commits share one file); None: a file of its own.
    chunk: Mapped[str | None] = mapped_column(String(64), nullable=True)


class Worker(Base):
    __tablename__ = "workers"
    name: Mapped[str] = mapped_column(String(200), primary_key=True)
    host: Mapped[str] = mapped_column(String(200))
    pid: Mapped[int] = mapped_column(Integer)
    heartbeat: Mapped[float] = mapped_column(Float)
    current_tile: Mapped[str | None] = mapped_column(String(200), nullable=True)
    tiles_done: Mapped[int] = mapped_column(Integer, default=0)


_engines: dict[str, Engine] = {}


def engine_for(url: str) -> Engine:
    if url not in _engines:
        if url.startswith("sqlite"):
            from sqlalchemy.engine import make_url

            database = make_url(url).database
            if database and database != ":memory:":
                __import__("pathlib").Path(database).parent.mkdir(parents=True, exist_ok=True)
            eng = create_engine(url, connect_args={"timeout": 60, "check_same_thread": False})

            @event.listens_for(eng, "connect")
            def _pragmas(conn, _record):  # several processes share the file
                cur = conn.cursor()
                cur.execute("PRAGMA journal_mode=WAL")
                # WAL + NORMAL: no fsync per commit (a crash of a process
                # loses nothing; a power cut may roll back the last commits,
                # and those tiles are then simply rendered again).
                cur.execute("PRAGMA synchronous=NORMAL")
                cur.execute("PRAGMA busy_timeout=60000")
                cur.execute("PRAGMA foreign_keys=ON")
                cur.close()
        else:
            eng = create_engine(url, pool_pre_ping=True)
        Base.metadata.create_all(eng)
        migrate(eng)
        _engines[url] = eng
    return _engines[url]


def migrate(eng: Engine) -> list[str]:
    """Brings a database made by an earlier version up to the models: adds
    the columns and indexes it lacks (additive changes only). Returns what
    it did."""
    done = []
    insp = inspect(eng)
    with eng.begin() as conn:
        for table in Base.metadata.sorted_tables:
            have = {c["name"] for c in insp.get_columns(table.name)}
            for col in table.columns:
                if col.name not in have:
                    ddl = f"ALTER TABLE {table.name} ADD COLUMN {col.name} {col.type.compile(eng.dialect)}"
                    if col.server_default is not None:
                        ddl += f" DEFAULT {col.server_default.arg}"
                    conn.execute(text(ddl))
                    done.append(f"{table.name}.{col.name}")
        for table in Base.metadata.sorted_tables:
            for index in table.indexes:
                index.create(conn, checkfirst=True)
        if "frames.tiles_done" in done:  # count what an older version finished
            conn.execute(text("UPDATE frames SET tiles_done = (SELECT count(*) FROM tiles WHERE tiles.job_id = frames.job_id"
                              " AND tiles.frame_index = frames.\"index\" AND tiles.status = 'done')"))
    return done


_factories: dict[str, sessionmaker] = {}


@contextmanager
def session_scope(url: str) -> Iterator[Session]:
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


def job_progress(s: Session, job: Job) -> tuple[int, int]:
    """(tiles done, tiles in all) from the frames' counters."""
    done = sum(f.tiles_done or 0 for f in job.frames)
    total = sum(f.tiles_total for f in job.frames)
    return int(done), int(total)


def dumps(obj) -> str:
    return json.dumps(obj, separators=(",", ":"))
