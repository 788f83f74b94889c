"""The job page's player in Chromium at 1280x900 against a real two-worker
farm: a 512x512 frame, the play, step and frame slider and the frame's
label all lie within the viewport (and still do in a lower window, the
picture scaled down to fit); small frames (96x96, 256x256) are shown at a
crisp integer zoom, never a fractional stretch; the MP4 takes exactly the
frame view's box, and while it plays the frame label, the δ slider and the
frame's figures follow the video's time. Screenshots go to
build/screenshots/player-*.png."""

from __future__ import annotations

import httpx
import pytest

from tests.farm.test_farm import Farm
from tests.web.browser import chromium_page, shot

WIDTH, HEIGHT = 1280, 900  # chromium_page's viewport
CONTROLS = ("#canvas", "#play", "#prev", "#next", "#scrub", "#scrub-label")
MP4_FPS = 8  # the farm encodes animation.mp4 at 8 fps


@pytest.fixture(scope="module")
def farm(tmp_path_factory):
    f = Farm(tmp_path_factory.mktemp("player-web") / "data").start()
    yield f
    f.stop()


@pytest.fixture(scope="module")
def jobs(farm):
    """Done jobs by frame side: 512 and 256 (two frames, the bicube), 96 (a
    δ sweep of 24 frames, the Whitney umbrella: a 3 s MP4)."""
    specs = {512: ("bicube", [0, "pi/9"]), 256: ("bicube", [0, "pi/9"]),
             96: ("whitney", {"start": 0, "stop": "pi/9", "count": 24})}
    ids = {}
    for side, (scene, deltas) in specs.items():
        r = httpx.post(farm.url + "/api/jobs", json={"scene": scene, "deltas": deltas, "width": side, "height": side},
                       timeout=30)
        assert r.status_code == 201, r.text
        ids[side] = r.json()["id"]
    for side, job_id in ids.items():
        assert farm.wait_job(job_id, 180)["status"] == "done", side
    return ids


def _open(page, farm, job_id: str) -> None:
    page.goto(f"{farm.url}/#/job/{job_id}")
    page.wait_for_function("document.querySelector('#status')?.textContent === 'done'", timeout=30_000)
    page.wait_for_function("document.querySelector('#canvas')?.dataset?.drawn === 'beauty/0'", timeout=30_000)


def _box(page, selector: str) -> dict:
    return page.eval_on_selector(selector, """e => { const b = e.getBoundingClientRect();
        return {left: b.left, top: b.top, right: b.right, bottom: b.bottom, width: b.width, height: b.height,
                rendering: getComputedStyle(e).imageRendering}; }""")


def _assert_in_view(page, height: int) -> dict:
    """Every control of the player within the viewport, unscrolled; the boxes."""
    assert page.evaluate("window.scrollY") == 0
    boxes = {s: _box(page, s) for s in CONTROLS}
    for s, b in boxes.items():
        assert b["width"] > 0 and b["height"] > 0, (s, b)
        assert b["top"] >= 0 and b["bottom"] <= height and b["left"] >= 0 and b["right"] <= WIDTH, (s, b, height)
    return boxes


def test_a_512_frame_and_its_controls_fit_the_viewport(farm, jobs):
    with chromium_page() as page:
        _open(page, farm, jobs[512])
        boxes = _assert_in_view(page, HEIGHT)
        # At 1280x900 the frame fits at its own size: one screen pixel a pixel.
        assert (boxes["#canvas"]["width"], boxes["#canvas"]["height"]) == (512, 512), boxes["#canvas"]
        shot(page, "player-512")
        # A lower window: the picture is scaled down so that the controls stay in view.
        page.set_viewport_size({"width": WIDTH, "height": 640})
        page.wait_for_function("document.querySelector('#canvas').getBoundingClientRect().height < 512")
        boxes = _assert_in_view(page, 640)
        assert boxes["#canvas"]["width"] == boxes["#canvas"]["height"]  # the aspect ratio is kept
        page.set_viewport_size({"width": WIDTH, "height": HEIGHT})
        page.wait_for_function("document.querySelector('#canvas').getBoundingClientRect().height === 512")
        assert not page.errors, page.errors


