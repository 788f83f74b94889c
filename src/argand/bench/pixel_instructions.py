"""Renders one preset frame on one thread, for counting instructions per pixel.

    valgrind --tool=callgrind "--toggle-collect=argand::render_tile*" \\
        .venv/bin/python -m argand.bench.pixel_instructions whitney 0 48
    callgrind_annotate callgrind.out.<pid> | grep "PROGRAM TOTALS"

Total instructions collected inside render_tile divided by width * height is
the figure of docs/rendering.md's cost table (noise-free, unlike wall-clock
time on a shared machine). DELTA is a number or ``pi/18``, ``pi/36``.
"""

from __future__ import annotations

import math
import sys

from argand.render import render_frame
from argand.render.frames import FrameParams
from argand.scene import load_scene


def parse_delta(text: str) -> float:
    if text.startswith("pi/"):
        return math.pi / float(text[3:])
    return float(text)


def main(argv: list[str]) -> None:
    if len(argv) != 3:
        raise SystemExit("usage: python -m argand.bench.pixel_instructions SCENE DELTA SIDE")
    scene = load_scene(argv[0])
    side = int(argv[2])
    render_frame(scene, FrameParams(sigma=0.0, delta=parse_delta(argv[1]), width=side, height=side), workers=1)


if __name__ == "__main__":
    main(sys.argv[1:])
