"""/api/jobs: submit, list, read, control, re-prioritise, delete, and follow a job."""

from __future__ import annotations

import asyncio
import json
from typing import Literal

from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import StreamingResponse
from sqlalchemy import case, func, select
from sqlalchemy.orm import Session, defer

from argand.api.methods import allowed_methods
from argand.api.deps import JobIdDep, SessionDep, SettingsDep, job_or_404, wake_drainer
from argand.api.request_limits import StreamSlots, client_key
from argand.api.schemas import FrameCounts, JobOut, JobPage, JobRequest, PriorityPatch, job_out, job_summary
from argand.farm.control import delete_job, set_job_status, set_priority
from argand.farm.database import session_scope
from argand.farm.models import Frame, Job
from argand.farm.progress import eta_seconds, jobs_progress
from argand.farm.states import ACTIONS, ENDED, JOB, shown_frame_status
from argand.farm.job_limits import MAX_PAGE
from argand.farm.submission import FarmBusy, JobRefused, JobSpec, StoreFull, create_job, job_frames
from argand.frames.frame_set import root_atlas_cuts
from argand.render.convert import to_core_scene
from argand.scene import Scene, SceneError, load_scene, scene_from_dict
from argand.scene.presets import PRESETS

router = APIRouter(prefix="/api/jobs", tags=["jobs"])
#: Seconds a client is told to wait when max_active_jobs are in flight (jobs end in seconds to minutes).
BUSY_RETRY_AFTER_S = 30


def resolve_scene(spec: str | dict) -> tuple[str, Scene]:
    """(name, validated scene) of a preset's name or a scene object; 422 if invalid."""
    try:
        if isinstance(spec, str):
            if spec not in PRESETS:
                raise SceneError(f"unknown preset {spec!r}; presets: {', '.join(PRESETS)}")
            return spec, load_scene(spec)
        return "custom", scene_from_dict(spec)
    except SceneError as exc:
        raise HTTPException(422, detail=str(exc)) from None


def _job(s: Session, job_id: str) -> JobOut:
    return job_out(job_or_404(s, job_id))


@router.post("", status_code=201, responses={413: {"description": "The body is above max_body_bytes"},
                                                 429: {"description": "max_active_jobs are in flight"},
                                                 507: {"description": "The data folder's free space is below min_free_bytes"}})
def submit(req: JobRequest, settings: SettingsDep, s: SessionDep, request: Request) -> JobOut:
    """A new job, stored with its messages in one transaction; the messages
    go to the broker from the outbox, so the answer does not wait on it (a
    job submitted while Redis is down runs once it is back)."""
    name, scene = resolve_scene(req.scene)
    if req.samples is not None:  # the job's scene carries its samples per pixel (checked by JobRequest)
        scene = scene.model_copy(update={"samples": req.samples})
    try:
        axes = req.axes()
        if req.atlas_layout == "roots":  # (the atlas's size is checked first: a refusal costs no solving)
            job_frames(settings.max_frames, **axes)
            axes["atlas_cuts"] = root_atlas_cuts(to_core_scene(scene), req.width, req.height, req.atlas)
        frames = job_frames(settings.max_frames, **axes)
        spec = JobSpec(name, scene, frames, req.width, req.height, req.tile or settings.default_tile, req.priority,
                       req.method)
        job_id = create_job(settings, spec, send=False, session=s)
    except FarmBusy as exc:
        raise HTTPException(429, detail=str(exc), headers={"Retry-After": str(BUSY_RETRY_AFTER_S)}) from None
    except StoreFull as exc:
        raise HTTPException(507, detail=str(exc)) from None
    except JobRefused as exc:
        raise HTTPException(422, detail=str(exc)) from None
    wake_drainer(request)
    return _job(s, job_id)


