"""Atheris (libFuzzer for Python) target for the scene/expression path.

Each input is one of: a surface expression (argand.scene.parse_surface), an
angle (argand.frames.angles.parse_angle), or a JSON scene
(argand.scene.scene_from_text) that, when valid, is planned and rendered as
a 4x4 frame through the C++ binding. The contract checked: the parsers
either return or raise ValueError (ExpressionError / SceneError), never
another exception; a parsed surface has degree 1..MAX_DEGREE and at most
MAX_TERMS terms; an accepted scene renders (plan_frame may refuse it with a
ValueError saying why) into AOVs of the frame's size; every input finishes
within libFuzzer's -timeout. Python code is coverage-instrumented; the C++
core is not (find_roots and the renderer have their own libFuzzer targets).

    .venv/bin/python fuzz/scene_fuzz.py -max_total_time=60 fuzz/corpus/scene
"""

from __future__ import annotations

import math
import sys

import atheris

from argand.frames.angles import parse_angle
from argand.render.frames import FrameParams, TileRect, render_tile
from argand.scene import scene_from_text
from argand.scene.expression import MAX_DEGREE, MAX_TERMS, parse_surface

# Coverage of every Python function loaded so far (instrument_imports misses
# modules that the editable install's finder loads).
atheris.instrument_all()


def check_surface(text: str) -> None:
    try:
        poly = parse_surface(text)
    except ValueError:
        return
    assert 1 <= poly.degree <= MAX_DEGREE, poly.degree
    assert 0 < len(poly.terms) <= MAX_TERMS, len(poly.terms)
    _, coefficients = poly.as_arrays()
    assert all(math.isfinite(c) and c != 0.0 for c in coefficients), coefficients


def check_angle(text: str) -> None:
    try:
        value = parse_angle(text)
    except ValueError:
        return
    assert math.isfinite(value), value


def check_scene(text: str, width: int, height: int) -> None:
    try:
        scene = scene_from_text(text, kind="json", source="fuzz")
    except ValueError:
        return
    try:
        tile = render_tile(scene, FrameParams(delta=0.3, width=width, height=height), TileRect(0, 0, width, height))
    except ValueError:
        return  # plan_frame refused the scene, saying why
    assert tile.aovs["status"].shape[:2] == (height, width), tile.aovs["status"].shape


def test_one_input(data: bytes) -> None:
    provider = atheris.FuzzedDataProvider(data)
    mode = provider.ConsumeIntInRange(0, 2)
    if mode == 0:
        check_surface(provider.ConsumeUnicodeNoSurrogates(provider.remaining_bytes()))
    elif mode == 1:
        check_angle(provider.ConsumeUnicodeNoSurrogates(provider.remaining_bytes()))
    else:
        width, height = provider.ConsumeIntInRange(1, 4), provider.ConsumeIntInRange(1, 4)
        check_scene(provider.ConsumeUnicodeNoSurrogates(provider.remaining_bytes()), width, height)


if __name__ == "__main__":
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()
