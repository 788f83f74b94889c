"""A job's frames over HTTP and `argand render`'s are built once, by
FrameSet.from_axes: for each of a family of inputs, the same (σ, δ) pairs,
to the last bit and in the same order, or the same refusal, word for word.
Real parts: the API served over loopback with a real Redis and SQLite, the
CLI's own command (in process) writing its frames."""

from __future__ import annotations

import json

import httpx
import pytest
from typer.testing import CliRunner

from tests.farm.test_limits import _serve
from tests.farm.test_work import farm_parts  # noqa: F401  (the fixture)

from argand.cli import app as cli_app
from argand.frames.frame_set import FrameSet, atlas_grid


def sweep(start, stop, count) -> dict:
    return {"start": start, "stop": stop, "count": count}


#: Axes as a job gives them; the CLI gets the same values (a sweep as START:STOP:COUNT).
ACCEPTED = [
    {},
    {"sigma": "pi/36"},
    {"delta": "pi/9"},
    {"sigmas": "pi/3"},
    {"deltas": sweep(0, "pi/9", 5)},
    {"sigmas": sweep(0, "pi/2", 4), "delta": "pi/9"},
    {"sigmas": sweep(0, "pi/4", 3), "deltas": sweep("pi/36", "pi/2", 4)},
    {"sigma": 0.5, "deltas": sweep(0.1, 2.5, 7)},
    {"deltas": sweep("pi/36", "pi/9", 12)},
    {"atlas": 4},
]
REFUSED = [
    {"sigma": 0, "sigmas": sweep(0, 1, 2)},
    {"delta": 0.1, "deltas": sweep(0, 1, 2)},
    {"atlas": 3, "delta": 0.1},
    {"atlas": 3, "sigma": 0, "deltas": sweep(0, 1, 2)},
    {"sigmas": sweep(0, "pi", 2), "delta": "pi/2"},
    {"sigma": "pi", "delta": "pi/9"},
    {"sigma": "-0.1"},
    {"sigmas": sweep(0, 3, 7), "deltas": sweep(0.5, 1.5, 3)},
]


def cli_args(axes: dict) -> list[str]:
    out = []
    for name, value in axes.items():
        text = f"{value['start']}:{value['stop']}:{value['count']}" if isinstance(value, dict) else str(value)
        out += [f"--{name}", text]
    return out


def run_cli(*args: str):
    return CliRunner().invoke(cli_app, ["render", "whitney", *args], catch_exceptions=False)


@pytest.fixture
def api(farm_parts):  # noqa: F811
    settings, _ = farm_parts
    server, thread, url = _serve(settings.model_copy(update={"max_active_jobs": 100}))
    with httpx.Client(base_url=url, timeout=60) as c:
        yield c
    server.should_exit = True
    thread.join(10)


def api_refusal(c, axes: dict) -> str:
    r = c.post("/api/jobs", json={"scene": "whitney", "width": 2, "height": 2, "tile": 16, **axes})
    assert r.status_code == 422, (axes, r.status_code, r.text[:300])
    detail = r.json()["detail"]
    if isinstance(detail, str):
        return detail
    assert len(detail) == 1, detail
    return detail[0]["msg"].removeprefix("Value error, ")


def test_the_api_and_the_cli_give_the_same_pairs(api, tmp_path):
    for k, axes in enumerate(ACCEPTED):
        r = api.post("/api/jobs", json={"scene": "whitney", "width": 2, "height": 2, "tile": 16, **axes})
        assert r.status_code == 201, (axes, r.text)
        job = api.get(f"/api/jobs/{r.json()['id']}").json()
        served = [(f["sigma"], f["delta"]) for f in sorted(job["frames"], key=lambda f: f["index"])]
        out = tmp_path / f"run{k}"
        result = run_cli(*cli_args(axes), "--size", "2x2", "--workers", "1", "--out", str(out))
        assert result.exit_code == 0, (axes, result.output)
        rendered = [(f["sigma"], f["delta"]) for f in
                    (json.loads((out / f"frame_{i:04d}.json").read_text()) for i in range(len(served)))]
        assert not (out / f"frame_{len(served):04d}.json").exists()
        assert served == rendered, axes
        expected = FrameSet.from_axes(**axes)
        assert served == [(p.sigma, p.delta) for p in expected.points], axes
        assert (job["sigmas"], job["deltas"]) == (list(expected.sigmas), list(expected.deltas)), axes
    assert len(served) == len(atlas_grid(4))  # the last input, checked against the atlas itself


def test_the_api_and_the_cli_refuse_the_same_inputs_with_the_same_words(api, tmp_path):
    for axes in REFUSED:
        served = api_refusal(api, axes)
        result = run_cli(*cli_args(axes), "--size", "2x2", "--out", str(tmp_path / "bad"))
        assert result.exit_code == 2, (axes, result.output)
        printed = " ".join(result.output.split()).removeprefix("error: ")
        assert printed == " ".join(served.split()), axes
        with pytest.raises(ValueError) as info:
            FrameSet.from_axes(**axes)
        assert str(info.value) == served, axes
        assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("axes, message", [
    ({"sigmas": []}, "sigmas: no values: give at least one"),
    ({"deltas": {"start": 0, "stop": 1}}, "deltas: a sweep is {start, stop, count}, got the keys ['start', 'stop']"),
    ({"deltas": {"start": 0, "stop": 1, "count": 0}}, "deltas: a sweep's count must be a whole number >= 1, got 0"),
    ({"deltas": {"start": 0, "stop": 1, "count": True}}, "deltas: a sweep's count must be a whole number >= 1"),
    ({"sigma": [0.1]}, "sigma: an angle must be a number or text"),
    ({"deltas": "0:1"}, "deltas: expected START:STOP:COUNT"),
    ({"sigmas": sweep(0, 1, 101), "deltas": sweep(0, 1, 100)}, "10100 frames exceed the limit of 10000"),
    ({"atlas": 200}, "20100 frames exceed the limit of 10000"),
])
def test_from_axes_names_the_axis_it_refuses(axes, message):
    with pytest.raises(ValueError) as info:
        FrameSet.from_axes(**axes, max_frames=10_000)
    assert str(info.value).startswith(message)
