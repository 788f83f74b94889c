"""The job page's "Any band" panel in Chromium against a real two-worker
farm: the σ and δ sliders move over the whole band rule (δ clamped to
π - σ), the picture follows with certified bands from the band route
(latest wins while a band is on its way), the histogram of the roots'
arguments is drawn. Scrubbing a 512x512 job for a few seconds: how many
bands per second the page shows is measured and written to
build/screenshots/bands-scrub.json (docs/web.md quotes it)."""

from __future__ import annotations

import io
import json
import time

import httpx
import numpy as np
import pytest
from PIL import Image

from tests.farm.test_farm import Farm
from tests.web.browser import SHOTS, chromium_page, shot

SIDE = 512


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("bands-web") / "data").start()
    yield f
    f.stop()


def _done_job(farm, scene: str, side: int) -> str:
    r = httpx.post(farm.url + "/api/jobs", json={"scene": scene, "deltas": [0, "pi/9"], "width": side,
                                                 "height": side}, timeout=30)
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    deadline = time.monotonic() + 180
    while farm.get(f"/api/jobs/{job_id}")["status"] != "done":
        assert time.monotonic() < deadline, "the job did not finish"
        time.sleep(0.2)
    return job_id


def _canvas_pixels(page, selector: str) -> np.ndarray:
    data = page.evaluate(f"""() => {{ const c = document.querySelector('{selector}');
        return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }}""")
    w, h = page.evaluate(f"() => [document.querySelector('{selector}').width, document.querySelector('{selector}').height]")
    return np.array(data, np.uint8).reshape(h, w, 4)


def test_the_sliders_show_any_band_and_follow_a_scrub(farm):
    job_id = _done_job(farm, "whitney", 96)
    with chromium_page() as page:
        page.goto(f"{farm.url}/#/job/{job_id}")
        page.wait_for_selector("#band-canvas")
        page.wait_for_function("document.querySelector('#band-canvas')?.dataset?.band")
        # σ = π/4 (180 of 720 steps), δ = π/2: the picture is the band route's, pixel for pixel.
        page.eval_on_selector("#band-sigma", "(el) => { el.value = 180; el.dispatchEvent(new Event('input')); }")
        page.eval_on_selector("#band-delta", "(el) => { el.value = 360; el.dispatchEvent(new Event('input')); }")
        want = f"{np.pi / 4}/{np.pi / 2}"
        page.wait_for_function(f"document.querySelector('#band-canvas').dataset.band === '{want}'", timeout=30_000)
        assert "σ = π/4, δ = π/2" in page.text_content("#band-label")
        png = httpx.get(f"{farm.url}/api/jobs/{job_id}/band.png", params={"sigma": repr(np.pi / 4),
                                                                           "delta": repr(np.pi / 2)}).content
        expected = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
        assert np.array_equal(_canvas_pixels(page, "#band-canvas"), expected)
        # The band rule: σ = 3π/4 clamps δ to π/4 at most.
        page.eval_on_selector("#band-sigma", "(el) => { el.value = 540; el.dispatchEvent(new Event('input')); }")
        assert page.eval_on_selector("#band-delta", "(el) => Number(el.value)") == 180
        page.wait_for_function("document.querySelector('#band-figures')?.textContent.includes('certified')")
        # The histogram of the roots' arguments is drawn (some non-background pixel).
        page.wait_for_function("""() => { const c = document.querySelector('#band-arguments');
            return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data).some((v) => v > 0); }""")
        shot(page, "job-bands")
        assert not page.errors, page.errors


def test_the_atlas_where_the_roots_are_shows_bands_and_opens_them(farm):
    """The page's atlas cut where the roots are: the cuts the API gives,
    one thumbnail per band (the band route's picture), and a click shows
    that exact band in the main picture."""
    job_id = _done_job(farm, "steiner", 64)
    with chromium_page() as page:
        page.goto(f"{farm.url}/#/job/{job_id}")
        page.wait_for_function("document.querySelector('#root-atlas')?.dataset?.done === '6'", timeout=60_000)
        atlas = httpx.get(f"{farm.url}/api/jobs/{job_id}/arguments", params={"atlas": 6}).json()["atlas"]
        cells = page.eval_on_selector_all(".root-atlas-cell[data-band]", "(els) => els.map((e) => [e.dataset.band, e.dataset.loaded])")
        # (JavaScript's shortest round-trip text of the doubles: the same values.)
        assert [tuple(map(float, band.split("/"))) for band, _ in cells] == [tuple(b) for b in atlas["bands"]]
        assert all(loaded == "yes" for _, loaded in cells), cells
        # A thumbnail is the band route's PNG of its band.
        key = cells[2][0]
        s, d = atlas["bands"][2]
        thumb = page.evaluate(f"""async () => {{
            const img = document.querySelector('.root-atlas-cell[data-band="{key}"] img');
            const c = document.createElement('canvas'); c.width = img.naturalWidth; c.height = img.naturalHeight;
            c.getContext('2d').drawImage(img, 0, 0);
            return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }}""")
        png = httpx.get(f"{farm.url}/api/jobs/{job_id}/band.png", params={"sigma": repr(s), "delta": repr(d)}).content
        expected = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
        assert np.array_equal(np.array(thumb, np.uint8).reshape(expected.shape), expected)
        # A click shows that band (its exact values) above.
        page.click(f'.root-atlas-cell[data-band="{key}"]')
        page.wait_for_function(f"document.querySelector('#band-canvas').dataset.band === '{key}'", timeout=30_000)
        assert np.array_equal(_canvas_pixels(page, "#band-canvas"), expected)
        shot(page, "job-root-atlas")
        assert not page.errors, page.errors


def test_scrubbing_a_512_job_is_measured(farm):
    job_id = _done_job(farm, "bicube", SIDE)
    with chromium_page() as page:
        page.goto(f"{farm.url}/#/job/{job_id}")
        page.wait_for_function("document.querySelector('#band-canvas')?.dataset?.band", timeout=60_000)
        # Move δ one step every 16 ms for 4 s (a hand dragging the slider), counting the bands drawn.
        drawn = page.evaluate("""async () => {
            const c = document.querySelector('#band-canvas'), d = document.querySelector('#band-delta');
            const seen = new Set(); const start = performance.now(); let v = 0;
            while (performance.now() - start < 4000) {
                v = (v + 1) % 120; d.value = String(v); d.dispatchEvent(new Event('input'));
                await new Promise((r) => setTimeout(r, 16));
                seen.add(c.dataset.band);
            }
            await new Promise((r) => setTimeout(r, 1500));
            return {bands: seen.size, fps: Number(c.dataset.fps), last: c.dataset.band, value: Number(d.value),
                    expected: `${0}/${(Number(d.value) / 720) * Math.PI}`};
        }""")
        assert drawn["bands"] >= 8, drawn  # the picture followed the slider
        assert drawn["last"] == drawn["expected"]  # and ended on the band the slider shows
        SHOTS.mkdir(parents=True, exist_ok=True)
        (SHOTS / "bands-scrub.json").write_text(json.dumps({"size": SIDE, **drawn}, indent=2) + "\n")
        print(f"scrubbing a {SIDE}x{SIDE} job: {drawn['bands']} bands drawn in 4 s, {drawn['fps']:.1f} frames/s")
        assert not page.errors, page.errors