@router.get("")
def list_jobs(
    s: SessionDep,
    status: Literal[tuple(JOB.states)] | None = Query(None, description="Only the jobs in this state"),
    page: int = Query(1, ge=1, le=MAX_PAGE),
    per_page: int = Query(20, ge=1, le=200),
) -> JobPage:
    """Summaries, newest first: a job's frames are not listed (GET
    /api/jobs/{id}/frames pages through them), so a page's size and time do
    not grow with its jobs' frames."""
    # A fixed number of queries whatever the page holds: the jobs (their scene
    # JSON deferred), their progress in one aggregate, their frames' counts in another.
    q = select(Job).options(defer(Job.scene)).order_by(Job.created.desc())
    cq = select(func.count()).select_from(Job)
    if status:
        q, cq = q.where(Job.status == status), cq.where(Job.status == status)
    total = s.scalar(cq)
    rows = s.scalars(q.offset((page - 1) * per_page).limit(per_page)).all()
    ids = [j.id for j in rows]
    progress = jobs_progress(s, ids)
    counts = frame_counts(s, ids)
    return JobPage(total=total, page=page, per_page=per_page,
                   jobs=[job_summary(j, progress[j.id], counts.get(j.id, FrameCounts())) for j in rows])


def frame_counts(s, job_ids: list[str]) -> dict[str, FrameCounts]:
    """Each job's frames counted (in all, done, σ rows, δ columns, the first
    done) in one aggregate query over the frames' indexed columns."""
    if not job_ids:
        return {}
    done = Frame.status == "done"
    rows = s.execute(select(Frame.job_id, func.count(), func.sum(case((done, 1), else_=0)),
                            func.count(Frame.sigma_index.distinct()), func.count(Frame.delta_index.distinct()),
                            func.min(case((done, Frame.index), else_=None)))
                     .where(Frame.job_id.in_(job_ids)).group_by(Frame.job_id)).all()
    return {job_id: FrameCounts(int(n), int(d or 0), int(rs), int(cs), first) for job_id, n, d, rs, cs, first in rows}


@router.get("/{job_id}")
def get_job(job_id: str, s: SessionDep) -> JobOut:
    return _job(s, job_id)


def _control(action: str):
    """The route of one action (one path each, so that another method or an
    unknown name on a job's sub-path is a 404 or a 405, not a 422)."""

    def control(job_id: str, settings: SettingsDep, s: SessionDep, request: Request) -> JobOut:
        try:
            set_job_status(settings, job_id, action, send=False, session=s)
        except FarmBusy as exc:  # a retry of an ended job counts against max_active_jobs, as a submission does
            raise HTTPException(429, detail=str(exc), headers={"Retry-After": str(BUSY_RETRY_AFTER_S)}) from None
        wake_drainer(request)
        return _job(s, job_id)

    control.__name__ = f"{action}_job"
    control.__doc__ = f"{action.capitalize()} the job (states it applies to: {', '.join(ACTIONS[action][0])})."
    return control


for _action in ACTIONS:
    router.add_api_route(f"/{{job_id}}/{_action}", _control(_action), methods=["POST"],
                         responses={429: {"description": "A retry while max_active_jobs are in flight"}})


@router.post("/{job_id}/{action}", include_in_schema=False)
def unknown_action(job_id: str, action: str, request: Request) -> None:
    """A POST to a job's sub-path that is no action: a 405 where the path
    exists with other methods (animation.gif), else a 422 naming the actions."""
    if allowed_methods(request.app, request.url.path):
        raise HTTPException(405)  # its Allow: argand.api.app
    raise HTTPException(422, detail=f"action must be one of {', '.join(ACTIONS)}, not {action!r}")


@router.patch("/{job_id}")
def patch(job_id: str, body: PriorityPatch, settings: SettingsDep, s: SessionDep, request: Request) -> JobOut:
    """A new priority for the job's queued tiles: at once, or (after another
    change in the last 10 s) within 10 s; the same priority changes nothing."""
    set_priority(settings, job_id, body.priority, send=False, session=s)
    wake_drainer(request)
    return _job(s, job_id)


@router.delete("/{job_id}", status_code=204)
def delete(job_id: str, settings: SettingsDep, s: SessionDep) -> None:
    delete_job(settings, job_id, session=s)


#: Seconds between two polls of a followed job's progress.
POLL_S = 0.5
#: A stream whose job has not changed for this long gets an SSE comment, so
#: clients and proxies that time out idle reads keep the stream open.
KEEPALIVE_S = 15.0


