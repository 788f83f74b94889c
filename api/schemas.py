"""Request and response bodies of the HTTP API."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from argand.core import METHODS
from argand.farm.models import Job
from argand.farm.limits import MAX_FRAMES, MAX_SIDE
from argand.farm.planning import MAX_TILE, MIN_TILE
from argand.farm.progress import eta_seconds, job_progress
from argand.farm.queue import PRIORITIES
from argand.render.angles import parse_angle
from argand.render.frames import MAX_SAMPLES
from argand.scene.model import check_samples

Priority = Field(5, ge=PRIORITIES.start, le=PRIORITIES.stop - 1)


def _angle(v: Any) -> float:
    """An angle: a JSON number or an expression such as "pi/9", read by
    argand.render.angles.parse_angle (bounded: no recursion, no big integers,
    at most MAX_ANGLE_LENGTH characters); anything else is a ValueError (a 422)."""
    return parse_angle(v)


class DeltaRange(BaseModel):
    model_config = ConfigDict(extra="forbid")
    start: float | str
    stop: float | str
    count: int = Field(ge=1, le=MAX_FRAMES, description="Frames in the sweep (the farm's max_frames may be lower)")

    @field_validator("start", "stop", mode="before")
    @classmethod
    def _parse(cls, v: Any) -> float:
        return _angle(v)


class JobRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    scene: str | dict = Field(description="A preset name or a scene object")
    sigma: float | str = 0.0
    deltas: list[float | str] | DeltaRange = Field(default_factory=lambda: [0.0])
    width: int = Field(256, ge=1, le=MAX_SIDE)
    height: int = Field(256, ge=1, le=MAX_SIDE)
    tile: int | None = Field(None, ge=MIN_TILE, le=MAX_TILE, description="Tile size in pixels (default: the farm's)")
    priority: int = Priority
    method: Literal[METHODS] = "auto"
    samples: int | None = Field(None, ge=1, le=MAX_SAMPLES,
                                description="Samples per pixel, a square (1, 4, 9, ..., MAX_SAMPLES; default: the "
                                "scene's): the colour is their mean, the status the worst of theirs")

    @field_validator("samples")
    @classmethod
    def _samples(cls, v: int | None) -> int | None:
        return None if v is None else check_samples(v)

    @field_validator("sigma", mode="before")
    @classmethod
    def _sigma(cls, v: Any) -> float:
        return _angle(v)

    @field_validator("deltas", mode="before")
    @classmethod
    def _deltas(cls, v: Any) -> Any:
        if isinstance(v, list):
            if not v:
                raise ValueError("deltas must not be empty")
            if len(v) > MAX_FRAMES:
                raise ValueError(f"deltas has {len(v)} entries; at most {MAX_FRAMES} (and the farm's max_frames)")
            out = [_angle(d) for d in v]
            if any(d < 0 for d in out):
                raise ValueError("every delta must be >= 0")
            return out
        return v


class PriorityPatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    priority: int = Field(ge=PRIORITIES.start, le=PRIORITIES.stop - 1)


class FrameBrief(BaseModel):
    """A frame in the job list: no figures (their JSON is read by the job's own view only)."""
    index: int
    sigma: float
    delta: float
    status: str
    png_url: str | None
    exr_url: str | None
    thumbnail_url: str | None
    finished: float | None


class FrameOut(FrameBrief):
    certified_share: float | None
    figures: dict | None


class JobSummary(BaseModel):
    """A job in the list: its counters and frames, without the scene and the frames' figures."""
    id: str
    status: str
    scene_name: str
    sigma: float
    width: int
    height: int
    tile: int
    method: str
    priority: int
    progress: float
    tiles_done: int
    tiles_total: int
    eta_s: float | None
    created: float
    started: float | None
    finished: float | None
    error: str | None
    frames: list[FrameBrief]
    animation_url: str | None
    webp_url: str | None


class JobOut(JobSummary):
    scene: dict
    frames: list[FrameOut]


class JobPage(BaseModel):
    total: int
    page: int
    per_page: int
    jobs: list[JobSummary]


def _urls(base: str, index: int, done: bool) -> dict:
    return {"png_url": f"{base}/frames/{index}.png" if done else None,
            "exr_url": f"{base}/frames/{index}.exr" if done else None,
            "thumbnail_url": f"{base}/frames/{index}/thumbnail.png" if done else None}


def _job_fields(job: Job, done: int, total: int, frames: int) -> dict:
    base = f"/api/jobs/{job.id}"
    animated = job.status == "done" and frames > 1
    return dict(
        id=job.id, status=job.status, scene_name=job.scene_name, sigma=job.sigma, width=job.width,
        height=job.height, tile=job.tile, method=job.method, priority=job.priority,
        progress=done / total if total else 0.0, tiles_done=done, tiles_total=total,
        eta_s=eta_seconds(job, done, total), created=job.created, started=job.started, finished=job.finished,
        error=job.error, animation_url=f"{base}/animation.gif" if animated else None,
        webp_url=f"{base}/animation.webp" if animated else None,
    )


def frame_out(base: str, f) -> FrameOut:
    return FrameOut(index=f.index, sigma=f.sigma, delta=f.delta, status=f.status, **_urls(base, f.index, f.status == "done"),
                    finished=f.finished, certified_share=(f.figures or {}).get("certified_share"), figures=f.figures)


def frame_brief(base: str, index: int, sigma: float, delta: float, status: str, finished: float | None) -> FrameBrief:
    return FrameBrief(index=index, sigma=sigma, delta=delta, status=status, **_urls(base, index, status == "done"),
                      finished=finished)


def job_out(job: Job) -> JobOut:
    """The job's own view: every frame with its figures."""
    done, total = job_progress(job)
    base = f"/api/jobs/{job.id}"
    return JobOut(scene=job.scene, frames=[frame_out(base, f) for f in job.frames],
                  **_job_fields(job, done, total, len(job.frames)))


def job_summary(job: Job, progress: tuple[int, int], frames: list[tuple]) -> JobSummary:
    """A job in the list, from its row (scene deferred), its (tiles done, total) and its
    frames' (index, sigma, delta, status, finished)."""
    base = f"/api/jobs/{job.id}"
    return JobSummary(frames=[frame_brief(base, *f) for f in frames], **_job_fields(job, *progress, len(frames)))
