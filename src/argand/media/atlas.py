"""atlas.png: a grid job's frames as one contact sheet
(argand.media.contact_sheet), rows by σ (top: the smallest), columns by δ,
each axis labelled with its values (matplotlib's
Agg canvas, no pyplot, so it is safe in a server's threads). `argand render`
writes it for a grid; the farm makes it on first request."""

from __future__ import annotations

import io
from typing import Mapping

import numpy as np

from argand.frames.frame_set import FrameSet, format_angle
from argand.media.contact_sheet import PAD, cell_size, contact_sheet

BACKGROUND = "#14161a"
TEXT = "#e6e6e6"


def to_rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[i:i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


def grid_sheet(grid: FrameSet, cells: Mapping[int, np.ndarray], size: tuple[int, int]) -> np.ndarray:
    """The grid's contact sheet (argand.media.contact_sheet), each frame in
    its (σ row, δ column) cell of ``size`` (w, h); ``cells`` maps a frame's
    index (in grid.points) to its picture; a missing frame is an empty cell."""
    places = {(p.sigma_index, p.delta_index): cells[k] for k, p in enumerate(grid.points) if k in cells}
    return contact_sheet(places, grid.shape, size, background=to_rgb(BACKGROUND))


def atlas_png(grid: FrameSet, cells: Mapping[int, np.ndarray], width: int, height: int, title: str = "") -> bytes:
    """The labelled atlas as PNG bytes: the contact sheet at one screen pixel
    per pixel, δ values under the columns (for an atlas on uneven cuts,
    how many cuts each band spans), σ values beside the rows."""
    from matplotlib.figure import Figure

    w, h = cell_size(width, height)
    sheet = grid_sheet(grid, cells, (w, h))
    sh, sw = sheet.shape[:2]
    dpi = 100
    left, bottom, top, right = 80, 60, 40 if title else 16, 16
    fig = Figure(figsize=((sw + left + right) / dpi, (sh + bottom + top) / dpi), dpi=dpi, facecolor=BACKGROUND)
    W, H = sw + left + right, sh + bottom + top
    ax = fig.add_axes((left / W, bottom / H, sw / W, sh / H))
    ax.imshow(sheet, interpolation="nearest", extent=(0, sw, sh, 0))
    rows, cols = grid.shape
    # A column of the uniform atlas has one δ; one laid out on other cuts
    # (where the roots are) has a δ per frame: its column j is the band
    # ending j + 1 cuts after σ.
    uniform = all(abs(p.delta - grid.deltas[p.delta_index]) <= 1e-12 * max(1.0, p.delta) for p in grid.points)
    xticks = [format_angle(d) for d in grid.deltas] if uniform else [f"+{c + 1}" for c in range(cols)]
    ax.set_xticks([PAD + c * (w + PAD) + w / 2 for c in range(cols)], xticks)
    ax.set_yticks([PAD + r * (h + PAD) + h / 2 for r in range(rows)], [format_angle(s) for s in grid.sigmas])
    ax.set_xlabel("δ (band width)" if uniform else "band width in cuts (σ values, π)",
                  color=TEXT)
    ax.set_ylabel("σ (band start)", color=TEXT)
    ax.tick_params(colors=TEXT, labelsize=8, length=0)
    for spine in ax.spines.values():
        spine.set_visible(False)
    if title:
        fig.suptitle(title, color=TEXT, fontsize=10, y=1 - 8 / H, va="top")
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=dpi, facecolor=BACKGROUND)
    return out.getvalue()
