"""The API's contract, as its OpenAPI document states it: integers are JSON
integers (not true, not "512"), a scene's name is not empty, a job's status
filter is one of the states (an enum in the document), and a body that is
not JSON is a 400, documented. Real uvicorn, Redis and SQLite."""

from __future__ import annotations

from tests.farm.test_limits import JOB, api  # noqa: F401  (the fixture)
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)


def test_integers_are_strict_and_a_scene_name_is_not_empty(api):  # noqa: F811
    c, _settings, _ = api
    for body in ({**JOB, "width": True}, {**JOB, "width": "512"}, {**JOB, "priority": False},
                 {**JOB, "deltas": {"start": 0, "stop": 1, "count": True}}, {**JOB, "tile": 16.5},
                 {**JOB, "scene": ""}, {**JOB, "scene": "   "}):
        r = c.post("/api/jobs", json=body)
        assert r.status_code == 422, (body, r.status_code, r.text)
    assert c.patch("/api/jobs/0123456789ab", json={"priority": True}).status_code == 422
    assert c.get("/api/jobs").json()["total"] == 0
    assert c.post("/api/jobs", json=JOB).status_code == 201  # the same job with integers is taken


def test_an_unparsable_body_is_a_400_and_the_status_filter_is_an_enum(api):  # noqa: F811
    c, _settings, _ = api
    r = c.post("/api/jobs", content=b'{"scene": "plucker",', headers={"content-type": "application/json"})
    assert r.status_code == 400 and "not valid JSON" in r.json()["detail"], r.text
    assert c.get("/api/jobs", params={"status": ""}).status_code == 422
    assert c.get("/api/jobs", params={"status": "done"}).status_code == 200
    schema = c.get("/openapi.json").json()
    [status] = [p for p in schema["paths"]["/api/jobs"]["get"]["parameters"] if p["name"] == "status"]
    enum = status["schema"]["anyOf"][0]["enum"]
    assert "done" in enum and "" not in enum
    assert "400" in schema["paths"]["/api/jobs"]["post"]["responses"]