@pytest.mark.parametrize("side", [96, 256])
def test_small_frames_are_shown_at_a_crisp_integer_zoom(farm, jobs, side):
    with chromium_page() as page:
        _open(page, farm, jobs[side])
        assert page.evaluate("window.devicePixelRatio") == 1
        boxes = _assert_in_view(page, HEIGHT)
        canvas = boxes["#canvas"]
        zoom = canvas["width"] / side
        assert zoom == int(zoom) and canvas["height"] == canvas["width"], canvas  # an integer zoom, no stretch
        assert zoom >= 2, canvas  # enlarged (there is room for it at 1280x900)
        assert canvas["rendering"] == "pixelated", canvas  # with crisp pixels
        # The largest zoom that fits: one more would push the controls off the screen or past the column.
        room_h = HEIGHT - canvas["top"] - (boxes["#scrub-label"]["bottom"] - canvas["bottom"])
        room_w = page.eval_on_selector("#stage", "s => s.clientWidth")
        assert (zoom + 1) * side > min(room_h, room_w), (zoom, room_h, room_w)
        shot(page, f"player-{side}")
        assert not page.errors, page.errors


def test_the_mp4_takes_the_frames_box_and_its_label_follows_the_video(farm, jobs):
    with chromium_page() as page:
        _open(page, farm, jobs[96])
        frame_box = _box(page, "#canvas")
        initial = page.text_content("#scrub-label")
        assert initial.startswith("frame 1/24")
        page.click("#show-mp4")
        page.wait_for_function("document.querySelector('#video').readyState >= 2", timeout=30_000)
        assert page.is_hidden("#canvas") and page.is_visible("#video")
        # The video's box is the frame view's, and shaped like the video: no letterbox.
        video_box = _box(page, "#video")
        assert {k: video_box[k] for k in ("left", "top", "width", "height")} == \
            {k: frame_box[k] for k in ("left", "top", "width", "height")}, (video_box, frame_box)
        natural = page.eval_on_selector("#video", "v => [v.videoWidth, v.videoHeight, v.duration]")
        assert natural[:2] == [96, 96] and video_box["width"] / video_box["height"] == natural[0] / natural[1]
        assert natural[2] == pytest.approx(24 / MP4_FPS, abs=0.2)
        # It plays: the label moves on with the video's time.
        assert page.eval_on_selector("#video", "v => !v.paused") and "pause" in page.text_content("#play")
        page.wait_for_function(f"document.querySelector('#scrub-label').textContent !== {initial!r}", timeout=15_000)
        page.wait_for_function("document.querySelector('#video').currentTime > 1", timeout=15_000)
        # Paused, the label, the δ slider and the figures show the video's frame.
        page.click("#play")
        page.wait_for_function("document.querySelector('#video').paused")
        page.wait_for_timeout(200)
        t = page.eval_on_selector("#video", "v => v.currentTime")
        index = min(23, int(t * MP4_FPS + 1e-3))
        assert page.text_content("#scrub-label").startswith(f"frame {index + 1}/24"), (t, page.text_content("#scrub-label"))
        assert page.input_value("#scrub") == str(index) and page.get_attribute("#canvas", "data-frame") == str(index)
        assert "play" in page.text_content("#play")
        shot(page, "player-mp4")
        # A step seeks the video to the next frame, and back on the canvas the same frame is shown.
        page.click("#next")
        nxt = (index + 1) % 24
        page.wait_for_function(f"Math.floor(document.querySelector('#video').currentTime * {MP4_FPS} + 1e-3) === {nxt}")
        assert page.text_content("#scrub-label").startswith(f"frame {nxt + 1}/24")
        page.click("#show-mp4")
        page.wait_for_function(f"document.querySelector('#canvas')?.dataset?.drawn === 'beauty/{nxt}'")
        assert page.is_hidden("#video") and _box(page, "#canvas")["width"] == frame_box["width"]
        assert not page.errors, page.errors
