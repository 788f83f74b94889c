"""A sweep of frames rendered on this machine, with its files: what
`argand render` does, and the baseline `argand bench farm` holds the farm
against (the same frames and the same files, without the farm)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

from argand.render.frames import FrameParams, TileAOVs, render_frame


def render_sweep(
    scene: Any,
    params: Sequence[FrameParams],
    out: Path,
    tile: int = 64,
    workers: int | None = None,
    compression: str | None = None,
    fps: float = 8.0,
    on_frame: Callable[[int, FrameParams], None] | None = None,
    on_tile: Callable[[TileAOVs], None] | None = None,
) -> list[dict]:
    """Renders ``params`` in order on ``workers`` threads and writes
    frame_NNNN.exr/.png/.json under ``out``, and animation.gif when there is
    more than one frame. Returns each frame's figures. With ``workers``,
    OpenImageIO's encoding uses as many threads (its default is every
    core), and its settings are restored after."""
    import OpenImageIO as oiio

    saved = {k: oiio.get_int_attribute(k) for k in ("threads", "exr_threads")}
    if workers:
        for k in saved:
            oiio.attribute(k, int(workers))
    try:
        return _render_sweep(scene, params, out, tile, workers, compression, fps, on_frame, on_tile)
    finally:
        for k, v in saved.items():
            oiio.attribute(k, v)


def _render_sweep(scene, params, out, tile, workers, compression, fps, on_frame, on_tile) -> list[dict]:
    from argand.render import gif
    from argand.render.output import EXR_COMPRESSION, to_srgb8, write_frame

    previews, figures = [], []
    for index, p in enumerate(params):
        if on_frame:
            on_frame(index, p)
        result = render_frame(scene, p, tile=tile, workers=workers, on_tile=on_tile)
        srgb = to_srgb8(result.rgba)
        write_frame(result, out, index, srgb8=srgb, compression=compression or EXR_COMPRESSION)
        if len(params) > 1:
            previews.append(gif.encode_frame(srgb))
        figures.append(result.figures)
    if previews:
        tmp = out / "animation.gif.tmp"
        tmp.write_bytes(gif.splice(previews, fps=fps))
        tmp.replace(out / "animation.gif")
    return figures
