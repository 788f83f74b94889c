"""A new job: its limits checked, its rows stored (job, frames, tiles) and
its first messages sent."""

from __future__ import annotations

import shutil
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sqlalchemy import func, insert, select
from sqlalchemy.orm import Session

from argand.farm.database import in_session
from argand.farm.dispatch import alive_workers
from argand.farm.models import Frame, Job, Tile
from argand.farm.outbox import add_runs, try_drain
from argand.farm.planning import batch_pixels, core_scene_of, frame_plan, plan_runs, tile_rects
from argand.farm.settings import Settings
from argand.farm.states import ENDED
from argand.render.frames import check_tile
from argand.render.options import EngineOptions
from argand.frames.frame_set import BandRuleError, FrameSet, angle_text, check_band_rule
from argand.scene import Scene


class JobRefused(ValueError):
    """A job the farm does not take; the message says which limit and why."""


class FarmBusy(JobRefused):
    """The farm has as many jobs in flight as its settings allow (a 429)."""


@dataclass(frozen=True)
class JobSpec:
    """A job as it arrives, typed: its scene validated (the store keeps it as
    JSON, Scene.to_dict) and its frames as a FrameSet."""

    scene_name: str
    scene: Scene
    frames: FrameSet
    width: int
    height: int
    tile: int
    priority: int = 5
    method: str = "auto"

    def __post_init__(self) -> None:
        if not isinstance(self.scene, Scene):
            raise TypeError(f"JobSpec.scene must be a validated argand.scene.Scene (scene_from_dict, load_scene), "
                            f"got {type(self.scene).__name__}")
        if not isinstance(self.frames, FrameSet):
            raise TypeError(f"JobSpec.frames must be a FrameSet (FrameSet.from_axes), got {type(self.frames).__name__}")


def job_frames(max_frames: int | None = None, **axes: Any) -> FrameSet:
    """A job's (σ, δ) frames from its axes (sigma, sigmas, delta, deltas,
    atlas), built by FrameSet.from_axes as `argand render` builds them; a job
    above ``max_frames`` (counted before anything is expanded), an axis given
    two ways or a pair that breaks the band rule is refused, saying why."""
    try:
        return FrameSet.from_axes(**axes, max_frames=max_frames)
    except ValueError as exc:
        raise JobRefused(str(exc)) from None


