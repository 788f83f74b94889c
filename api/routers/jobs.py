"""/api/jobs: submit, list, read, control, re-prioritise, delete, and follow a job."""

from __future__ import annotations

import asyncio
import json
from typing import Literal

from fastapi import APIRouter, HTTPException, Query
from fastapi.responses import StreamingResponse
from sqlalchemy import func, select

from argand.api.deps import JobIdDep, SettingsDep, job_or_404
from argand.api.schemas import DeltaRange, JobOut, JobPage, JobRequest, PriorityPatch, job_out
from argand.farm.control import delete_job, set_job_status, set_priority
from argand.farm.database import session_scope
from argand.farm.models import Job
from argand.farm.states import ACTIONS, ENDED, JOB
from argand.farm.limits import MAX_PAGE
from argand.farm.submission import FarmBusy, JobRefused, JobSpec, create_job, sweep_deltas
from argand.scene import SceneError, load_scene, scene_from_dict
from argand.scene.presets import PRESETS

router = APIRouter(prefix="/api/jobs", tags=["jobs"])


def resolve_scene(spec: str | dict) -> tuple[str, dict]:
    """(name, scene as a dict) of a preset's name or a scene object; 422 if invalid."""
    try:
        if isinstance(spec, str):
            if spec not in PRESETS:
                raise SceneError(f"unknown preset {spec!r}; presets: {', '.join(PRESETS)}")
            return spec, load_scene(spec).to_dict()
        return "custom", scene_from_dict(spec).to_dict()
    except SceneError as exc:
        raise HTTPException(422, detail=str(exc)) from None


def _job(settings, job_id: str) -> JobOut:
    with session_scope(settings.sqlalchemy_url) as s:
        return job_out(job_or_404(s, job_id))


@router.post("", status_code=201, responses={413: {"description": "The body is above max_body_bytes"},
                                                 429: {"description": "max_active_jobs are in flight"}})
def submit(req: JobRequest, settings: SettingsDep) -> JobOut:
    name, scene = resolve_scene(req.scene)
    try:
        deltas = sweep_deltas(req.deltas.model_dump() if isinstance(req.deltas, DeltaRange) else req.deltas,
                              settings.max_frames)
        spec = JobSpec(name, scene, float(req.sigma), deltas, req.width, req.height,
                       req.tile or settings.default_tile, req.priority, req.method)
        job_id = create_job(settings, spec)
    except FarmBusy as exc:
        raise HTTPException(429, detail=str(exc)) from None
    except JobRefused as exc:
        raise HTTPException(422, detail=str(exc)) from None
    return _job(settings, job_id)


@router.get("")
def list_jobs(
    settings: SettingsDep,
    status: str | None = Query(None, description="|".join(JOB.states)),
    page: int = Query(1, ge=1, le=MAX_PAGE),
    per_page: int = Query(20, ge=1, le=200),
) -> JobPage:
    if status is not None and status not in JOB.states:
        raise HTTPException(422, detail=f"status must be one of {', '.join(JOB.states)}")
    with session_scope(settings.sqlalchemy_url) as s:
        q = select(Job).order_by(Job.created.desc())
        cq = select(func.count()).select_from(Job)
        if status:
            q, cq = q.where(Job.status == status), cq.where(Job.status == status)
        total = s.scalar(cq)
        rows = s.scalars(q.offset((page - 1) * per_page).limit(per_page)).all()
        return JobPage(total=total, page=page, per_page=per_page, jobs=[job_out(j) for j in rows])


@router.get("/{job_id}")
def get_job(job_id: str, settings: SettingsDep) -> JobOut:
    return _job(settings, job_id)


@router.post("/{job_id}/{action}")
def control(job_id: str, action: Literal[tuple(ACTIONS)], settings: SettingsDep) -> JobOut:
    set_job_status(settings, job_id, action)
    return _job(settings, job_id)


@router.patch("/{job_id}")
def patch(job_id: str, body: PriorityPatch, settings: SettingsDep) -> JobOut:
    """A new priority, in effect at once for the job's queued tiles."""
    set_priority(settings, job_id, body.priority)
    return _job(settings, job_id)


@router.delete("/{job_id}", status_code=204)
def delete(job_id: str, settings: SettingsDep) -> None:
    delete_job(settings, job_id)


def _progress(settings, job_id: str) -> dict | None:
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id)
        if job is None:
            return None
        view = job_out(job)
    payload = view.model_dump(include={"id", "status", "progress", "eta_s", "tiles_done", "tiles_total"})
    payload["frames"] = [{"index": f.index, "status": f.status} for f in view.frames]
    return payload


@router.get("/{job_id}/events")
async def events(job_id: JobIdDep, settings: SettingsDep):
    """Server-sent events: the job's progress until it ends."""

    async def stream():
        last = None
        while True:
            payload = _progress(settings, job_id)
            if payload is None:
                yield "event: deleted\ndata: {}\n\n"
                return
            if payload != last:
                yield f"event: progress\ndata: {json.dumps(payload)}\n\n"
                last = payload
            if payload["status"] in ENDED:
                yield f"event: end\ndata: {json.dumps({'status': payload['status']})}\n\n"
                return
            await asyncio.sleep(0.5)

    return StreamingResponse(stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"})
