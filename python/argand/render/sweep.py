"""A sweep of frames rendered on this machine, with its files: what
`argand render` does, and the baseline `argand bench farm` holds the farm
against (the same frames and the same files, without the farm)."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from argand.render.frames import FrameParams, TileAOVs, render_frame
from argand.render.output import EXR_COMPRESSION


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
) -> list[dict]:
    """Renders ``params`` in order on ``workers`` threads (encoding too) and
    writes frame_NNNN.exr/.png/.json under ``out``, and animation.gif when
    there is more than one frame. Returns each frame's figures."""
    from argand.render import gif
    from argand.render.output import to_srgb8, write_frame

    previews, figures = [], []
    with oiio_threads(workers):
        for index, p in enumerate(params):
            if on_frame:
                on_frame(index, p)
            result = render_frame(scene, p, tile=tile, workers=workers, on_tile=on_tile)
            srgb = to_srgb8(result.rgba)
            write_frame(result, out, index, srgb8=srgb, compression=compression)
            if len(params) > 1:
                previews.append(gif.encode_frame(srgb))
            figures.append(result.figures)
    if previews:
        tmp = out / "animation.gif.tmp"
        tmp.write_bytes(gif.splice(previews, fps=fps))
        tmp.replace(out / "animation.gif")
    return figures