def check_limits(settings: Settings, spec: JobSpec) -> None:
    """Raises JobRefused, naming the limit, for a job above the settings' limits."""
    n_frames = len(spec.frames)
    try:
        check_band_rule([(p.sigma, p.delta) for p in spec.frames.points])
    except BandRuleError as exc:
        raise JobRefused(str(exc)) from None
    if spec.width > settings.max_width or spec.height > settings.max_height:
        raise JobRefused(f"frame size {spec.width}x{spec.height} exceeds the limit "
                         f"{settings.max_width}x{settings.max_height}")
    if n_frames > settings.max_frames:
        raise JobRefused(f"{n_frames} frames exceed the limit of {settings.max_frames}")
    pixels = spec.width * spec.height * n_frames
    samples = spec.scene.samples  # a sample costs what a pixel does: the limit counts traced rays
    if pixels * samples > settings.max_job_pixels:
        rays = f" x {samples} samples per pixel = {pixels * samples} rays" if samples > 1 else ""
        raise JobRefused(f"the job has {pixels} pixels{rays}, above the limit of {settings.max_job_pixels}")
    tiles = -(-spec.width // spec.tile) * -(-spec.height // spec.tile) * n_frames
    if tiles > settings.max_job_tiles:
        raise JobRefused(f"the job has {tiles} tiles ({spec.tile}-pixel tiles), above the limit of "
                         f"{settings.max_job_tiles}: use larger tiles or fewer frames")


def check_renderable(spec: JobSpec, engine: EngineOptions = EngineOptions()) -> None:
    """Plans every distinct frame with the code a worker runs before its
    first tile (argand.farm.planning.frame_plan): a frame that breaks the
    band rule or cannot be planned (a camera or coefficient out of range) is
    refused here, with the renderer's reason, instead of failing in a worker."""
    try:
        core = core_scene_of(spec.scene)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        raise JobRefused(f"the scene cannot be rendered: {exc}") from None
    first: dict[tuple[float, float], int] = {}
    for index, p in enumerate(spec.frames.points):
        first.setdefault((p.sigma, p.delta), index)
    for (sigma, delta), index in sorted(first.items()):
        try:
            frame_plan(core, sigma, delta, spec.width, spec.height, spec.method, spec.scene.samples, engine)
        except (ValueError, ArithmeticError, RuntimeError) as exc:
            at = f"σ = {angle_text(sigma)}, δ = {angle_text(delta)}"
            where = f"frame {index} ({at})" if len(first) > 1 else at
            raise JobRefused(f"the scene cannot be rendered: {exc} [at {where}]") from None


class StoreFull(JobRefused):
    """The data folder's free space is below the floor (a 507)."""


def free_bytes(path) -> int:
    """Free bytes (for an unprivileged user) on the file system of ``path``
    (or of its nearest existing parent)."""
    path = Path(path)
    while not path.exists() and path != path.parent:
        path = path.parent
    return shutil.disk_usage(path).free


def check_disk(settings: Settings) -> None:
    """Raises StoreFull when the data folder has less free space than
    min_free_bytes: a new job would fill the disk, and the jobs already
    accepted need the room to finish."""
    free = free_bytes(settings.store_path)
    if free < settings.min_free_bytes:
        raise StoreFull(f"the data folder {settings.data_path} has {free // (1 << 20)} MiB free, below the floor of "
                        f"{settings.min_free_bytes // (1 << 20)} MiB (setting ARGAND_MIN_FREE_BYTES): new jobs are "
                        "refused until space is freed (delete finished jobs)")


def check_in_flight(settings: Settings, session: Session | None = None) -> None:
    """Raises FarmBusy when the farm already holds max_active_jobs unfinished jobs."""
    with in_session(settings.sqlalchemy_url, session) as s:
        n = s.scalar(select(func.count()).select_from(Job).where(Job.status.not_in(ENDED)))
    if n >= settings.max_active_jobs:
        raise FarmBusy(f"the farm has {n} jobs queued, running or paused (the limit is {settings.max_active_jobs}); "
                       "retry when some have finished")


def create_job(settings: Settings, spec: JobSpec, send: bool = True, session: Session | None = None) -> str:
    """Checks the limits, then stores the job, its frames, its tiles and its
    messages (outbox rows, argand.farm.outbox) in one transaction: a broker
    outage, or a crash right after the commit, cannot leave a queued job
    without work. With ``send``, the messages are then sent here if the
    broker answers (else they wait for a drainer); the API passes False and
    wakes its drainer instead, so a submission never waits on the broker.
    In ``session`` when given (a route's; committed here), else in one of
    its own. Returns the job's id."""
    check_limits(settings, spec)
    try:
        check_tile(spec.tile)
    except ValueError as exc:
        raise JobRefused(str(exc)) from None
    check_renderable(spec, settings.engine)
    check_in_flight(settings, session)
    check_disk(settings)
    job_id = uuid.uuid4().hex[:12]
    stored = spec.scene.to_dict()
    rects = tile_rects(spec.width, spec.height, spec.tile)
    n_frames, positions = len(spec.frames), spec.frames.positions
    workers = max(1, alive_workers(settings))
    runs = plan_runs({f: list(range(len(rects))) for f in range(n_frames)}, n_frames, rects,
                     batch_pixels(settings.batch_pixels, stored), workers, positions,
                     window=settings.run_bands if settings.files_on_request else 1)
    with in_session(settings.sqlalchemy_url, session) as s:
        c = s.connection()
        c.execute(insert(Job).values(id=job_id, status="queued", scene_name=spec.scene_name, scene=stored,
                                     width=spec.width, height=spec.height, tile=spec.tile,
                                     method=spec.method, engine=settings.engine.stored(), priority=spec.priority,
                                     created=time.time()))
        c.execute(insert(Frame), [dict(job_id=job_id, index=i, sigma=p.sigma, delta=p.delta, sigma_index=p.sigma_index,
                                       delta_index=p.delta_index, status="queued", tiles_total=len(rects), tiles_done=0)
                                  for i, p in enumerate(spec.frames.points)])
        c.execute(insert(Tile), [dict(job_id=job_id, frame_index=i, tile_index=t, status="queued", attempts=0,
                                      renders=0) for i in range(n_frames) for t in range(len(rects))])
        add_runs(c, job_id, runs, spec.priority)
    if send:
        try_drain(settings, job_id)
    return job_id
