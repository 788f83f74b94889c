"""A sweep of frames rendered on this machine, with its files: what
`argand render` does, and the baseline `argand bench farm` holds the farm
against (the same frames and the same files, without the farm)."""

from __future__ import annotations

from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from argand.render.field import RootField
from argand.render.frames import FrameParams, FrameResult, TileAOVs, render_bands, same_rays
from argand.frames.frame_set import FrameSet
from argand.media.atomic import atomic_path, write_atomic
from argand.media.frame_files import EXR_COMPRESSION


@contextmanager
def oiio_threads(n: int | None) -> Iterator[None]:
    """OpenImageIO (and its OpenEXR) on ``n`` threads inside the block (None:
    as they are; their default is every core), restored after."""
    import OpenImageIO as oiio

    saved = {k: oiio.get_int_attribute(k) for k in ("threads", "exr_threads")}
    try:
        if n:
            for k in saved:
                oiio.attribute(k, int(n))
        yield
    finally:
        for k, v in saved.items():
            oiio.attribute(k, v)


def render_sweep(
    scene: Any,
    params: Sequence[FrameParams],
    out: Path,
    tile: int = 64,
    workers: int | None = None,
    compression: str = EXR_COMPRESSION,
    fps: float = 8.0,
    on_frame: Callable[[int, FrameParams], None] | None = None,
    on_tile: Callable[[TileAOVs], None] | None = None,
    grid: FrameSet | None = None,
    mp4: bool = True,
    root_field: Path | None = None,
) -> list[dict]:
    """Renders ``params`` on ``workers`` threads (encoding too), frames that
    share their rays together (their roots solved once), and
    writes frame_NNNN.exr/.png/.json under ``out``, animation.gif and
    animation.mp4 (unless not ``mp4``) when there is more than one frame, and
    atlas.png when ``grid`` (the frames' places, one per param) has more than
    one σ and δ. on_frame(index, params) is called as each frame is written.
    ``root_field``: also write the run's root field there (RootField.save;
    the frames must share their rays). Returns each frame's figures."""
    from argand.media.frame_files import to_srgb8, write_frame

    if grid is not None and len(grid) != len(params):
        raise ValueError(f"the grid has {len(grid)} frames, the sweep {len(params)}")

    previews, figures, cells = [], [], {}
    animated = len(params) > 1
    atlas = grid is not None and grid.is_grid
    # Pillow and PyAV for an animation, the atlas's modules for an atlas,
    # imported only then: one frame's process does without them.
    if animated:
        from argand.media import gif
        from argand.media.video import Mp4Encoder
    if atlas:
        from argand.media.atlas import atlas_png
        from argand.media.contact_sheet import cell_size, scale_to_cell
    if animated:
        out.mkdir(parents=True, exist_ok=True)
    # The MP4 is encoded as the frames come, into a temporary renamed once whole.
    with oiio_threads(workers), (atomic_path(out / "animation.mp4") if animated and mp4 else nullcontext()) as mp4_tmp, \
            (Mp4Encoder(mp4_tmp, fps) if mp4_tmp is not None else nullcontext()) as video:
        field = RootField(0, 0, 0, 0)
        # The field is recorded only where it is used: asked for, or read by
        # the later groups of a long sweep (recording costs a 512² frame
        # some 0.02-0.05 s of CPU).
        keep = root_field is not None or len(params) > BANDS_AT_ONCE
        for index, result in enumerate(_frames(scene, params, tile, workers, on_tile, field if keep else None)):
            p = result.params
            if on_frame:
                on_frame(index, p)
            srgb = to_srgb8(result.rgba)
            write_frame(result, out, index, srgb8=srgb, compression=compression)
            if animated:
                previews.append(gif.encode_frame(srgb))
                if video is not None:
                    video.add(srgb)
            if atlas:  # kept at the atlas's cell size only
                cells[index] = scale_to_cell(srgb, cell_size(p.width, p.height))
            figures.append(result.figures)
    if previews:
        write_atomic(out / "animation.gif", gif.splice(previews, fps=fps))
    if atlas:
        write_atomic(out / "atlas.png", atlas_png(grid, cells, params[0].width, params[0].height))
    if root_field is not None:
        if not field.tiles:
            raise ValueError("--root-field: the frames do not share their rays (they differ in more than σ and δ)")
        field.save(root_field)
    return figures


#: Frames rendered together (their primary roots solved once): more saves
#: solves, and holds more frames in memory at once.
BANDS_AT_ONCE = 32


def _frames(scene: Any, params: Sequence[FrameParams], tile: int, workers: int | None,
            on_tile: Callable[[TileAOVs], None] | None, field: RootField | None) -> Iterator[FrameResult]:
    """The sweep's frames in order, BANDS_AT_ONCE at a time through
    render_bands (each, to the bit, the frame render_frame gives alone):
    the first group records the root field into ``field``, the later ones
    decide from it instead of solving again (when they share its rays).
    ``field`` None: every group solves its own roots."""
    for first in range(0, len(params), BANDS_AT_ONCE):
        group = list(params[first:first + BANDS_AT_ONCE])
        same = all(same_rays(params[0], p) for p in group)
        if first == 0 and same and field is not None:
            yield from render_bands(scene, group, tile=tile, workers=workers, on_tile=on_tile, record=field)
        elif field is not None and field.tiles and same:
            yield from render_bands(scene, group, tile=tile, workers=workers, on_tile=on_tile, field=field)
        else:
            yield from render_bands(scene, group, tile=tile, workers=workers, on_tile=on_tile)



