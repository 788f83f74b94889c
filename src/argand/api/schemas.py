"""Request and response bodies of the HTTP API."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, Strict, StringConstraints, field_validator,
                      model_validator)

from argand.core import METHODS
from argand.farm.models import Job
from argand.farm.job_limits import MAX_FRAME_SIDE, MAX_FRAMES
from argand.farm.planning import MAX_TILE, MIN_TILE
from argand.render.frames import TILE_MULTIPLE
from argand.farm.progress import eta_seconds, job_progress
from argand.farm.queue import PRIORITIES
from argand.farm.states import shown_frame_status
from argand.frames.angles import parse_angle
from argand.render.frames import MAX_SAMPLES
from argand.scene.model import check_samples
from argand.frames.frame_set import DEFAULT_HEIGHT, DEFAULT_WIDTH, FrameSet, FramePoint, angle_text

Priority = Field(5, ge=PRIORITIES.start, le=PRIORITIES.stop - 1)
def _integral(v: Any) -> Any:
    """A JSON number without a fractional part is an integer, as JSON Schema
    has it (3.0 is the integer 3); everything else goes to the strict check."""
    return int(v) if isinstance(v, float) and v.is_integer() else v


#: A JSON integer and nothing else: not true (pydantic would read 1), not
#: "512", not 16.5; 3.0 is 3 (an "integer" of the OpenAPI document).
StrictInt = Annotated[int, Strict(), BeforeValidator(_integral)]


def bounded_int(low: int, high: int, multiple_of: int | None = None) -> Any:
    """StrictInt from ``low`` to ``high`` (and a multiple of ``multiple_of``),
    for an optional field: the bounds sit on the integer itself, so that the
    document has them as its minimum, maximum and multipleOf (given on the
    optional field, they read "ge"/"le")."""
    return Annotated[int, Strict(), Field(ge=low, le=high, multiple_of=multiple_of), BeforeValidator(_integral)]
#: A preset's name: not empty, not blank.
PresetName = Annotated[str, StringConstraints(min_length=1, strip_whitespace=True)]


def _angle(v: Any) -> float:
    """An angle: a JSON number or an expression such as "pi/9", read by
    argand.frames.angles.parse_angle (bounded: no recursion, no big integers,
    at most MAX_ANGLE_LENGTH characters); anything else is a ValueError (a 422)."""
    return parse_angle(v)


class AngleRange(BaseModel):
    """A sweep of σ or δ: ``count`` values from start to stop inclusive."""
    model_config = ConfigDict(extra="forbid")
    start: float | str
    stop: float | str
    count: StrictInt = Field(ge=1, le=MAX_FRAMES, description="Values in the sweep (the farm's max_frames may be lower)")

    @field_validator("start", "stop", mode="before")
    @classmethod
    def _parse(cls, v: Any) -> float:
        return _angle(v)


def _axis(v: Any, name: str) -> Any:
    """A number or angle text (one value), a list of them, or a range (left to pydantic)."""
    if isinstance(v, list):
        if not v:
            raise ValueError(f"{name} must not be empty")
        if len(v) > MAX_FRAMES:
            raise ValueError(f"{name} has {len(v)} entries; at most {MAX_FRAMES} (and the farm's max_frames)")
        return [_angle(d) for d in v]
    if isinstance(v, dict):
        return v
    return [_angle(v)]


#: Most steps of an atlas (its frames, steps (steps + 1) / 2, meet the farm's max_frames too).
MAX_ATLAS_STEPS = 140


class JobRequest(BaseModel):
    """A job's frames are (σ, δ) pairs: ``sigmas`` x ``deltas`` (each a
    number, a list or a range; ``sigma`` and ``delta`` are one value, the
    default 0), or with ``atlas`` the triangular grid over the whole space
    σ ≥ 0, σ + δ ≤ π; FrameSet.from_axes builds them, as for `argand
    render`. Every pair must keep the band rule."""
    model_config = ConfigDict(extra="forbid")
    scene: PresetName | dict = Field(description="A preset name or a scene object")
    sigma: float | str | None = Field(None, description="One σ (the default, 0); or give sigmas")
    sigmas: float | str | list[float | str] | AngleRange | None = Field(
        None, description="σ values: a number, a list or {start, stop, count}; with several deltas, a grid")
    delta: float | str | None = Field(None, description="One δ (the default, 0); or give deltas")
    deltas: float | str | list[float | str] | AngleRange | None = Field(
        None, description="δ values: a number, a list or {start, stop, count}")
    atlas: bounded_int(1, MAX_ATLAS_STEPS) | None = Field(None, description=(
        "N: the whole space σ ≥ 0, σ + δ ≤ π on a triangular grid of N rows and columns, step π/N "
        "(N(N+1)/2 frames); instead of sigma(s) and delta(s)"))
    atlas_layout: Literal["uniform", "roots"] = Field("uniform", description=(
        "With atlas: \"uniform\" cuts [0, π] every π/N; \"roots\" cuts it where the scene's roots are "
        "(argand.frames.frame_set.atlas_cuts over the arguments of an evenly spread grid of its pixels' roots), "
        "so the frames sit where the picture changes"))
    width: StrictInt = Field(DEFAULT_WIDTH, ge=1, le=MAX_FRAME_SIDE)
    height: StrictInt = Field(DEFAULT_HEIGHT, ge=1, le=MAX_FRAME_SIDE)
    tile: bounded_int(MIN_TILE, MAX_TILE, TILE_MULTIPLE) | None = Field(
        None, description=f"Tile size in pixels, a multiple of {TILE_MULTIPLE} (default: the farm's): tiles on the "
        f"renderer's {TILE_MULTIPLE}x{TILE_MULTIPLE} seed blocks keep a frame the same bits whatever its tiling")
    priority: StrictInt = Priority
    method: Literal[METHODS] = "auto"
    samples: bounded_int(1, MAX_SAMPLES) | None = Field(None,
                                description="Samples per pixel, a square (1, 4, 9, ..., MAX_SAMPLES; default: the "
                                "scene's): the colour is their mean, the status the worst of theirs")

    @field_validator("samples")
    @classmethod
    def _samples(cls, v: int | None) -> int | None:
        return None if v is None else check_samples(v)

    # null is the field left out (the document says each may be null).
    @field_validator("sigma", "delta", mode="before")
    @classmethod
    def _one_value(cls, v: Any) -> float | None:
        return None if v is None else _angle(v)

    @field_validator("sigmas", mode="before")
    @classmethod
    def _sigmas(cls, v: Any) -> Any:
        return None if v is None else _axis(v, "sigmas")

    @field_validator("deltas", mode="before")
    @classmethod
    def _deltas(cls, v: Any) -> Any:
        return None if v is None else _axis(v, "deltas")

    @model_validator(mode="after")
    def _one_way(self) -> "JobRequest":
        FrameSet.check_one_way(**self.axes())
        if self.atlas_layout != "uniform" and self.atlas is None:
            raise ValueError("atlas_layout lays out an atlas: give it with atlas")
        return self

    def axes(self) -> dict[str, Any]:
        """sigma, sigmas, delta, deltas and atlas as FrameSet.from_axes takes
        them (a range as {start, stop, count})."""
        def plain(axis):
            return axis.model_dump() if isinstance(axis, AngleRange) else axis
        return dict(sigma=self.sigma, sigmas=plain(self.sigmas), delta=self.delta, deltas=plain(self.deltas),
                    atlas=self.atlas)


class PriorityPatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    priority: StrictInt = Field(ge=PRIORITIES.start, le=PRIORITIES.stop - 1)


class FrameBrief(BaseModel):
    """A frame without its figures."""
    index: int
    sigma: float
    delta: float
    sigma_label: str = Field(description="σ as a person writes it (a π fraction where it is one: \"π/36\")")
    delta_label: str = Field(description="δ as a person writes it")
    sigma_index: int = Field(description="The frame's row in the job's grid (its σ in the job's sigmas)")
    delta_index: int = Field(description="The frame's column in the job's grid (its δ in the job's deltas)")
    status: str = Field(description="queued, rendering, assembling or done; a frame not done of a stopped job "
                        "shows the job's state (canceled, paused, failed)")
    png_url: str | None
    exr_url: str | None
    json_url: str | None = Field(description="The frame's figures as a file (frame_NNNN.json, as argand render writes it)")
    thumbnail_url: str | None
    finished: float | None


class FrameOut(FrameBrief):
    certified_share: float | None
    figures: dict | None


class FramePage(BaseModel):
    """A page of a job's frames, in index order, with their figures."""
    total: int
    page: int
    per_page: int
    frames: list[FrameOut]


