"""The service itself: presets, scene validation, workers, health, and
/api/meta (the definitions the front end reads instead of keeping copies)."""

from __future__ import annotations

import math
import tempfile
import threading
import time
from pathlib import Path

from fastapi import APIRouter, HTTPException, Response
from sqlalchemy import func, select

from argand.api.deps import SettingsDep
from argand.api.routes.frames import binary
from argand.api.schemas import JobRequest
from argand.core import METHODS
from argand.farm.database import session_scope
from argand.farm.models import Job
from argand.farm.outbox import pending
from argand.farm.planning import MAX_TILE, MIN_TILE
from argand.render.frames import TILE_MULTIPLE
from argand.farm.previews import EMPTY, PREVIEW_CHANNELS, STATUS_COLOURS
from argand.farm.queue import PRIORITIES, broker_client
from argand.farm.reaper import take_census
from argand.farm.states import ACTIONS, ENDED, FRAME_SHOWN, JOB
from argand.farm.submission import check_disk
from argand.farm.workers import list_workers
from argand.render import MAX_OBJECTS, FrameParams, render_frame
from argand.render.frames import MAX_SAMPLES, STATUS_NAMES
from argand.media.frame_files import to_srgb8, write_png
from argand.scene import MAX_DEGREE, ExpressionError, SceneError, load_scene, parse_surface, scene_from_dict
from argand.scene.presets import PRESETS

router = APIRouter(tags=["service"])


@router.get("/api/meta")
def meta(settings: SettingsDep) -> dict:
    """States, actions, pixel statuses (code, name, colour), channels,
    methods, limits and a new job's defaults, each from where it is defined."""
    fields = JobRequest.model_fields
    return {
        "job_states": list(JOB.states),
        "ended_states": list(ENDED),
        "frame_states": list(FRAME_SHOWN),
        "actions": {action: list(applies_to) for action, (applies_to, _) in ACTIONS.items()},
        "pixel_statuses": [{"code": code, "name": name, "colour": "#%02x%02x%02x" % STATUS_COLOURS[name]}
                           for code, name in sorted(STATUS_NAMES.items())],
        "status_empty": {"colour": "#%02x%02x%02x" % EMPTY,
                         "meaning": "no surface: the pixel's ray provably meets none (the background)"},
        "channels": list(PREVIEW_CHANNELS),
        "methods": list(METHODS),
        "limits": {"max_width": settings.max_width, "max_height": settings.max_height,
                   "max_frames": settings.max_frames, "max_job_pixels": settings.max_job_pixels,
                   "min_tile": MIN_TILE, "max_tile": MAX_TILE, "tile_multiple": TILE_MULTIPLE, "priority": [PRIORITIES.start, PRIORITIES.stop - 1],
                   "max_degree": MAX_DEGREE, "max_job_tiles": settings.max_job_tiles,
                   "max_active_jobs": settings.max_active_jobs, "max_body_bytes": settings.max_body_bytes,
                   "max_objects": MAX_OBJECTS, "max_streams_per_client": settings.max_streams_per_client,
                   "max_streams": settings.max_streams, "min_free_bytes": settings.min_free_bytes,
                   "tile_soft_time_limit_s": settings.tile_soft_time_limit_s,
                   "tile_hard_time_limit_s": settings.tile_hard_time_limit_s, "max_samples": MAX_SAMPLES,
                   "samples": [k * k for k in range(1, math.isqrt(MAX_SAMPLES) + 1)]},
        "defaults": {"width": fields["width"].default, "height": fields["height"].default,
                     "tile": settings.default_tile, "priority": fields["priority"].default,
                     "method": fields["method"].default, "samples": 1},
    }


@router.get("/api/presets")
def presets() -> list[dict]:
    out = []
    for name in PRESETS:
        scene = load_scene(name)
        out.append({"name": name, "scene": scene.to_dict(), "degrees": [o.polynomial.degree for o in scene.objects]})
    return out


_preset_thumbs: dict[str, bytes] = {}


@router.get("/api/presets/{name}/thumbnail.png", **binary("image/png", "A small render of the preset"))
def preset_thumbnail(name: str):
    """A small render of a preset at delta = pi/18 (cached in memory)."""
    if name not in PRESETS:
        raise HTTPException(404, detail=f"no preset {name!r}")
    if name not in _preset_thumbs:
        result = render_frame(load_scene(name), FrameParams(delta=math.pi / 18, width=128, height=128), workers=1)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "t.png"
            write_png(to_srgb8(result.rgba), path)
            _preset_thumbs[name] = path.read_bytes()
    return Response(_preset_thumbs[name], media_type="image/png")


@router.post("/api/scenes/validate")
def validate_scene(body: dict) -> dict:
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


