"""A job's files: each frame's PNG, EXR, thumbnail and channel previews, the
animation (GIF, WebP, MP4) and a grid's atlas. A frame's files are made on
their first request from the job's root field where the assembler did not
write them (argand.farm.derived), the animations and the atlas on theirs;
all are kept. Paths: argand.farm.layout."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException, Query
from fastapi.responses import FileResponse, Response
from sqlalchemy import func, select

from argand.api.deps import JobIdDep, SessionDep, SettingsDep, job_or_404
from argand.api.schemas import FramePage, frame_out
from argand.farm.assembly import animation_gif, animation_mp4, animation_webp, atlas_png
from argand.farm.derived import frame_file
from argand.farm.database import session_scope
from argand.farm.job_limits import MAX_PAGE
from argand.farm.models import Frame, Job
from argand.farm.previews import PREVIEW_CHANNELS, channel_png
from argand.farm.store import store_for

router = APIRouter(prefix="/api/jobs/{job_id}", tags=["frames"])


def binary(media: str, description: str) -> dict:
    """A route's documented answer: a file of this media type."""
    return {"response_class": Response, "responses": {200: {"content": {media: {}}, "description": description}}}


#: Frames in one page of GET /api/jobs/{id}/frames (a job has at most max_frames).
MAX_FRAMES_PER_PAGE = 1000


@router.get("/frames")
def frames_page(job_id: JobIdDep, s: SessionDep, page: int = Query(1, ge=1, le=MAX_PAGE),
                per_page: int = Query(100, ge=1, le=MAX_FRAMES_PER_PAGE)) -> FramePage:
    """The job's frames with their figures, in index order, a page at a time."""
    status = s.scalar(select(Job.status).where(Job.id == job_id))
    total = s.scalar(select(func.count()).select_from(Frame).where(Frame.job_id == job_id))
    rows = s.scalars(select(Frame).where(Frame.job_id == job_id).order_by(Frame.index)
                     .offset((page - 1) * per_page).limit(per_page)).all()
    base = f"/api/jobs/{job_id}"
    return FramePage(total=total, page=page, per_page=per_page, frames=[frame_out(base, f, status) for f in rows])


def _derived(settings, job_id: str, index: int, kind: str) -> Path:
    """The frame's file ``kind`` (png, thumbnail, exr, json), written now
    (from the job's root field, or its row) if it is not yet (argand.farm.derived.frame_file);
    404 while the frame is not done."""
    path = frame_file(settings, job_id, index, kind)
    if path is None:
        raise HTTPException(404, detail=f"frame {index} of job {job_id} is not ready")
    return path


@router.get("/frames/{index}.png", **binary("image/png", "The frame's PNG"))
def frame_png(job_id: JobIdDep, index: int, settings: SettingsDep):
    """The frame's picture (sRGB), made on its first request where the
    assembler did not write it, and kept."""
    return FileResponse(_derived(settings, job_id, index, "png"), media_type="image/png")


def _exr(settings, job_id: str, index: int) -> Path:
    return _derived(settings, job_id, index, "exr")


@router.get("/frames/{index}.exr", **binary("image/x-exr", "The frame's EXR (every AOV)"))
def frame_exr_file(job_id: JobIdDep, index: int, settings: SettingsDep):
    """The frame's EXR: R, G, B, A and every AOV. Written on its first
    request (decided from the job's root field, the very pixels the workers
    rendered) and kept."""
    return FileResponse(_exr(settings, job_id, index), media_type="image/x-exr")


@router.get("/frames/{index}.json", **binary("application/json", "The frame's figures (frame_NNNN.json)"))
def frame_json_file(job_id: JobIdDep, index: int, settings: SettingsDep):
    """The frame's figures as `argand render` writes them (frame_NNNN.json:
    the frame's figures and index), written on its first request and kept."""
    return FileResponse(_derived(settings, job_id, index, "json"), media_type="application/json")


@router.get("/frames/{index}/thumbnail.png", **binary("image/png", "A small copy of the frame's PNG"))
def frame_thumbnail(job_id: JobIdDep, index: int, settings: SettingsDep):
    return FileResponse(_derived(settings, job_id, index, "thumbnail"), media_type="image/png")


@router.get("/frames/{index}/{channel}.png", **binary("image/png", "The channel in false colour"))
def frame_channel(job_id: JobIdDep, index: int, channel: str, settings: SettingsDep):
    """A channel of the frame in false colour (beauty: the frame's PNG)."""
    if channel not in PREVIEW_CHANNELS:
        raise HTTPException(422, detail=f"channel must be one of {', '.join(PREVIEW_CHANNELS)}")
    layout = store_for(settings).job(job_id)
    if channel == "beauty":
        return FileResponse(_derived(settings, job_id, index, "png"), media_type="image/png")
    out = layout.channel(channel, index)
    if out.exists():
        return FileResponse(out, media_type="image/png")
    exr = _exr(settings, job_id, index)
    if not out.exists():
        channel_png(exr, channel, out)
    return FileResponse(out, media_type="image/png")


@router.get("/animation.gif", **binary("image/gif", "The animation"))
def animation_as_gif(job_id: JobIdDep, settings: SettingsDep):
    """The animation as GIF: spliced by the assembler when the job ended, or
    made from the frames' PNGs on the first request, then kept."""
    path = store_for(settings).job(job_id).animation("gif")
    if not path.exists():
        n = _done_frames(settings, job_id, "animation")
        animation_gif(settings, job_id, n)
    return FileResponse(path, media_type="image/gif")


def _done_frames(settings, job_id: str, what: str) -> int:
    """The number of frames of a finished job; 404 while it is not done."""
    with session_scope(settings.sqlalchemy_url) as s:
        job = job_or_404(s, job_id)
        status, n = job.status, len(job.frames)
    if status != "done":
        raise HTTPException(404, detail=f"the {what} is not ready: the job is {status}")
    return n


@router.get("/animation.webp", **binary("image/webp", "The animation as WebP"))
def animation_as_webp(job_id: JobIdDep, settings: SettingsDep):
    """The animation as a looping WebP (smaller than the GIF, full colour),
    made from the frames' PNGs on the first request, then kept."""
    n = _done_frames(settings, job_id, "animation")
    if not animation_webp(settings, job_id, n):
        raise HTTPException(501, detail="this installation's Pillow has no WebP support")
    return FileResponse(store_for(settings).job(job_id).animation("webp"), media_type="image/webp")


@router.get("/animation.mp4", **binary("video/mp4", "The animation as MP4 (H.264)"))
def animation_as_mp4(job_id: JobIdDep, settings: SettingsDep):
    """The animation as MP4 (H.264, yuv420p: every browser plays it), made
    from the frames' PNGs on the first request, then kept."""
    n = _done_frames(settings, job_id, "animation")
    if n < 2:
        raise HTTPException(404, detail="a job of one frame has no animation")
    animation_mp4(settings, job_id, n)
    return FileResponse(store_for(settings).job(job_id).animation("mp4"), media_type="video/mp4")


@router.get("/atlas.png", **binary("image/png", "The grid's frames as one labelled contact sheet"))
def atlas(job_id: JobIdDep, settings: SettingsDep):
    """The frames of a grid job (several σ and δ) as one contact sheet,
    labelled with σ (rows) and δ (columns), made on the first request, then kept."""
    _done_frames(settings, job_id, "atlas")
    if not atlas_png(settings, job_id):
        raise HTTPException(404, detail="the job is not a grid (an atlas needs several sigmas and several deltas)")
    return FileResponse(store_for(settings).job(job_id).atlas(), media_type="image/png")
