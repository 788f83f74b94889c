"""The FastAPI service: render jobs over HTTP (OpenAPI at /docs)."""

from __future__ import annotations

import asyncio
import json
import sys
import math
import threading
import time
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, FastAPI, HTTPException, Query, Request
from fastapi.staticfiles import StaticFiles
from fastapi.responses import FileResponse, JSONResponse, PlainTextResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, Field, field_validator
import numpy as np
from sqlalchemy import func, select

from argand.api.db import JOB_STATES, Frame, Job, Tile, Worker, job_progress, session_scope
from argand.api.settings import Settings, get_settings

SettingsDep = Annotated[Settings, Depends(get_settings)]


# ---------------------------------------------------------------------------
# Request and response models
# ---------------------------------------------------------------------------


def _angle(v: Any) -> float:
    from argand.render.angles import parse_angle

    if isinstance(v, str):
        return parse_angle(v)
    f = float(v)
    if not math.isfinite(f):
        raise ValueError("angles must be finite")
    return f


class DeltaRange(BaseModel):
    model_config = ConfigDict(extra="forbid")
    start: float | str
    stop: float | str
    count: int = Field(ge=1)

    @field_validator("start", "stop", mode="before")
    @classmethod
    def _parse(cls, v: Any) -> float:
        return _angle(v)


class JobRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    scene: str | dict = Field(description="A preset name or a scene object")
    sigma: float | str = 0.0
    deltas: list[float | str] | DeltaRange = Field(default_factory=lambda: [0.0])
    width: int = Field(256, ge=1)
    height: int = Field(256, ge=1)
    tile: int | None = Field(None, ge=8, le=4096)
    priority: int = Field(5, ge=0, le=9)
    method: Literal["auto", "smith", "paper", "unverified"] = "auto"

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
            out = [_angle(d) for d in v]
            if any(d < 0 for d in out):
                raise ValueError("every delta must be >= 0")
            return out
        return v


class PriorityPatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    priority: int = Field(ge=0, le=9)


def resolve_scene(spec: str | dict) -> tuple[str, dict]:
    from argand.scene import SceneError, load_scene, scene_from_dict
    from argand.scene.presets import PRESETS

    try:
        if isinstance(spec, str):
            if spec not in PRESETS:
                raise SceneError(f"unknown preset {spec!r}; presets: {', '.join(PRESETS)}")
            return spec, load_scene(spec).to_dict()
        return "custom", scene_from_dict(spec).to_dict()
    except SceneError as exc:
        raise HTTPException(422, detail=str(exc)) from None


def job_view(s, job: Job, request: Request | None = None) -> dict:
    done, total = job_progress(s, job)
    from argand.worker.farm import eta_seconds

    base = f"/api/jobs/{job.id}"
    frames = [
        {
            "index": f.index,
            "sigma": f.sigma,
            "delta": f.delta,
            "status": f.status,
            "png_url": f"{base}/frames/{f.index}.png" if f.status == "done" else None,
            "exr_url": f"{base}/frames/{f.index}.exr" if f.status == "done" else None,
            "thumbnail_url": f"{base}/frames/{f.index}/thumbnail.png" if f.status == "done" else None,
            "finished": f.finished,
            "certified_share": (f.figures or {}).get("certified_share"),
            "figures": f.figures,
        }
        for f in job.frames
    ]
    return {
        "id": job.id,
        "status": job.status,
        "scene_name": job.scene_name,
        "scene": job.scene,
        "sigma": job.sigma,
        "width": job.width,
        "height": job.height,
        "tile": job.tile,
        "method": job.method,
        "priority": job.priority,
        "progress": done / total if total else 0.0,
        "tiles_done": done,
        "tiles_total": total,
        "eta_s": eta_seconds(job, done, total),
        "created": job.created,
        "started": job.started,
        "finished": job.finished,
        "error": job.error,
        "frames": frames,
        "animation_url": f"{base}/animation.gif" if job.status == "done" and len(frames) > 1 else None,
        "webp_url": f"{base}/animation.webp" if job.status == "done" and len(frames) > 1 else None,
    }


