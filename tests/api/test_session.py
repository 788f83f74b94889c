"""A request's database session (argand.api.deps.SessionDep): one per
request, shared by the route and its dependencies (the job a path names),
committed before the response is sent and rolled back when the route
raises; the farm functions a route calls work in it (in_session). Real
parts: the app served over loopback, a real Redis and SQLite."""

from __future__ import annotations

import httpx
import pytest
from fastapi import HTTPException
from sqlalchemy import select

from tests.farm.test_work import farm_parts, submit  # noqa: F401  (the fixture)
from tests.helpers.served import served

from argand.api.deps import JobIdDep, SessionDep
from argand.farm.database import in_session, session_scope
from argand.farm.models import Job


def priority_of(settings, job_id: str) -> int:
    with session_scope(settings.sqlalchemy_url) as s:
        return s.scalar(select(Job.priority).where(Job.id == job_id))


def test_one_session_per_request_committed_before_the_answer_or_rolled_back(farm_parts):  # noqa: F811
    from argand.api.app import create_app

    settings, _ = farm_parts
    job_id = submit(settings, "steiner", [0.0], 16, 16, 16)
    app = create_app(settings)
    shared: list[bool] = []
    reading: list[bool] = []

    @app.post("/probe/{job_id}")
    def probe(job_id: JobIdDep, s: SessionDep, again: SessionDep, priority: int, fail: bool = False) -> dict:
        reading.append(s.in_transaction())  # JobIdDep's check ended its read: no connection held
        s.get(Job, job_id).priority = priority
        s.flush()
        shared.append(s is again)
        if fail:
            raise HTTPException(409, detail="refused after the change")
        return {"ok": True}

    with served(app) as url, httpx.Client(base_url=url, timeout=30) as c:
        assert c.post(f"/probe/{job_id}", params={"priority": 8, "fail": True}).status_code == 409
        assert priority_of(settings, job_id) == 5  # rolled back
        assert c.post(f"/probe/{job_id}", params={"priority": 9}).status_code == 200
        assert priority_of(settings, job_id) == 9  # committed when the answer came
        assert c.post("/probe/nosuchjob", params={"priority": 1}).status_code == 404  # JobIdDep, same session
        # The routes call the farm in the request's session: a pause is visible at once.
        assert c.post(f"/api/jobs/{job_id}/pause").json()["status"] == "paused"
        assert c.get(f"/api/jobs/{job_id}").json()["status"] == "paused"
        assert c.patch(f"/api/jobs/{job_id}", json={"priority": 3}).json()["priority"] == 3
        assert priority_of(settings, job_id) == 3
        assert c.delete(f"/api/jobs/{job_id}").status_code == 204
        assert c.get(f"/api/jobs/{job_id}").status_code == 404
    assert shared == [True, True] and reading == [False, False]


def test_in_session_commits_a_callers_session_at_the_end_of_the_block(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    job_id = submit(settings, "steiner", [0.0], 16, 16, 16)
    with session_scope(settings.sqlalchemy_url) as mine:
        with in_session(settings.sqlalchemy_url, mine) as s:
            assert s is mine
            s.get(Job, job_id).priority = 7
        assert priority_of(settings, job_id) == 7  # committed at the block's end, before the caller's own end
        with pytest.raises(RuntimeError):
            with in_session(settings.sqlalchemy_url, mine) as s:
                s.get(Job, job_id).priority = 1
                raise RuntimeError("inside the block")
        mine.rollback()
    assert priority_of(settings, job_id) == 7
    with in_session(settings.sqlalchemy_url) as s:  # no session given: one of its own
        s.get(Job, job_id).priority = 2
    assert priority_of(settings, job_id) == 2
