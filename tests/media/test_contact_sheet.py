"""One contact sheet: argand.media.contact_sheet lays out the atlas of a
(σ, δ) grid and the render benchmark's presets by δ alike."""

from __future__ import annotations

import numpy as np
import OpenImageIO as oiio
import pytest

from argand.bench.render import SHEET_BACKGROUND, preset_sheet
from argand.frames.frame_set import atlas_grid
from argand.media.atlas import BACKGROUND, grid_sheet, to_rgb
from argand.media.contact_sheet import EMPTY_CELL, PAD, contact_sheet
from argand.media.frame_files import to_srgb8
from argand.render import FrameParams, render_frame
from argand.scene import load_scene


def solid(h: int, w: int, value: int, channels: int = 3) -> np.ndarray:
    return np.full((h, w, channels), value, np.uint8)


def cell_at(sheet: np.ndarray, r: int, c: int, w: int, h: int, pad: int = PAD) -> np.ndarray:
    y, x = pad + r * (h + pad), pad + c * (w + pad)
    return sheet[y:y + h, x:x + w]


def test_cells_land_in_their_row_and_column_with_the_gaps_between():
    w, h = 5, 3
    sheet = contact_sheet({(0, 1): solid(h, w, 200), (1, 0): solid(h, w, 90, 4)}, (2, 3), (w, h),
                          background=(1, 2, 3), empty=(7, 8, 9), pad=2)
    assert sheet.shape == (2 * (h + 2) + 2, 3 * (w + 2) + 2, 3) and sheet.dtype == np.uint8
    assert np.all(cell_at(sheet, 0, 1, w, h, 2) == 200) and np.all(cell_at(sheet, 1, 0, w, h, 2) == 90)
    for r, c in ((0, 0), (0, 2), (1, 1), (1, 2)):
        assert np.all(cell_at(sheet, r, c, w, h, 2) == (7, 8, 9))
    assert np.all(sheet[:2] == (1, 2, 3)) and np.all(sheet[:, :2] == (1, 2, 3))  # the frame around
    assert np.all(sheet[2 + h:2 + h + 2] == (1, 2, 3))  # the gap between the rows


def test_a_larger_picture_is_scaled_to_its_cell_and_a_place_outside_is_refused():
    big = np.zeros((30, 50, 3), np.uint8)
    big[:, 25:] = 255  # left half black, right half white
    sheet = contact_sheet({(0, 0): big}, (1, 1), (10, 6))
    cell = cell_at(sheet, 0, 0, 10, 6)
    assert cell[:, :4].max() < 20 and cell[:, 6:].min() > 235
    with pytest.raises(ValueError, match=r"cell \(2, 0\) is outside the sheet's 1 x 1 cells"):
        contact_sheet({(2, 0): big}, (1, 1), (10, 6))


def test_an_atlas_is_the_contact_sheet_of_its_frames_in_their_places():
    grid = atlas_grid(3)  # rows of 3, 2 and 1 frames
    cells = {k: solid(4, 4, 10 * (k + 1)) for k in range(len(grid))}
    del cells[4]
    sheet = grid_sheet(grid, cells, (4, 4))
    assert np.array_equal(sheet, contact_sheet(
        {(p.sigma_index, p.delta_index): cells[k] for k, p in enumerate(grid.points) if k != 4}, (3, 3), (4, 4),
        background=to_rgb(BACKGROUND)))
    p = grid.points[4]
    assert np.all(cell_at(sheet, p.sigma_index, p.delta_index, 4, 4) == EMPTY_CELL)
    assert np.all(cell_at(sheet, 2, 2, 4, 4) == EMPTY_CELL)  # outside the triangle


def test_the_benchmarks_preset_sheet_is_the_contact_sheet_of_the_rendered_frames(tmp_path):
    deltas, size = [0.0, 0.3], 12
    path = tmp_path / "sheet.png"
    preset_sheet(["steiner", "whitney"], deltas, size, path)
    expected = {(r, c): to_srgb8(render_frame(load_scene(name), FrameParams(delta=d, width=size, height=size)).rgba)
                for r, name in enumerate(["steiner", "whitney"]) for c, d in enumerate(deltas)}
    want = contact_sheet(expected, (2, 2), (size, size), background=SHEET_BACKGROUND)
    written = oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8)
    assert written.shape == want.shape and np.array_equal(written, want)
    assert np.all(written[:PAD] == 255)