# ---------------------------------------------------------------------------
# Routers (one per resource)
# ---------------------------------------------------------------------------

jobs = APIRouter(prefix="/api/jobs", tags=["jobs"])


@jobs.post("", status_code=201)
def submit(req: JobRequest, settings: SettingsDep) -> dict:
    from argand.worker.farm import create_job, frames_of

    name, scene = resolve_scene(req.scene)
    deltas = frames_of(req.deltas.model_dump() if isinstance(req.deltas, DeltaRange) else req.deltas)
    if any(d < 0 for d in deltas):
        raise HTTPException(422, detail="every delta must be >= 0")
    if req.width > settings.max_width or req.height > settings.max_height:
        raise HTTPException(422, detail=f"frame size {req.width}x{req.height} exceeds the limit {settings.max_width}x{settings.max_height}")
    if len(deltas) > settings.max_frames:
        raise HTTPException(422, detail=f"{len(deltas)} frames exceed the limit of {settings.max_frames}")
    pixels = req.width * req.height * len(deltas)
    if pixels > settings.max_job_pixels:
        raise HTTPException(422, detail=f"the job has {pixels} pixels, above the limit of {settings.max_job_pixels}")
    tile = req.tile or settings.default_tile
    job_id = create_job(settings, name, scene, float(req.sigma), deltas, req.width, req.height, tile, req.priority, req.method)
    with session_scope(settings.sqlalchemy_url) as s:
        return job_view(s, s.get(Job, job_id))


@jobs.get("")
def list_jobs(
    settings: SettingsDep,
    status: str | None = Query(None, description="|".join(JOB_STATES)),
    page: int = Query(1, ge=1),
    per_page: int = Query(20, ge=1, le=200),
) -> dict:
    if status is not None and status not in JOB_STATES:
        raise HTTPException(422, detail=f"status must be one of {', '.join(JOB_STATES)}")
    with session_scope(settings.sqlalchemy_url) as s:
        q = select(Job).order_by(Job.created.desc())
        cq = select(func.count()).select_from(Job)
        if status:
            q = q.where(Job.status == status)
            cq = cq.where(Job.status == status)
        total = s.scalar(cq)
        rows = s.scalars(q.offset((page - 1) * per_page).limit(per_page)).all()
        return {"total": total, "page": page, "per_page": per_page, "jobs": [job_view(s, j) for j in rows]}


def _job_or_404(s, job_id: str) -> Job:
    job = s.get(Job, job_id)
    if job is None:
        raise HTTPException(404, detail=f"no job {job_id!r}")
    return job


@jobs.get("/{job_id}")
def get_job(job_id: str, settings: SettingsDep) -> dict:
    with session_scope(settings.sqlalchemy_url) as s:
        return job_view(s, _job_or_404(s, job_id))


def _file(settings: Settings, job_id: str, name: str, media: str) -> FileResponse:
    from argand.worker.farm import store_for

    with session_scope(settings.sqlalchemy_url) as s:
        _job_or_404(s, job_id)
    path = Path(store_for(settings).job_dir(job_id)) / name
    if not path.exists():
        raise HTTPException(404, detail=f"{name} is not ready")
    return FileResponse(path, media_type=media)


@jobs.get("/{job_id}/frames/{index}.png")
def frame_png(job_id: str, index: int, settings: SettingsDep):
    return _file(settings, job_id, f"frame_{index:04d}.png", "image/png")


@jobs.get("/{job_id}/frames/{index}.exr")
def frame_exr(job_id: str, index: int, settings: SettingsDep):
    return _file(settings, job_id, f"frame_{index:04d}.exr", "image/x-exr")


@jobs.get("/{job_id}/frames/{index}/thumbnail.png")
def frame_thumb(job_id: str, index: int, settings: SettingsDep):
    return _file(settings, job_id, f"thumb_{index:04d}.png", "image/png")


