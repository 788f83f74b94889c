"""Contact sheets: presets (rows) by delta (columns), for the README."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from argand.render.frames import FrameParams, render_frame
from argand.media.frame_files import to_srgb8, write_png


def contact_sheet(
    scenes: Sequence[str], deltas: Sequence[float], size: int, path: Path, sigma: float = 0.0, pad: int = 4
) -> dict[str, list[float]]:
    """Renders every (scene, delta) at size x size and writes one PNG grid.
    Returns the certified share of each frame."""
    from argand.scene import load_scene

    rows, shares = [], {}
    for name in scenes:
        scene = load_scene(name)
        cells = []
        for d in deltas:
            result = render_frame(scene, FrameParams(sigma=sigma, delta=d, width=size, height=size))
            cells.append(to_srgb8(result.rgba))
            shares.setdefault(name, []).append(result.certified_share)
        rows.append(cells)
    h = len(rows) * (size + pad) + pad
    w = len(deltas) * (size + pad) + pad
    sheet = np.full((h, w, 3), 255, np.uint8)
    for r, cells in enumerate(rows):
        for c, img in enumerate(cells):
            y, x = pad + r * (size + pad), pad + c * (size + pad)
            sheet[y : y + size, x : x + size] = img
    path.parent.mkdir(parents=True, exist_ok=True)
    write_png(sheet, path)
    return shares
