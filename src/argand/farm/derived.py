"""A done frame's files made on their first request, and kept.

With Settings.files_on_request (the default) a job is done once its tiles
are: the workers keep each tile's figures, not its pixels, and nothing is
encoded between the last tile and the job's end. A frame's PNG, thumbnail
and EXR are written when first asked for, the frame decided again from the
job's root field (argand.farm.bands.render_band: the job's scene, size,
method, samples, tiling and engine options, the roots read from the field),
which gives the bits the workers rendered; its JSON (the figures, as
`argand render` writes them) from the frame's row; the animation and the
atlas are then made from those files. Each file is written once (one lock per frame,
atomic renames), whole or not at all, and served from the store afterwards.

With files_on_request False the assembler writes a frame's PNG, thumbnail
and GIF fragment (argand.farm.assembly), and only the EXR comes from here
(Settings.exr_on_request).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from sqlalchemy import select

from argand.farm.bands import KeyedLocks, render_band
from argand.farm.database import engine_for
from argand.farm.layout import JobLayout
from argand.farm.models import Frame, Job
from argand.farm.planning import samples_of
from argand.farm.settings import Settings
from argand.farm.store import FrameStore, store_for
from argand.media.frame_files import figures_json, to_srgb8, write_exr, write_png
from argand.render.frames import FrameParams
from argand.render.options import EngineOptions
from argand.scene import scene_from_dict

#: The thumbnail keeps every step-th pixel, step = max(width, height) // THUMBNAIL_SIZE.
THUMBNAIL_SIZE = 160

#: What a farm's frame figures add to a frame's own (frame_figures): where
#: the assembler's time went (argand bench farm reports it). The frame's
#: JSON file leaves them out, as `argand render` writes it.
ASSEMBLY_FIGURES = ("assembly_s", "encode_s")

#: The files of a frame made here.
KINDS = ("png", "thumbnail", "exr", "json")

_locks = KeyedLocks()  # one decision per frame when its first requests come together


def write_pictures(store: FrameStore, layout: JobLayout, index: int, srgb: np.ndarray) -> None:
    """The frame's PNG and thumbnail from its sRGB pixels (the assembler's
    and the first request's one writer, so both give the same bytes)."""
    write_png(srgb, store.prepare(layout.frame(index, "png")))
    h, w = srgb.shape[:2]
    step = max(1, max(w, h) // THUMBNAIL_SIZE)
    write_png(np.ascontiguousarray(srgb[::step, ::step]), store.prepare(layout.thumbnail(index)))


def path_of(layout: JobLayout, index: int, kind: str) -> Path:
    if kind == "thumbnail":
        return layout.thumbnail(index)
    if kind in ("png", "exr", "json"):
        return layout.frame(index, kind)
    raise ValueError(f"a derived frame file is one of {', '.join(KINDS)}, not {kind!r}")


def frame_file(settings: Settings, job_id: str, index: int, kind: str) -> Path | None:
    """The path of frame ``index``'s file ``kind`` (png, thumbnail, exr,
    json), written now if it is not yet: the frame decided again from the
    job's root field, the frame the workers rendered, to the bit. A PNG
    request writes the thumbnail too, and the other way round (one
    decision, two cheap files); the EXR (some 100 ms to encode at 512x512)
    only when asked for; the JSON from the frame's figures. None while the
    frame is not done (or there is no such frame)."""
    store = store_for(settings)
    layout = store.job(job_id)
    path = path_of(layout, index, kind)
    if path.exists():
        return path
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.scene, Job.width, Job.height, Job.method, Job.tile, Job.engine)
                        .where(Job.id == job_id)).first()
        frame = c.execute(select(Frame.status, Frame.sigma, Frame.delta, Frame.figures)
                          .where(Frame.job_id == job_id, Frame.index == index)).first()
    if job is None or frame is None or frame.status != "done":
        return None
    if kind == "json":  # (the frame's figures, without the farm's own: nothing to decide)
        figures = {k: v for k, v in (frame.figures or {}).items() if k not in ASSEMBLY_FIGURES}
        store.write_atomic(store.prepare(path), figures_json(figures, index))
        return path
    with _locks.hold((settings.sqlalchemy_url, job_id, index)):
        if path.exists():
            return path
        params = FrameParams(sigma=frame.sigma, delta=frame.delta, width=job.width, height=job.height,
                             method=job.method, samples=samples_of(job.scene), engine=EngineOptions.from_stored(job.engine))
        result, _source = render_band(settings, job_id, scene_from_dict(job.scene), params, job.tile)
        if kind == "exr":
            write_exr(result, store.prepare(path), compression=settings.exr_compression)
        else:
            write_pictures(store, layout, index, to_srgb8(result.rgba))
    return path


def frame_files(settings: Settings, job_id: str, n_frames: int, kind: str) -> list[Path]:
    """frame_file for every frame of a done job, in order (the animation's
    and the atlas's inputs). Raises FileNotFoundError if a frame is not done."""
    paths = []
    for i in range(n_frames):
        path = frame_file(settings, job_id, i, kind)
        if path is None:
            raise FileNotFoundError(f"frame {i} of job {job_id} is not done")
        paths.append(path)
    return paths