CHANNELS = ("beauty", "modulus", "argument", "status")
#: Status colours: certified, cluster, unverified, undecided.
STATUS_RGB = np.array([[46, 160, 67], [230, 180, 30], [215, 60, 50], [120, 90, 200]], dtype=np.uint8)


def channel_png(exr: Path, channel: str, out: Path) -> None:
    """A false-colour PNG of one AOV of a frame (cached beside the frame)."""
    from argand.render.output import read_exr, write_png

    names, px = read_exr(exr)
    hit = px[..., names.index("A")] > 0
    rgb = np.full(px.shape[:2] + (3,), 24, np.uint8)
    if channel == "status":
        st = px[..., names.index("status")].astype(int).clip(0, 3)
        rgb = STATUS_RGB[st]
        rgb[~hit & (st == 0)] = (24, 24, 28)
    else:
        v = px[..., names.index("Z" if channel == "modulus" else "arg")]
        if channel == "argument":
            t = np.abs(v) / np.pi
        else:
            finite = hit & np.isfinite(v)
            lo, hi = (np.percentile(v[finite], [2, 98]) if finite.any() else (0.0, 1.0))
            t = np.clip((v - lo) / max(hi - lo, 1e-12), 0, 1)
        t = np.nan_to_num(t)
        ramp = np.stack([t, 1 - np.abs(2 * t - 1), 1 - t], axis=-1)  # blue -> green -> red
        rgb = np.where(hit[..., None], (40 + 215 * ramp).astype(np.uint8), rgb)
    write_png(np.ascontiguousarray(rgb.astype(np.uint8)), out)


@jobs.get("/{job_id}/frames/{index}/{channel}.png")
def frame_channel(job_id: str, index: int, channel: str, settings: SettingsDep):
    from argand.worker.farm import store_for

    if channel not in CHANNELS:
        raise HTTPException(422, detail=f"channel must be one of {', '.join(CHANNELS)}")
    if channel == "beauty":
        return frame_png(job_id, index, settings)
    if channel == "thumbnail":
        return frame_thumb(job_id, index, settings)
    folder = Path(store_for(settings).job_dir(job_id))
    exr = folder / f"frame_{index:04d}.exr"
    if not exr.exists():
        raise HTTPException(404, detail="the frame is not ready")
    out = folder / f"{channel}_{index:04d}.png"
    if not out.exists():
        channel_png(exr, channel, out)
    return FileResponse(out, media_type="image/png")


@jobs.get("/{job_id}/animation.gif")
def animation(job_id: str, settings: SettingsDep):
    return _file(settings, job_id, "animation.gif", "image/gif")


@jobs.get("/{job_id}/animation.webp")
def animation_webp(job_id: str, settings: SettingsDep):
    """The animation as a looping WebP (smaller than the GIF, full colour),
    made from the frames' PNGs on the first request, then kept."""
    import OpenImageIO as oiio

    from argand.render import gif
    from argand.worker.farm import store_for

    with session_scope(settings.sqlalchemy_url) as s:
        job = _job_or_404(s, job_id)
        status, n = job.status, len(job.frames)
    if status != "done":
        raise HTTPException(404, detail=f"the animation is not ready: the job is {status}")
    store = store_for(settings)
    path = Path(store.job_dir(job_id)) / "animation.webp"
    if not path.exists():
        frames = [oiio.ImageBuf(str(path.with_name(f"frame_{i:04d}.png"))).get_pixels(oiio.UINT8)[..., :3] for i in range(n)]
        data = gif.encode_animation_webp(frames)
        if data is None:
            raise HTTPException(501, detail="this installation's Pillow has no WebP support")
        store.write_bytes_atomic(store.path("jobs", job_id, "animation.webp"), data)
    return FileResponse(path, media_type="image/webp")


