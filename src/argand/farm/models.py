"""The farm's state in SQL (SQLAlchemy 2): jobs, their frames and tiles, and
the workers' heartbeats. The database is the source of truth; the queue only
carries work. The states of each row and their changes: argand.farm.states.
The schema is made and upgraded by the Alembic revisions in
argand/farm/migrations (argand.farm.database.upgrade)."""

from __future__ import annotations

import time

from sqlalchemy import JSON, Float, ForeignKey, Index, Integer, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class Base(DeclarativeBase):
    pass


class Job(Base):
    __tablename__ = "jobs"
    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    status: Mapped[str] = mapped_column(String(16), default="queued", index=True)  # states.JOB
    scene_name: Mapped[str] = mapped_column(String(200))
    scene: Mapped[dict] = mapped_column(JSON)
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    tile: Mapped[int] = mapped_column(Integer)
    method: Mapped[str] = mapped_column(String(16), default="auto")
    #: The engine's modes the job is rendered with (EngineOptions as a dict;
    #: None: the defaults), fixed at submission from the submitting
    #: process's settings: every worker host renders the job's tiles, and the
    #: API decides its bands and on-request EXRs, with these, whatever its
    #: own environment says, so a frame is one algorithm's bits.
    engine: Mapped[dict | None] = mapped_column(JSON, nullable=True)
    priority: Mapped[int] = mapped_column(Integer, default=5)
    created: Mapped[float] = mapped_column(Float, default=time.time)
    started: Mapped[float | None] = mapped_column(Float, nullable=True)
    finished: Mapped[float | None] = mapped_column(Float, nullable=True)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    #: When the queued tiles were last sent again for a new priority (a PATCH
    #: re-sends at most once per argand.farm.outbox.PRIORITY_RESEND_S).
    priority_resent: Mapped[float | None] = mapped_column(Float, nullable=True)
    frames: Mapped[list["Frame"]] = relationship(back_populates="job", cascade="all, delete-orphan", order_by="Frame.index")


class Frame(Base):
    __tablename__ = "frames"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    index: Mapped[int] = mapped_column(Integer)
    sigma: Mapped[float] = mapped_column(Float)
    delta: Mapped[float] = mapped_column(Float)
    #: The frame's place in its job's grid (argand.frames.frame_set): row (σ) and column (δ).
    sigma_index: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    delta_index: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    status: Mapped[str] = mapped_column(String(16), default="queued")  # states.FRAME
    tiles_total: Mapped[int] = mapped_column(Integer)
    #: Tiles counted done (incremented in the transaction that completes them).
    tiles_done: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    finished: Mapped[float | None] = mapped_column(Float, nullable=True)
    figures: Mapped[dict | None] = mapped_column(JSON, nullable=True)
    #: Seconds the assembly took (also in figures; a column for /metrics).
    assembly_s: Mapped[float | None] = mapped_column(Float, nullable=True)
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
    status: Mapped[str] = mapped_column(String(16), default="queued", index=True)  # states.TILE
    worker: Mapped[str | None] = mapped_column(String(200), nullable=True)
    started: Mapped[float | None] = mapped_column(Float, nullable=True)
    #: Seconds between the message's sending and the claim that started the tile.
    waited: Mapped[float | None] = mapped_column(Float, nullable=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    renders: Mapped[int] = mapped_column(Integer, default=0)  # completed renders written (must end at 1)
    seconds: Mapped[float | None] = mapped_column(Float, nullable=True)
    #: The store file holding the tile's AOVs (the tiles a worker finished
    #: between two commits share one file); "frame": assembled whole from memory.
    chunk: Mapped[str | None] = mapped_column(String(64), nullable=True)
    #: Why the tile's last attempt ended without it (an error, a time limit).
    error: Mapped[str | None] = mapped_column(Text, nullable=True)


class Outbox(Base):
    """A message to the workers not sent yet: written in the transaction that
    makes its tiles queued (a job's submission, a resume, a tile given back),
    deleted once the broker took it (argand.farm.outbox). A broker outage
    leaves the rows here, and a drainer sends them when it is back."""

    __tablename__ = "outbox"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    frame_index: Mapped[int] = mapped_column(Integer)
    tile_indices: Mapped[list] = mapped_column(JSON)
    priority: Mapped[int] = mapped_column(Integer)  # the job's 0..9, 9 first
    created: Mapped[float] = mapped_column(Float)
    #: Not sent before this time (a priority change re-sends at a bounded rate).
    not_before: Mapped[float] = mapped_column(Float, default=0.0, server_default="0")
    #: A drainer sending the row holds it until then (a drainer that died lets go).
    lease_until: Mapped[float] = mapped_column(Float, default=0.0, server_default="0")
    sender: Mapped[str | None] = mapped_column(String(64), nullable=True)


class Worker(Base):
    __tablename__ = "workers"
    name: Mapped[str] = mapped_column(String(200), primary_key=True)
    host: Mapped[str] = mapped_column(String(200))
    pid: Mapped[int] = mapped_column(Integer)
    heartbeat: Mapped[float] = mapped_column(Float)
    current_tile: Mapped[str | None] = mapped_column(String(200), nullable=True)
    tiles_done: Mapped[int] = mapped_column(Integer, default=0)