class JobSummary(BaseModel):
    """A job in the list: its counters, of a size that does not grow with its
    frames (no scene, no axes, no frames: the job's own route has them, and
    its frames route pages through them)."""
    id: str
    status: str
    scene_name: str
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
    frames_total: int
    frames_done: int
    sigma_count: int = Field(description="Values on the grid's σ axis (rows)")
    delta_count: int = Field(description="Values on the grid's δ axis (columns)")
    thumbnail_url: str | None = Field(description="The thumbnail of the job's first frame done")
    frames_url: str = Field(description="The job's frames, page by page (GET, ?page=&per_page=)")
    animation_url: str | None
    webp_url: str | None
    mp4_url: str | None
    atlas_url: str | None = Field(description="atlas.png, the frames as a labelled contact sheet (a grid job, once done)")


class JobOut(JobSummary):
    """The job's own view: the summary, its scene, its grid's axes and every frame with its figures."""
    scene: dict
    sigmas: list[float] = Field(description="The grid's σ axis (rows), by sigma_index")
    deltas: list[float] = Field(description="The grid's δ axis (columns), by delta_index")
    sigma_labels: list[str] = Field(description="The σ axis as a person writes it (π fractions: \"π/36\"), by sigma_index")
    delta_labels: list[str] = Field(description="The δ axis as a person writes it, by delta_index")
    frames: list[FrameOut]