@jobs.post("/{job_id}/{action}")
def control(job_id: str, action: Literal["cancel", "pause", "resume", "retry"], settings: SettingsDep) -> dict:
    from argand.worker.farm import set_job_status

    try:
        set_job_status(settings, job_id, action)
    except KeyError:
        raise HTTPException(404, detail=f"no job {job_id!r}") from None
    with session_scope(settings.sqlalchemy_url) as s:
        return job_view(s, s.get(Job, job_id))


@jobs.patch("/{job_id}")
def patch(job_id: str, body: PriorityPatch, settings: SettingsDep) -> dict:
    """A new priority takes effect at once: the job's queued tiles are sent
    again at that priority (the older messages become no-ops, since a tile
    is claimed by compare-and-set)."""
    from argand.worker.farm import dispatch_job

    with session_scope(settings.sqlalchemy_url) as s:
        job = _job_or_404(s, job_id)
        job.priority = body.priority
        active = job.status in ("queued", "running")
    if active:
        dispatch_job(settings, job_id)
    with session_scope(settings.sqlalchemy_url) as s:
        return job_view(s, s.get(Job, job_id))


@jobs.delete("/{job_id}", status_code=204)
def delete(job_id: str, settings: SettingsDep) -> None:
    from argand.worker.farm import store_for

    with session_scope(settings.sqlalchemy_url) as s:
        job = _job_or_404(s, job_id)
        job.status = "canceled"
    with session_scope(settings.sqlalchemy_url) as s:
        s.delete(s.get(Job, job_id))
    store_for(settings).remove_job(job_id)


