"""The web front end in a real browser (Debian's Chromium through Playwright)
against a real two-worker farm: submit through the form, watch progress
reach 100%, play, scrub, switch channel, download the GIF; an invalid
expression shows its error and submits nothing. Screenshots of each page go
to build/screenshots/ (tests.web.browser.SHOTS; `make screenshots` copies
those the docs show into docs/screenshots/)."""

from __future__ import annotations

import httpx
import pytest

from tests.farm.test_farm import Farm
from tests.web.browser import REPO, chromium_page, shot


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("web") / "data").start()
    yield f
    f.stop()


@pytest.fixture
def page(farm):
    with chromium_page() as pg:
        yield pg


def test_invalid_expression_shows_its_error_and_submits_nothing(farm, page):
    page.goto(farm.url + "/#/new")
    page.wait_for_selector(".preset")
    page.fill("#surface", "x^2 + w")
    page.wait_for_function("document.querySelector('#surface-msg')?.textContent.includes('unknown name')")
    assert "column 7" in page.text_content("#surface-msg")
    page.click("#submit")
    page.wait_for_function("document.querySelector('#form-msg')?.textContent.length > 0")
    assert farm.get("/api/jobs")["total"] == 0
    page.fill("#surface", "x^2*z + y^2")
    page.wait_for_function("document.querySelector('#surface-msg')?.textContent === 'degree 3'")
    # Every preset's thumbnail is rendered on its first request: wait for all
    # of them, so the gallery (and its screenshot) shows every surface.
    page.wait_for_function(
        "[...document.querySelectorAll('.preset img')].every(i => i.complete && i.naturalWidth > 0)", timeout=120_000
    )
    shot(page, "new-job")
    assert not page.errors, page.errors


def test_submit_watch_play_scrub_channel_download(farm, page, tmp_path):
    page.goto(farm.url + "/#/new")
    page.click("[data-preset=whitney]")
    page.fill("#count", "6")
    page.fill("#width", "96")
    page.fill("#height", "96")
    page.fill("#tile", "32")
    page.select_option("#samples", "4")  # the choices come from /api/meta's limits
    page.click("#submit")
    page.wait_for_url("**/#/job/*")
    page.wait_for_function("document.querySelector('#status')?.textContent === 'done'", timeout=120_000)
    assert page.get_attribute("#progress > span", "style").replace(" ", "") == "width:100%;"
    # Play: the shown frame changes.
    first = page.get_attribute("#canvas", "data-frame")
    page.click("#play")
    page.wait_for_function(f"document.querySelector('#canvas')?.dataset?.frame !== '{first}'", timeout=10_000)
    page.click("#play")
    # Scrub to the fourth frame: the label shows its delta.
    job_id = page.url.rsplit("/", 1)[1]
    job = farm.get(f"/api/jobs/{job_id}")
    assert job["scene"]["samples"] == 4 and job["frames"][0]["figures"]["samples"] == 4
    page.eval_on_selector("#scrub", "(el) => { el.value = 3; el.dispatchEvent(new Event('input')); }")
    assert job["delta_labels"][3] == "π/15" and "δ = π/15, σ = 0" in page.text_content("#scrub-label")
    page.wait_for_function("document.querySelector('#canvas')?.dataset?.drawn === 'beauty/3'")
    assert page.is_hidden("#scrub-sigma") and page.is_hidden("#play-axis")  # one σ: δ only
    shot(page, "job")
    # The status channel.
    page.select_option("#channel", "status")
    page.wait_for_function("document.querySelector('#canvas')?.dataset?.drawn === 'status/3'")
    assert page.is_visible("#legend")
    assert "dark: no surface" in page.text_content("#legend")  # the background's pixels are explained too
    shot(page, "job-status-channel")
    # The share of certified samples per pixel.
    page.select_option("#channel", "certified_share")
    page.wait_for_function("document.querySelector('#canvas')?.dataset?.drawn === 'certified_share/3'")
    page.select_option("#channel", "status")
    page.wait_for_function("document.querySelector('#canvas')?.dataset?.drawn === 'status/3'")
    # Keyboard: right arrow steps one frame.
    page.keyboard.press("ArrowRight")
    assert page.get_attribute("#canvas", "data-frame") == "4"
    # Download the GIF.
    with page.expect_download() as info:
        page.click("#gif")
    path = tmp_path / "animation.gif"
    info.value.save_as(path)
    assert path.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    # The jobs table and the workers page.
    page.goto(farm.url + "/#/jobs")
    page.wait_for_selector(f"tr[data-job='{job_id}']")
    shot(page, "jobs")
    page.goto(farm.url + "/#/workers")
    page.wait_for_selector("#w table")
    assert page.locator("#w tbody tr").count() == 2
    shot(page, "workers")
    # Compare two frames of the job, then under a slider.
    page.goto(farm.url + f"/#/compare?a={job_id}:0&b={job_id}:5")
    page.wait_for_selector("#img-b")
    assert page.get_attribute("#img-a", "src").endswith(f"/api/jobs/{job_id}/frames/0.png")
    assert page.get_attribute("#img-b", "src").endswith(f"/api/jobs/{job_id}/frames/5.png")
    page.select_option("#cmp-mode", "slider")
    page.eval_on_selector("#cmp-split", "(el) => { el.value = 30; el.dispatchEvent(new Event('input')); }")
    assert "30%" in page.get_attribute("#img-b", "style")
    page.wait_for_function("document.querySelector('#img-b')?.complete")
    shot(page, "compare")
    assert not page.errors, page.errors


