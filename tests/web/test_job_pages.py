"""The job pages in Chromium in every job state (queued, running, paused,
canceled, failed, done), against the API in process on a real SQLite file
and a real embedded Redis, the tiles rendered by the worker's own functions
(argand.farm.tile_work) so that each state is reached exactly: the state,
the progress text (an ETA only while running), which actions are enabled
and that the disabled ones look it, the finished frames' downloads
whatever the state; delete, an unknown job's page and its way back; and
/docs (Swagger UI) rendering its operations with every request off the
app's origin aborted. A screenshot of each page in each state goes to
build/screenshots/states/."""

from __future__ import annotations

import httpx
import pytest

from argand.farm import tile_work
from tests.api.test_api import _served
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)
from tests.web.browser import chromium_page, shot

WORKER = "w-pages"


@pytest.fixture
def site(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    with _served(farm_parts) as (c, _, _app):
        yield settings, c, str(c.base_url).rstrip("/")


def _style(page, selector: str) -> dict:
    return page.evaluate("sel => { const s = getComputedStyle(document.querySelector(sel)); "
                         "return {opacity: Number(s.opacity), cursor: s.cursor, border: s.borderStyle}; }", selector)


def _check_job_page(page, c: httpx.Client, url: str, job_id: str, status: str) -> None:
    job = c.get(f"/api/jobs/{job_id}").json()
    meta = c.get("/api/meta").json()
    assert job["status"] == status
    page.goto(f"{url}/#/job/{job_id}")
    page.wait_for_function(f"document.querySelector('#status')?.textContent === '{status}'", timeout=30_000)
    page.wait_for_function("[...document.querySelectorAll('#grid .cell img')].every(i => i.complete && i.naturalWidth > 0)")
    text = page.text_content("#progress-text")
    assert ("left" in text) == (status == "running"), (status, text)
    assert text.startswith({"queued": "queued", "paused": "paused at", "canceled": "canceled at", "failed": "failed at",
                            "done": "done", "running": f"{job['tiles_done']}/{job['tiles_total']} tiles"}[status]), text
    assert status != "failed" or job["error"] in text, text
    assert text.endswith({"paused": "(resume or retry to go on)", "canceled": "(retry to go on)",
                          "failed": "(retry to go on)"}.get(status, "")), text
    # Each action is enabled only where it applies, and a disabled one looks disabled.
    for action, applies in meta["actions"].items():
        button = f"#actions button[data-action={action}]"
        disabled = page.is_disabled(button)
        assert disabled == (status not in applies), (status, action)
        style = _style(page, button)
        if disabled:
            assert style["opacity"] < 0.5 and style["cursor"] == "not-allowed" and style["border"] == "dashed", style
        else:
            assert style["opacity"] == 1 and style["cursor"] == "pointer", style
    assert page.is_enabled("#actions button[data-delete]")
    # The finished frames are listed for download whatever the job's state.
    done = [f for f in job["frames"] if f["status"] == "done"]
    links = page.eval_on_selector_all("#downloads a[href$='.png']", "as => as.map(a => a.getAttribute('href'))")
    assert links == [f["png_url"] for f in done], (status, links)
    if not done:
        assert page.text_content("#downloads") == "No frame is done yet."
    cells = page.eval_on_selector_all("#grid .cell", "cs => cs.map(c => c.textContent.trim())")
    assert [t for t, f in zip(cells, job["frames"]) if f["status"] != "done"] == \
        [f["status"] for f in job["frames"] if f["status"] != "done"]
    shot(page, f"states/{status}-job")
    # The list: the same job, an ETA only while it runs.
    page.goto(f"{url}/#/jobs")
    page.wait_for_selector(f"tr[data-job='{job_id}'] .badge.{status}")
    eta = page.text_content(f"tr[data-job='{job_id}'] td:nth-child(6)")
    assert (eta.endswith(" s") if status == "running" else eta == "—"), (status, eta)
    for action, applies in meta["actions"].items():
        assert page.is_disabled(f"tr[data-job='{job_id}'] button[data-action={action}]") == (status not in applies)
    shot(page, f"states/{status}-jobs")
    assert not page.errors, page.errors


def test_every_job_page_in_every_state(site):
    settings, c, url = site
    r = c.post("/api/jobs", json={"scene": "plucker", "deltas": {"start": 0, "stop": "pi/9", "count": 3},
                                  "width": 64, "height": 64, "tile": 32})
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    with chromium_page() as page:
        page.on("dialog", lambda d: d.accept())
        _check_job_page(page, c, url, job_id, "queued")
        assert tile_work.run_tiles(settings, job_id, 0, [0, 1, 2, 3], WORKER) == "rendered"
        assert tile_work.run_tiles(settings, job_id, 1, [0, 1], WORKER) == "rendered"
        _check_job_page(page, c, url, job_id, "running")
        assert c.post(f"/api/jobs/{job_id}/pause").json()["status"] == "paused"
        _check_job_page(page, c, url, job_id, "paused")
        # Resume from the page itself: the buttons follow the state.
        page.goto(f"{url}/#/job/{job_id}")
        page.click("#actions button[data-action=resume]")
        page.wait_for_function("document.querySelector('#status')?.textContent === 'running'")
        page.wait_for_function("document.querySelector('#actions button[data-action=resume]').disabled")
        page.click("#actions button[data-action=cancel]")
        page.wait_for_function("document.querySelector('#status')?.textContent === 'canceled'")
        _check_job_page(page, c, url, job_id, "canceled")
        assert c.post(f"/api/jobs/{job_id}/retry").json()["status"] == "running"
        for _ in range(settings.max_tile_attempts):
            why, claimed = tile_work.claim(settings, job_id, 2, [3], WORKER, None)
            assert why is None
            tile_work.release(settings, job_id, 2, WORKER, claimed, resend=True, reason="RuntimeError: broken")
        _check_job_page(page, c, url, job_id, "failed")
        assert c.post(f"/api/jobs/{job_id}/retry").json()["status"] == "running"
        for frame in (1, 2):
            assert tile_work.run_tiles(settings, job_id, frame, [0, 1, 2, 3], WORKER) == "rendered"
        _check_job_page(page, c, url, job_id, "done")
        # Delete from the job page: back to the list, the job gone.
        page.goto(f"{url}/#/job/{job_id}")
        page.wait_for_selector("#actions button[data-delete]")
        page.click("#actions button[data-delete]")
        page.wait_for_url("**/#/jobs")
        assert c.get(f"/api/jobs/{job_id}").status_code == 404
        assert not page.errors, page.errors
        # An unknown job: what happened, and a way back (the browser logs the API's 404).
        page.goto(f"{url}/#/job/{job_id}")
        page.wait_for_selector("#back")
        assert page.text_content("h1") == "Job not found" and job_id in page.text_content("#job-error")
        shot(page, "states/unknown-job")
        page.click("#back")
        page.wait_for_url("**/#/jobs")
        page.wait_for_selector("#table")
        assert page.errors == ["Failed to load resource: the server responded with a status of 404 (Not Found)"], page.errors


def test_the_api_page_renders_offline(site):
    """/docs: Swagger UI's files come from the app itself; with every request
    elsewhere aborted, its operations render and nothing tried to leave."""
    _, c, url = site
    html = c.get("/docs").text
    assert "cdn" not in html.lower() and "/docs-assets/swagger-ui-bundle.js" in html
    with chromium_page(offline_except=url) as page:
        page.goto(f"{url}/docs")
        page.wait_for_selector(".opblock", timeout=30_000)
        paths = page.eval_on_selector_all(".opblock-summary-path", "ps => ps.map(p => p.textContent.replace(/\\u200b/g, ''))")
        assert "/api/jobs" in paths and "/api/jobs/{job_id}" in paths, paths
        assert len(paths) >= 10
        shot(page, "api-docs")
        assert page.blocked == [] and not page.errors, (page.blocked, page.errors)


def test_the_icon_is_served(site):
    _, c, _ = site
    r = c.get("/favicon.ico")
    assert r.status_code == 200 and r.headers["content-type"] == "image/x-icon" and r.content[:4] == b"\0\0\1\0"
