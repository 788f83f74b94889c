"""atlas.png: a grid job's frames as one contact sheet, rows by σ (top:
the smallest), columns by δ, each axis labelled with its values (matplotlib's
Agg canvas, no pyplot, so it is safe in a server's threads). `argand render`
writes it for a grid; the farm makes it on first request."""

from __future__ import annotations

import io
from typing import Mapping

import numpy as np
from PIL import Image

from argand.frames.frame_set import FrameSet, format_angle

#: The longest side of a cell, in pixels (frames are scaled down to it, never up).
CELL = 160
PAD = 4
#: Cells without a frame: outside the triangle of an atlas, or not rendered yet.
EMPTY_CELL = (40, 42, 48)
BACKGROUND = "#14161a"
TEXT = "#e6e6e6"


def cell_size(width: int, height: int, cell: int = CELL) -> tuple[int, int]:
    """(w, h) of a cell: the frame's aspect, longest side ``cell`` at most."""
    scale = min(1.0, cell / max(width, height))
    return max(1, round(width * scale)), max(1, round(height * scale))


def scale_to_cell(rgb: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(h, w, 3) uint8 -> the picture at ``size`` (w, h) (Lanczos; as is when it is that size)."""
    if rgb.shape[1::-1] == tuple(size):
        return rgb
    return np.asarray(Image.fromarray(np.ascontiguousarray(rgb)).resize(tuple(size), Image.LANCZOS))


def contact_sheet(grid: FrameSet, cells: Mapping[int, np.ndarray], size: tuple[int, int]) -> np.ndarray:
    """(rows, cols) cells of ``size`` (w, h) with PAD between them; ``cells``
    maps a frame's index (in grid.points) to its (h', w', 3) uint8 picture,
    scaled to the cell here; a missing frame is an empty cell."""
    (w, h), (rows, cols) = size, grid.shape
    sheet = np.empty((rows * (h + PAD) + PAD, cols * (w + PAD) + PAD, 3), np.uint8)
    sheet[...] = np.array(to_rgb(BACKGROUND), np.uint8)
    for r in range(rows):
        for c in range(cols):
            y, x = PAD + r * (h + PAD), PAD + c * (w + PAD)
            sheet[y:y + h, x:x + w] = EMPTY_CELL
    for k, p in enumerate(grid.points):
        picture = cells.get(k)
        if picture is None:
            continue
        picture = scale_to_cell(picture[..., :3], (w, h))
        y, x = PAD + p.sigma_index * (h + PAD), PAD + p.delta_index * (w + PAD)
        sheet[y:y + h, x:x + w] = picture[..., :3]
    return sheet


def to_rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[i:i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


def atlas_png(grid: FrameSet, cells: Mapping[int, np.ndarray], width: int, height: int, title: str = "") -> bytes:
    """The labelled atlas as PNG bytes: the contact sheet at one screen pixel
    per pixel, δ values under the columns, σ values beside the rows."""
    from matplotlib.figure import Figure

    w, h = cell_size(width, height)
    sheet = contact_sheet(grid, cells, (w, h))
    sh, sw = sheet.shape[:2]
    dpi = 100
    left, bottom, top, right = 80, 60, 40 if title else 16, 16
    fig = Figure(figsize=((sw + left + right) / dpi, (sh + bottom + top) / dpi), dpi=dpi, facecolor=BACKGROUND)
    W, H = sw + left + right, sh + bottom + top
    ax = fig.add_axes((left / W, bottom / H, sw / W, sh / H))
    ax.imshow(sheet, interpolation="nearest", extent=(0, sw, sh, 0))
    rows, cols = grid.shape
    ax.set_xticks([PAD + c * (w + PAD) + w / 2 for c in range(cols)], [format_angle(d) for d in grid.deltas])
    ax.set_yticks([PAD + r * (h + PAD) + h / 2 for r in range(rows)], [format_angle(s) for s in grid.sigmas])
    ax.set_xlabel("δ (band width)", color=TEXT)
    ax.set_ylabel("σ (band start)", color=TEXT)
    ax.tick_params(colors=TEXT, labelsize=8, length=0)
    for spine in ax.spines.values():
        spine.set_visible(False)
    if title:
        fig.suptitle(title, color=TEXT, fontsize=10, y=1 - 8 / H, va="top")
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=dpi, facecolor=BACKGROUND)
    return out.getvalue()
