"""argand.render: frames of a scene in complex space, rendered locally.

``render_tile(scene, params, rect) -> TileAOVs`` is the unit of work (the
farm's workers use its planned form, ``frames.render_tile_into``); ``render_frame`` renders all tiles of a frame
on all cores; ``argand.media.frame_files`` writes EXR (all AOVs), PNG and JSON
through OpenImageIO; ``argand.media.gif`` encodes each frame's GIF
fragment and splices the animation from them.
``primary_ray(scene, width, height, x, y)`` gives the exact doubles of a
pixel's ray, so anyone can check a pixel against the surface itself.
"""

from argand.frames.angles import parse_angle, parse_sweep
from argand.render.frames import (
    AOV_CHANNELS,
    BAND_RULE,
    LADDER_LEVEL_NAMES,
    MAX_OBJECTS,
    MAX_SAMPLES,
    STATUS_NAMES,
    FrameParams,
    FrameResult,
    TileAOVs,
    TileRect,
    delta_sweep,
    render_frame,
    render_tile,
    tiles,
)
from argand.render.rays import primary_ray

__all__ = [
    "AOV_CHANNELS",
    "BAND_RULE",
    "LADDER_LEVEL_NAMES",
    "MAX_OBJECTS",
    "MAX_SAMPLES",
    "STATUS_NAMES",
    "FrameParams",
    "FrameResult",
    "TileAOVs",
    "TileRect",
    "delta_sweep",
    "parse_angle",
    "parse_sweep",
    "primary_ray",
    "render_frame",
    "render_tile",
    "tiles",
]