def _progress(settings, job_id: str) -> dict | None:
    """The job's progress for its event stream, in three small queries (no frame
    objects, no figures); None once the job is gone."""
    with session_scope(settings.sqlalchemy_url) as s:
        job = s.get(Job, job_id, options=[defer(Job.scene)])
        if job is None:
            return None
        done, total = jobs_progress(s, [job_id])[job_id]
        frames = [{"index": i, "status": shown_frame_status(job.status, st)} for i, st in
                  s.execute(select(Frame.index, Frame.status).where(Frame.job_id == job_id).order_by(Frame.index))]
        return {"id": job.id, "status": job.status, "progress": done / total if total else 0.0,
                "eta_s": eta_seconds(job, done, total), "tiles_done": done, "tiles_total": total, "frames": frames}


class _Poller:
    """One poll of a job's progress every POLL_S, in the thread pool (never on the
    event loop), shared by every open stream of the job; it stops when the job
    ends or is gone, or when its last stream closes."""

    def __init__(self, pollers: dict, key, settings, job_id: str) -> None:
        self.pollers, self.key, self.settings, self.job_id = pollers, key, settings, job_id
        self.payload: dict | None = None
        self.version = 0
        self.streams = 0
        self.changed = asyncio.Condition()
        self.task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        try:
            while self.streams:
                payload = await run_in_threadpool(_progress, self.settings, self.job_id)
                if self.version == 0 or payload != self.payload:
                    self.payload, self.version = payload, self.version + 1
                    async with self.changed:
                        self.changed.notify_all()
                if payload is None or payload["status"] in ENDED:
                    return
                await asyncio.sleep(POLL_S)
        except Exception as exc:  # the database failed: the streams end with the reason, not wait for ever
            self.payload, self.version = {"error": f"{type(exc).__name__}: {exc}"}, self.version + 1
            async with self.changed:
                self.changed.notify_all()
        finally:
            if self.pollers.get(self.key) is self:
                del self.pollers[self.key]

    @classmethod
    def join(cls, pollers: dict, settings, job_id: str) -> "_Poller":
        key = (settings.sqlalchemy_url, job_id)
        poller = pollers.get(key)
        if poller is None or poller.task.done():
            poller = pollers[key] = cls(pollers, key, settings, job_id)
        poller.streams += 1
        return poller

    async def after(self, seen: int) -> tuple[int, dict | None]:
        """(version, payload) of the first payload newer than version ``seen``."""
        async with self.changed:
            await self.changed.wait_for(lambda: self.version > seen)
        return self.version, self.payload


class _SlotStream(StreamingResponse):
    """A stream that gives its slot back however it ends (even when the
    client leaves before the first byte, when the body never starts)."""

    def __init__(self, body, give_back, **kwargs) -> None:
        super().__init__(body, **kwargs)
        self.give_back = give_back

    async def __call__(self, scope, receive, send) -> None:
        try:
            await super().__call__(scope, receive, send)
        finally:
            self.give_back()


@router.get("/{job_id}/events", responses={429: {"description": "Too many event streams open (per client or in all)"}})
async def events(job_id: JobIdDep, settings: SettingsDep, request: Request):
    """Server-sent events: the job's progress until it ends. At most
    max_streams_per_client open streams per client (the API token's holder,
    or the address that connected: request_limits.client_key) and
    max_streams in all (a 429 beyond)."""
    state = request.app.state
    if not hasattr(state, "job_pollers"):
        state.job_pollers = {}  # (database, job id) -> _Poller, for this app's event loop
        state.stream_slots = StreamSlots(settings.max_streams_per_client, settings.max_streams)
    pollers = state.job_pollers
    give_back = state.stream_slots.take(client_key(request, settings.token()))

    async def stream():
        poller = _Poller.join(pollers, settings, job_id)  # when the response starts: left in `finally`
        seen = 0
        try:
            while True:
                try:
                    seen, payload = await asyncio.wait_for(poller.after(seen), KEEPALIVE_S)
                except asyncio.TimeoutError:
                    yield ": keep-alive\n\n"
                    continue
                if payload is None:
                    yield "event: deleted\ndata: {}\n\n"
                    return
                if "error" in payload:
                    yield f"event: error\ndata: {json.dumps(payload)}\n\n"
                    return
                yield f"event: progress\ndata: {json.dumps(payload)}\n\n"
                if payload["status"] in ENDED:
                    yield f"event: end\ndata: {json.dumps({'status': payload['status']})}\n\n"
                    return
        finally:
            poller.streams -= 1

    return _SlotStream(stream(), give_back, media_type="text/event-stream", headers={"Cache-Control": "no-cache"})