@jobs.get("/{job_id}/events")
async def events(job_id: str, settings: SettingsDep):
    """Server-sent events: the job's progress until it ends."""
    with session_scope(settings.sqlalchemy_url) as s:
        _job_or_404(s, job_id)

    async def stream():
        last = None
        while True:
            with session_scope(settings.sqlalchemy_url) as s:
                job = s.get(Job, job_id)
                if job is None:
                    yield "event: deleted\ndata: {}\n\n"
                    return
                view = job_view(s, job)
            payload = {k: view[k] for k in ("id", "status", "progress", "eta_s", "tiles_done", "tiles_total")}
            payload["frames"] = [{"index": f["index"], "status": f["status"]} for f in view["frames"]]
            if payload != last:
                yield f"event: progress\ndata: {json.dumps(payload)}\n\n"
                last = payload
            if view["status"] in ("done", "failed", "canceled"):
                yield f"event: end\ndata: {json.dumps({'status': view['status']})}\n\n"
                return
            await asyncio.sleep(0.5)

    return StreamingResponse(stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"})


misc = APIRouter(tags=["service"])


@misc.get("/api/presets")
def presets() -> list[dict]:
    from argand.scene import load_scene
    from argand.scene.presets import PRESETS

    out = []
    for name in PRESETS:
        scene = load_scene(name)
        out.append({"name": name, "scene": scene.to_dict(), "degrees": [o.polynomial.degree for o in scene.objects]})
    return out


_preset_thumbs: dict[str, bytes] = {}


@misc.get("/api/presets/{name}/thumbnail.png")
def preset_thumbnail(name: str):
    """A small render of a preset at delta = pi/18 (cached in memory)."""
    import tempfile

    from fastapi import Response

    from argand.render import FrameParams, render_frame
    from argand.render.output import to_srgb8, write_png
    from argand.scene import load_scene
    from argand.scene.presets import PRESETS

    if name not in PRESETS:
        raise HTTPException(404, detail=f"no preset {name!r}")
    if name not in _preset_thumbs:
        result = render_frame(load_scene(name), FrameParams(delta=math.pi / 18, width=128, height=128), workers=1)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "t.png"
            write_png(to_srgb8(result.rgba), path)
            _preset_thumbs[name] = path.read_bytes()
    return Response(_preset_thumbs[name], media_type="image/png")


@misc.post("/api/scenes/validate")
def validate_scene(body: dict) -> dict:
    from argand.scene import ExpressionError, SceneError, parse_surface, scene_from_dict

    if "surface" in body and "objects" not in body:
        try:
            p = parse_surface(body["surface"])
            return {"valid": True, "degree": p.degree}
        except ExpressionError as exc:
            return {"valid": False, "error": exc.message, "position": exc.position, "message": str(exc)}
    try:
        scene = scene_from_dict(body)
        return {"valid": True, "degrees": [o.polynomial.degree for o in scene.objects]}
    except SceneError as exc:
        return {"valid": False, "error": str(exc)}


@misc.get("/api/workers")
def workers(settings: SettingsDep) -> list[dict]:
    now = time.time()
    with session_scope(settings.sqlalchemy_url) as s:
        return [
            {"name": w.name, "host": w.host, "pid": w.pid, "heartbeat": w.heartbeat, "alive": now - w.heartbeat < settings.heartbeat_timeout_s,
             "current_tile": w.current_tile, "tiles_done": w.tiles_done}
            for w in s.scalars(select(Worker).order_by(Worker.name))
        ]


@misc.get("/healthz")
def healthz(settings: SettingsDep) -> dict:
    import redis

    with session_scope(settings.sqlalchemy_url) as s:
        s.scalar(select(func.count()).select_from(Job))
    url = settings.broker_url
    client = redis.Redis(unix_socket_path=url.split("://", 1)[1]) if url.startswith("redis+socket://") else redis.Redis.from_url(url)
    client.ping()
    return {"status": "ok"}


@misc.get("/metrics", response_class=PlainTextResponse)
def metrics(settings: SettingsDep) -> str:
    lines = ["# HELP argand_jobs Jobs by status", "# TYPE argand_jobs gauge"]
    with session_scope(settings.sqlalchemy_url) as s:
        for status in JOB_STATES:
            n = s.scalar(select(func.count()).select_from(Job).where(Job.status == status))
            lines.append(f'argand_jobs{{status="{status}"}} {n}')
        lines += ["# HELP argand_tiles Tiles by status", "# TYPE argand_tiles gauge"]
        for status in ("queued", "running", "done", "failed"):
            n = s.scalar(select(func.count()).select_from(Tile).where(Tile.status == status))
            lines.append(f'argand_tiles{{status="{status}"}} {n}')
        done_frames = s.scalar(select(func.count()).select_from(Frame).where(Frame.status == "done"))
        lines += ["# TYPE argand_frames_done_total counter", f"argand_frames_done_total {done_frames}"]
        now = time.time()
        alive = sum(1 for w in s.scalars(select(Worker)) if now - w.heartbeat < settings.heartbeat_timeout_s)
        lines += ["# TYPE argand_workers_alive gauge", f"argand_workers_alive {alive}"]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# The application
# ---------------------------------------------------------------------------


def _reaper(settings: Settings, stop: threading.Event) -> None:
    from argand.worker.farm import reap

    while not stop.wait(max(1.0, settings.heartbeat_interval_s)):
        try:
            reap(settings)
        except Exception as exc:  # the database may be briefly locked; next round
            print(f"argand reaper: {exc!r}", file=sys.stderr)


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()

    @asynccontextmanager
    async def lifespan(_app: FastAPI):
        stop = threading.Event()
        thread = threading.Thread(target=_reaper, args=(settings, stop), daemon=True, name="argand-reaper")
        thread.start()
        yield
        stop.set()

    app = FastAPI(title="Argand", description="Render jobs of algebraic surfaces in complex space.", lifespan=lifespan)
    app.dependency_overrides[get_settings] = lambda: settings
    app.include_router(jobs)
    app.include_router(misc)

    @app.exception_handler(ValueError)
    async def _value_error(_request: Request, exc: ValueError):
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    web = Path(__file__).resolve().parent.parent / "web"
    index = web / "index.html"
    if web.is_dir():
        app.mount("/static", StaticFiles(directory=web), name="static")

    @app.get("/", include_in_schema=False)
    def root():
        if index.exists():
            return FileResponse(index)
        return JSONResponse({"service": "argand", "docs": "/docs", "jobs": "/api/jobs"})

    return app
