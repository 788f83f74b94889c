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


def test_an_undeclared_method_is_a_405_that_lists_every_allowed_one(api):  # noqa: F811
    c, _settings, _ = api
    job_id = c.post("/api/jobs", json=JOB).json()["id"]
    r = c.post(f"/api/jobs/{job_id}/animation.gif")
    assert r.status_code == 405 and r.headers["allow"] == "GET, HEAD", (r.status_code, r.headers, r.text)
    r = c.options(f"/api/jobs/{job_id}")
    assert r.status_code == 405 and r.headers["allow"] == "DELETE, GET, HEAD, PATCH", r.headers
    assert c.put(f"/api/jobs/{job_id}/cancel").headers["allow"] == "POST"
    assert c.post(f"/api/jobs/{job_id}/explode").status_code == 422  # no such action (the actions named)
    assert c.post(f"/api/jobs/{job_id}/cancel").json()["status"] == "canceled"
    paths = c.get("/openapi.json").json()["paths"]
    assert {f"/api/jobs/{{job_id}}/{a}" for a in ("cancel", "pause", "resume", "retry")} <= set(paths)


def test_what_the_document_calls_valid_is_taken(api):  # noqa: F811
    """Found by schemathesis with every check: JSON Schema's integer 3.0,
    the nulls the document allows, the optional integers' bounds in the
    document, and an OPTIONS whose Allow names only the path's methods."""
    c, _settings, _ = api
    r = c.post("/api/jobs", json={**JOB, "width": 32.0, "priority": 3.0, "sigma": None, "sigmas": None, "delta": None,
                                  "deltas": None, "atlas": None, "samples": None})
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    assert c.patch(f"/api/jobs/{job_id}", json={"priority": 4.0}).json()["priority"] == 4
    assert c.post("/api/jobs", json={**JOB, "width": 32.5}).status_code == 422
    props = c.get("/openapi.json").json()["components"]["schemas"]["JobRequest"]["properties"]
    for name in ("atlas", "tile", "samples"):
        integer = props[name]["anyOf"][0]
        assert {"minimum", "maximum"} <= set(integer) and not {"ge", "le"} & set(integer), (name, integer)
    r = c.options(f"/api/jobs/{job_id}/animation.gif")
    assert r.status_code == 405 and r.headers["allow"] == "GET, HEAD", r.headers