def test_a_grid_job_plays_along_both_axes_and_its_atlas_opens_frames(farm, page, tmp_path):
    """A 3 σ x 4 δ grid through the form: the δ and σ sliders and the arrow
    keys move along the two axes, play runs along the chosen one, the atlas
    lays the thumbnails out by (σ, δ) and a click opens that frame, the
    player shows the MP4, and the downloads list GIF, WebP, MP4 and atlas.png."""
    page.goto(farm.url + "/#/new")
    page.click("[data-preset=whitney]")
    page.fill("#sigma", "0")
    page.fill("#sigma-stop", "pi/12")
    page.fill("#sigma-count", "3")
    page.fill("#start", "pi/36")
    page.fill("#stop", "pi/9")
    page.fill("#count", "4")
    for field, value in (("#width", "96"), ("#height", "96"), ("#tile", "48")):
        page.fill(field, value)
    page.click("#submit")
    page.wait_for_url("**/#/job/*")
    page.wait_for_function("document.querySelector('#status')?.textContent === 'done'", timeout=180_000)
    job = farm.get(f"/api/jobs/{page.url.rsplit('/', 1)[1]}")
    assert len(job["sigmas"]) == 3 and len(job["deltas"]) == 4
    at = {(f["sigma_index"], f["delta_index"]): f for f in job["frames"]}
    frame = lambda: int(page.get_attribute("#canvas", "data-frame"))  # noqa: E731
    # The atlas: a cell per frame at its row and column, every thumbnail loaded.
    page.wait_for_function("[...document.querySelectorAll('#grid.atlas .cell img')].length === 12 && "
                           "[...document.querySelectorAll('#grid .cell img')].every(i => i.complete && i.naturalWidth > 0)")
    assert page.locator("#grid .axis").count() == 3 + 4
    assert page.is_visible("#scrub") and page.is_visible("#scrub-sigma") and page.is_visible("#play-axis")
    # The σ slider moves down the current column, the δ slider along the row.
    page.eval_on_selector("#scrub-sigma", "(el) => { el.value = 2; el.dispatchEvent(new Event('input')); }")
    assert frame() == at[(2, 0)]["index"]
    page.eval_on_selector("#scrub", "(el) => { el.value = 3; el.dispatchEvent(new Event('input')); }")
    assert frame() == at[(2, 3)]["index"]
    assert (job["sigma_labels"], job["delta_labels"]) == (["0", "π/24", "π/12"], ["π/36", "π/18", "π/12", "π/9"])
    assert "δ = π/9, σ = π/12" in page.text_content("#scrub-label")
    assert [page.text_content(f"#grid .axis >> nth={i}") for i in range(7)] == job["delta_labels"] + job["sigma_labels"]
    # Arrow keys: up and down for σ, left and right for δ (wrapping).
    page.keyboard.press("ArrowUp")
    assert frame() == at[(1, 3)]["index"]
    page.keyboard.press("ArrowLeft")
    assert frame() == at[(1, 2)]["index"]
    page.keyboard.press("ArrowDown")
    page.keyboard.press("ArrowDown")
    assert frame() == at[(0, 2)]["index"]
    assert page.eval_on_selector("#scrub-sigma", "el => el.value") == "0"
    # Play along σ: the frame changes, the column stays.
    page.select_option("#play-axis", "sigma")
    page.click("#play")
    page.wait_for_function(f"document.querySelector('#canvas').dataset.frame !== '{at[(0, 2)]['index']}'", timeout=10_000)
    page.click("#play")
    assert job["frames"][frame()]["delta_index"] == 2
    # A click on the atlas opens that frame.
    page.click(f"#grid .cell[data-sigma-index='1'][data-delta-index='3']")
    assert frame() == at[(1, 3)]["index"]
    page.wait_for_function(f"document.querySelector('#canvas')?.dataset?.drawn === 'beauty/{at[(1, 3)]['index']}'")
    shot(page, "job-atlas")
    # The downloads: the three animations and the atlas, each served.
    for link, kind in (("#gif", "image/gif"), ("#webp", "image/webp"), ("#mp4", "video/mp4"), ("#atlas-png", "image/png")):
        r = httpx.get(farm.url + page.get_attribute(link, "href"), timeout=120)
        assert r.status_code == 200 and r.headers["content-type"] == kind, (link, r.status_code)
    # The player shows the MP4: the browser decodes it to the frame's size.
    page.click("#show-mp4")
    page.wait_for_function("document.querySelector('#video').readyState >= 2", timeout=30_000)
    assert page.eval_on_selector("#video", "v => [v.videoWidth, v.videoHeight]") == [96, 96]
    assert page.is_hidden("#canvas")
    page.click("#show-mp4")
    assert page.is_visible("#canvas") and page.is_hidden("#video")
    # The form's atlas: the whole space on a triangle of 3 steps (6 frames).
    page.goto(farm.url + "/#/new")
    page.click("[data-preset=whitney]")
    page.check("#atlas")
    page.fill("#atlas-steps", "3")
    for field, value in (("#width", "32"), ("#height", "32"), ("#tile", "32")):
        page.fill(field, value)
    page.click("#submit")
    page.wait_for_url("**/#/job/*")
    page.wait_for_function("document.querySelector('#status')?.textContent === 'done'", timeout=120_000)
    atlas = farm.get(f"/api/jobs/{page.url.rsplit('/', 1)[1]}")
    assert len(atlas["frames"]) == 6 and len(atlas["sigmas"]) == len(atlas["deltas"]) == 3
    assert page.locator("#grid.atlas .cell").count() == 6
    # The same atlas cut where the roots are: the API's cuts for the scene.
    page.goto(farm.url + "/#/new")
    page.click("[data-preset=whitney]")
    page.check("#atlas")
    page.check("#atlas-roots")
    page.fill("#atlas-steps", "3")
    for field, value in (("#width", "32"), ("#height", "32"), ("#tile", "32")):
        page.fill(field, value)
    page.click("#submit")
    page.wait_for_url("**/#/job/*")
    roots = farm.get(f"/api/jobs/{page.url.rsplit('/', 1)[1]}")
    from argand.frames.frame_set import root_atlas_cuts
    from argand.render.convert import to_core_scene
    from argand.scene import load_scene
    cuts = root_atlas_cuts(to_core_scene(load_scene("whitney")), 32, 32, 3)
    assert list(roots["sigmas"]) == cuts[:-1] and len(roots["frames"]) == 6
    assert not page.errors, page.errors


