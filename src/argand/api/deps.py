"""The routes' dependencies: the app's settings (given to create_app, kept on
app.state: tests pass their own), the request's database session and the
job a path names."""

from __future__ import annotations

from typing import Annotated, Iterator

from fastapi import Depends, HTTPException, Request
from sqlalchemy.orm import Session

from argand.farm.database import session_scope
from argand.farm.models import Job
from argand.farm.settings import Settings


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


SettingsDep = Annotated[Settings, Depends(get_settings)]


def get_session(settings: SettingsDep) -> Iterator[Session]:
    """One session per request (shared by the route and its dependencies),
    committed when the route returns, before the response is sent, and
    rolled back if it raises. Farm functions a route calls take it."""
    with session_scope(settings.sqlalchemy_url) as s:
        yield s


#: scope="function": the commit (or its error) comes before the response, never after a 2xx was sent.
SessionDep = Annotated[Session, Depends(get_session, scope="function")]


def job_or_404(s, job_id: str) -> Job:
    job = s.get(Job, job_id)
    if job is None:
        raise HTTPException(404, detail=f"no job {job_id!r}")
    return job


def require_job(job_id: str, s: SessionDep) -> str:
    """The path's job id, after a 404 if there is no such job. The check's
    read ends here, so a route that then serves or encodes a file holds no
    database connection meanwhile (the session starts another when used)."""
    job_or_404(s, job_id)
    s.commit()
    return job_id


JobIdDep = Annotated[str, Depends(require_job)]


def wake_drainer(request: Request) -> None:
    """After a change that wrote messages to the outbox: the app's drainer
    sends them now (without the request waiting for the broker)."""
    drainer = getattr(request.app.state, "drainer", None)
    if drainer is not None:
        drainer.wake.set()