class JobPage(BaseModel):
    total: int
    page: int
    per_page: int
    jobs: list[JobSummary]


def _urls(base: str, index: int, done: bool) -> dict:
    return {"png_url": f"{base}/frames/{index}.png" if done else None,
            "exr_url": f"{base}/frames/{index}.exr" if done else None,
            "json_url": f"{base}/frames/{index}.json" if done else None,
            "thumbnail_url": f"{base}/frames/{index}/thumbnail.png" if done else None}


@dataclass(frozen=True)
class FrameCounts:
    """What a job's summary says of its frames (one aggregate query for a page of jobs)."""
    total: int = 0
    done: int = 0
    sigma_count: int = 0
    delta_count: int = 0
    first_done: int | None = None


def _job_fields(job: Job, done: int, total: int, frames: FrameCounts, is_grid: bool) -> dict:
    base = f"/api/jobs/{job.id}"
    animated = job.status == "done" and frames.total > 1
    return dict(
        id=job.id, status=job.status, scene_name=job.scene_name, width=job.width,
        height=job.height, tile=job.tile, method=job.method, priority=job.priority,
        progress=done / total if total else 0.0, tiles_done=done, tiles_total=total,
        eta_s=eta_seconds(job, done, total), created=job.created, started=job.started, finished=job.finished,
        error=job.error, frames_total=frames.total, frames_done=frames.done, sigma_count=frames.sigma_count,
        delta_count=frames.delta_count,
        thumbnail_url=None if frames.first_done is None else f"{base}/frames/{frames.first_done}/thumbnail.png",
        frames_url=f"{base}/frames", animation_url=f"{base}/animation.gif" if animated else None,
        webp_url=f"{base}/animation.webp" if animated else None,
        mp4_url=f"{base}/animation.mp4" if animated else None,
        atlas_url=f"{base}/atlas.png" if is_grid and job.status == "done" else None,
    )


def frame_out(base: str, f, job_status: str) -> FrameOut:
    return FrameOut(index=f.index, sigma=f.sigma, delta=f.delta, sigma_label=angle_text(f.sigma),
                    delta_label=angle_text(f.delta), sigma_index=f.sigma_index, delta_index=f.delta_index,
                    status=shown_frame_status(job_status, f.status), **_urls(base, f.index, f.status == "done"),
                    finished=f.finished, certified_share=(f.figures or {}).get("certified_share"), figures=f.figures)


def job_out(job: Job) -> JobOut:
    """The job's own view: every frame with its figures."""
    done, total = job_progress(job)
    base = f"/api/jobs/{job.id}"
    places = [FramePoint(f.sigma_index, f.delta_index, f.sigma, f.delta) for f in job.frames]
    grid = FrameSet.from_points(places)
    sigmas, deltas = list(grid.sigmas), list(grid.deltas)
    done_frames = [f.index for f in job.frames if f.status == "done"]
    counts = FrameCounts(len(places), len(done_frames), len(sigmas), len(deltas), min(done_frames, default=None))
    return JobOut(scene=job.scene, sigmas=sigmas, deltas=deltas, sigma_labels=[angle_text(v) for v in sigmas],
                  delta_labels=[angle_text(v) for v in deltas],
                  frames=[frame_out(base, f, job.status) for f in job.frames],
                  **_job_fields(job, done, total, counts, grid.is_grid))


def job_summary(job: Job, progress: tuple[int, int], frames: FrameCounts) -> JobSummary:
    """A job in the list, from its row (scene deferred), its (tiles done, total) and its frames' counts."""
    is_grid = frames.sigma_count > 1 and frames.delta_count > 1  # FrameSet.is_grid, from the counts
    return JobSummary(**_job_fields(job, *progress, frames, is_grid))