def test_static_files_are_served_by_the_api(farm):
    for path in ("/", "/static/app.js", "/static/style.css"):
        r = httpx.get(farm.url + path)
        assert r.status_code == 200
    assert "cdn" not in httpx.get(farm.url + "/").text.lower()


def test_the_front_end_reads_the_farms_definitions_from_api_meta(farm):
    """/api/meta serves each definition from where it is defined, and the
    front end keeps no copy of them."""
    from argand.core import METHODS
    from argand.farm.previews import PREVIEW_CHANNELS, STATUS_COLOURS
    from argand.farm.states import ACTIONS, JOB
    from argand.render.frames import STATUS_NAMES

    meta = farm.get("/api/meta")
    assert meta["job_states"] == list(JOB.states) and meta["methods"] == list(METHODS)
    assert set(meta["actions"]) == set(ACTIONS) and meta["channels"] == list(PREVIEW_CHANNELS)
    assert [(p["code"], p["name"]) for p in meta["pixel_statuses"]] == sorted(STATUS_NAMES.items())
    assert [p["colour"] for p in meta["pixel_statuses"]] == ["#%02x%02x%02x" % STATUS_COLOURS[n] for n in STATUS_NAMES.values()]
    from argand.farm.previews import EMPTY

    assert meta["status_empty"]["colour"] == "#%02x%02x%02x" % EMPTY
    assert meta["limits"]["max_width"] == 4096 and meta["defaults"]["tile"] == 64
    from argand.render.frames import MAX_SAMPLES

    assert meta["limits"]["max_samples"] == MAX_SAMPLES and meta["limits"]["samples"][-1] == MAX_SAMPLES
    assert meta["defaults"]["samples"] == 1
    app_js = (REPO / "src" / "argand" / "web" / "app.js").read_text()
    for p in meta["pixel_statuses"]:
        assert p["colour"] not in app_js and f'"{p["name"]}"' not in app_js
    assert '"paused"' not in app_js and '"retry"' not in app_js and "4096" not in app_js
