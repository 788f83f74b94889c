"""Access: with a token, every state-changing route needs
``Authorization: Bearer <token>`` (reads stay open); a non-loopback host
without a token refuses to start; the browser asks for the token once and
sends it as a header. Real uvicorn, Redis, SQLite, CLI processes and Chromium."""

from __future__ import annotations

import os
import subprocess
import sys

import httpx
import pytest
from pydantic import SecretStr

from tests.farm.test_farm import Farm
from tests.farm.test_limits import JOB, _serve
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)
from tests.web.test_web import page  # noqa: F401  (the fixture)

TOKEN = "tok-3f9a1c77e2"


def _client(settings):
    server, thread, url = _serve(settings)
    return server, thread, httpx.Client(base_url=url, timeout=60)


@pytest.mark.parametrize("source", ["setting", "file"])
def test_state_changing_routes_need_the_token_and_reads_do_not(farm_parts, tmp_path, source):  # noqa: F811
    settings, _ = farm_parts
    if source == "setting":
        settings = settings.model_copy(update={"api_token": SecretStr(TOKEN)})
    else:
        (tmp_path / "token").write_text(TOKEN + "\n")
        settings = settings.model_copy(update={"api_token_file": tmp_path / "token"})
    server, thread, c = _client(settings)
    try:
        r = c.post("/api/jobs", json=JOB)
        assert r.status_code == 401 and "Authorization: Bearer" in r.json()["detail"]
        assert r.headers["www-authenticate"] == "Bearer"
        r = c.post("/api/jobs", json=JOB, headers={"Authorization": "Bearer wrong"})
        assert r.status_code == 401 and r.json()["detail"] == "the API token is wrong" and TOKEN not in r.text
        r = c.post("/api/jobs", json=JOB, headers={"Cookie": f"token={TOKEN}", "Origin": "http://evil.example"})
        assert r.status_code == 401  # a cookie is no credential: a cross-site request cannot act
        auth = {"Authorization": f"Bearer {TOKEN}"}
        r = c.post("/api/jobs", json=JOB, headers=auth)
        assert r.status_code == 201, r.text
        job_id = r.json()["id"]
        assert c.get(f"/api/jobs/{job_id}").status_code == 200 and c.get("/api/jobs").json()["total"] == 1
        for method, path, body in (("POST", f"/api/jobs/{job_id}/pause", None), ("PATCH", f"/api/jobs/{job_id}", {"priority": 2}),
                                   ("DELETE", f"/api/jobs/{job_id}", None)):
            assert c.request(method, path, json=body).status_code == 401, (method, path)
        assert c.get(f"/api/jobs/{job_id}").json()["status"] == "queued"
        assert c.post(f"/api/jobs/{job_id}/cancel", headers=auth).json()["status"] == "canceled"
        assert c.delete(f"/api/jobs/{job_id}", headers=auth).status_code == 204
        doc = c.get("/openapi.json").json()
        assert doc["components"]["securitySchemes"]["bearer"]["scheme"] == "bearer"
        assert doc["paths"]["/api/jobs"]["post"]["security"] == [{"bearer": []}] and "security" not in doc["paths"]["/api/jobs"]["get"]
    finally:
        c.close()
        server.should_exit = True
        thread.join(10)


def test_without_a_token_the_loopback_farm_is_open(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    server, thread, c = _client(settings)
    try:
        assert c.post("/api/jobs", json=JOB).status_code == 201
    finally:
        c.close()
        server.should_exit = True
        thread.join(10)


@pytest.mark.parametrize("command", ["api", "serve"])
def test_a_public_host_without_a_token_refuses_to_start(tmp_path, command):
    env = {k: v for k, v in os.environ.items() if not k.startswith("ARGAND_")}
    env.update(ARGAND_REDIS_URL="redis://127.0.0.1:1/0", COLUMNS="200")
    r = subprocess.run([sys.executable, "-m", "argand.cli", command, "--host", "0.0.0.0", "--port", "1",
                        "--data", str(tmp_path / "data")], env=env, capture_output=True, text=True, timeout=60)
    out = " ".join((r.stdout + r.stderr).split())
    assert r.returncode == 2 and "no API token is set" in out and "ARGAND_API_TOKEN" in out, out
    assert not (tmp_path / "data").exists()  # nothing was started


@pytest.fixture
def farm(tmp_path):
    """A farm with a token and no worker (the page fixture's farm)."""
    f = Farm(tmp_path / "data", workers=0, ARGAND_API_TOKEN=TOKEN).start()
    yield f
    f.stop()


def test_the_browser_asks_for_the_token_once_and_sends_it_as_a_header(farm, page):  # noqa: F811
    asked: list[str] = []

    def answer(dialog):
        asked.append(dialog.message)
        dialog.accept(TOKEN)
    page.on("dialog", answer)
    sent: list[str | None] = []
    page.on("request", lambda req: sent.append(req.headers.get("authorization")) if req.method == "POST" else None)
    page.goto(farm.url + "/#/new")
    page.click("[data-preset=whitney]")
    page.fill("#width", "32")
    page.fill("#height", "32")
    page.fill("#count", "1")
    page.click("#submit")
    page.wait_for_url("**/#/job/*")
    assert len(asked) == 1 and "API token" in asked[0]
    assert page.evaluate("sessionStorage.getItem('argand-api-token')") == TOKEN
    assert page.evaluate("document.cookie") == ""
    assert f"Bearer {TOKEN}" in sent
    assert farm.get("/api/jobs")["total"] == 1
    page.goto(farm.url + "/#/new")  # a second submission: no second question
    page.click("[data-preset=whitney]")
    page.fill("#width", "32")
    page.fill("#height", "32")
    page.fill("#count", "1")
    page.click("#submit")
    page.wait_for_function("location.hash.startsWith('#/job/')")
    page.wait_for_function("fetch('/api/jobs').then(r => r.json()).then(j => j.total === 2)")
    assert len(asked) == 1