@router.get("/api/workers")
def workers(settings: SettingsDep) -> list[dict]:
    return list_workers(settings)


def _check(name: str, probe) -> dict:
    try:
        return {"name": name, "ok": True, **(probe() or {})}
    except Exception as exc:  # a check reports, it does not raise
        return {"name": name, "ok": False, "error": f"{type(exc).__name__}: {str(exc)[:200]}"}


#: Messages older than this in the outbox mean that no drainer sends them.
OUTBOX_STALE_S = 120.0


def farm_health(settings) -> tuple[bool, dict]:
    """(can the farm work, what each part says): the database answers, the
    broker answers, the store has its free-space floor (min_free_bytes), at
    least one worker sent a heartbeat in time, and the outbox (messages not
    sent yet: a broker outage shows here) is drained."""

    def database():
        with session_scope(settings.sqlalchemy_url) as s:
            s.scalar(select(func.count()).select_from(Job))

    def broker():
        client = broker_client(settings)
        client.connection_pool.connection_kwargs.update(socket_timeout=2, socket_connect_timeout=2)
        client.ping()

    def workers():
        alive = sum(w["alive"] for w in list_workers(settings))
        if not alive:
            raise RuntimeError(f"no worker sent a heartbeat in the last {settings.heartbeat_timeout_s:g} s")
        return {"alive": alive}

    def outbox():
        n, oldest = pending(settings)
        if oldest is not None and oldest > OUTBOX_STALE_S:
            raise RuntimeError(f"{n} messages wait in the outbox, the oldest for {oldest:.0f} s: nothing sends them")
        return {"pending": n, "oldest_s": None if oldest is None else round(oldest, 1)}

    checks = [_check("database", database), _check("redis", broker), _check("store", lambda: check_disk(settings))]
    if checks[0]["ok"]:
        checks += [_check("workers", workers), _check("outbox", outbox)]
    else:  # each would wait out the database's connect timeout again
        checks += [{"name": name, "ok": False, "error": "not checked: the database does not answer"}
                   for name in ("workers", "outbox")]
    ok = all(c["ok"] for c in checks)
    return ok, {"status": "ok" if ok else "unavailable", "checks": checks}


_HEALTH_RESPONSES = {503: {"description": "The farm cannot work: a check failed (the body says which)"}}


#: A census is read at most once in this many seconds per farm (GET /healthz
#: is open: requests in a loop must not each cost one); later callers within
#: that time get the last one.
CENSUS_REUSE_S = 2.0
_census_lock = threading.Lock()
_censuses: dict[tuple[str, str], tuple[float, dict]] = {}


def queue_census(settings) -> dict:
    """The queue against the database (argand.farm.reaper.take_census): the
    queued tiles of active jobs, those that no message carries (work nobody
    is doing until the reaper sends it again) and the stale messages; at
    most CENSUS_REUSE_S old."""

    def census():
        client = broker_client(settings)
        client.connection_pool.connection_kwargs.update(socket_timeout=2, socket_connect_timeout=2)
        c = take_census(settings, client)
        return {"queued_tiles": c.queued, "unsent_tiles": c.unsent_tiles, "stale_messages": len(c.stale),
                "unsent_by_job": {job_id: len(tiles) for job_id, tiles in sorted(c.unsent.items())}}

    key = (settings.sqlalchemy_url, settings.broker_url)
    with _census_lock:  # one census at a time; the callers meanwhile wait for it and share it
        at, body = _censuses.get(key, (-float("inf"), {}))
        if time.monotonic() - at >= CENSUS_REUSE_S:
            body = _check("queue", census)
            _censuses[key] = (time.monotonic(), body)
        return body


@router.get("/healthz", responses=_HEALTH_RESPONSES)
def healthz(settings: SettingsDep, response: Response) -> dict:
    """The database, Redis and live workers; 503 when the farm cannot
    render. The ``queue`` entry is a report, not a check: tiles that no
    message carries are sent again by the reaper within twice
    queue_check_s."""
    ok, body = farm_health(settings)
    if not ok:
        response.status_code = 503
    database_ok = body["checks"][0]["ok"]
    body["queue"] = queue_census(settings) if database_ok else {
        "name": "queue", "ok": False, "error": "not read: the database does not answer"}
    return body


@router.get("/readyz", responses=_HEALTH_RESPONSES)
def readyz(settings: SettingsDep, response: Response) -> dict:
    """The API can take jobs: the database and Redis answer (workers may
    still be starting; queued work waits for them). 503 otherwise."""
    _, body = farm_health(settings)
    ready = all(c["ok"] for c in body["checks"] if c["name"] in ("database", "redis"))
    if not ready:
        response.status_code = 503
    return {"status": "ready" if ready else "unavailable", "checks": body["checks"]}
