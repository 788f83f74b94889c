"""Contact sheets: pictures in rows and columns, one cell each, a gap of
background between cells. One implementation for the atlas of a (σ, δ) grid
(argand.media.atlas, which labels it) and the render benchmark's presets by δ
(argand.bench.render, the README's picture)."""

from __future__ import annotations

from typing import Mapping

import numpy as np
from PIL import Image

#: The longest side of an atlas's cell, in pixels (frames are scaled down to it, never up).
CELL = 160
#: Pixels between cells and around them.
PAD = 4
#: Cells without a picture: outside the triangle of an atlas, or not rendered yet.
EMPTY_CELL = (40, 42, 48)
#: The gaps' colour unless a sheet asks for another.
BACKGROUND = (20, 22, 26)


def cell_size(width: int, height: int, cell: int = CELL) -> tuple[int, int]:
    """(w, h) of a cell: the frame's aspect, longest side ``cell`` at most."""
    scale = min(1.0, cell / max(width, height))
    return max(1, round(width * scale)), max(1, round(height * scale))


def scale_to_cell(rgb: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(h, w, 3) uint8 -> the picture at ``size`` (w, h) (Lanczos; as is when it is that size)."""
    if rgb.shape[1::-1] == tuple(size):
        return rgb
    return np.asarray(Image.fromarray(np.ascontiguousarray(rgb)).resize(tuple(size), Image.LANCZOS))


def contact_sheet(cells: Mapping[tuple[int, int], np.ndarray], shape: tuple[int, int], size: tuple[int, int],
                  background: tuple[int, int, int] = BACKGROUND, empty: tuple[int, int, int] = EMPTY_CELL,
                  pad: int = PAD) -> np.ndarray:
    """A (rows, cols) = ``shape`` sheet of cells of ``size`` (w, h), ``pad``
    pixels of ``background`` between and around them, as (H, W, 3) uint8.
    ``cells`` maps (row, column) to an (h', w', 3 or 4) uint8 picture, scaled
    to the cell here (alpha dropped); a cell without one is ``empty``.
    Raises ValueError for a place outside the shape."""
    (w, h), (rows, cols) = size, shape
    sheet = np.empty((rows * (h + pad) + pad, cols * (w + pad) + pad, 3), np.uint8)
    sheet[...] = np.array(background, np.uint8)
    for r in range(rows):
        for c in range(cols):
            y, x = pad + r * (h + pad), pad + c * (w + pad)
            sheet[y:y + h, x:x + w] = empty
    for (r, c), picture in cells.items():
        if not (0 <= r < rows and 0 <= c < cols):
            raise ValueError(f"cell ({r}, {c}) is outside the sheet's {rows} x {cols} cells")
        y, x = pad + r * (h + pad), pad + c * (w + pad)
        sheet[y:y + h, x:x + w] = scale_to_cell(picture[..., :3], (w, h))
    return sheet
