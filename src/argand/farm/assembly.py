"""Tiles -> a frame's figures (and files); frames -> the job's animation.

The commit that completes a frame elects its assembler (compare-and-set on
the frame's state); assembly is idempotent. With Settings.files_on_request
(the default) it adds up the tiles' figures into the frame's row: every
file of the frame (PNG, thumbnail, EXR, JSON) and the animation are made
on their first request (argand.farm.derived; the pictures from the job's
root field, the JSON from the row), so no encoding and no file stands
between the last tile and the job's end. Otherwise it
writes the frame's EXR (unless exr_on_request), PNG, thumbnail and GIF
fragment from the workers' tiles, and the frame that completes the job
splices the animation from the fragments (argand.media.gif). The WebP, the
MP4 and a grid's atlas.png are made from the frames' files on their first
request either way."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import OpenImageIO as oiio
from sqlalchemy import bindparam, func, select, update
from sqlalchemy.exc import NoResultFound

from argand.farm import derived
from argand.farm.database import clock, engine_for
from argand.farm.layout import JobLayout
from argand.farm.models import Frame, Job, Tile
from argand.farm.planning import samples_of, tile_rects
from argand.farm.settings import Settings
from argand.farm.states import FRAME, JOB
from argand.farm.store import FrameStore, store_for
from argand.media import gif
from argand.media.atlas import atlas_png as draw_atlas
from argand.media.contact_sheet import cell_size, scale_to_cell
from argand.render.options import EngineOptions
from argand.render.frames import AOV_CHANNELS, INTERLEAVED_CHANNELS, STATUS_NAMES, FrameParams, FrameResult, frame_figures
from argand.frames.frame_set import FrameSet, FramePoint
from argand.media.atomic import atomic_path
from argand.media.frame_files import to_srgb8, write_frame
from argand.media.video import Mp4Encoder


def maybe_assemble(settings: Settings, job_id: str, frame_index: int, assembler: str = "reaper",
                   local: dict[int, Any] | None = None, frame_px: np.ndarray | None = None) -> bool:
    """Assembles the frame if all its tiles are done and nobody else is at
    it (compare-and-set on the frame's state); the last frame also makes the
    animation and finishes the job. ``frame_px``: the whole frame, rendered
    in place by this process (every tile in ``local``)."""
    with engine_for(settings.sqlalchemy_url).begin() as c:
        since = clock(c)  # the reaper compares it with its own reading of this clock
        won = c.execute(update(Frame).where(
            Frame.job_id == job_id, Frame.index == frame_index, Frame.status.in_(FRAME.sources("assembling")),
            Frame.tiles_done >= Frame.tiles_total,
        ).values(status="assembling", assembler=assembler, assembling_since=since)).rowcount
    if not won:
        return False
    assemble_frame(settings, job_id, frame_index, local, frame_px=frame_px)
    finish_job_if_last(settings, job_id)
    return True


def maybe_assemble_many(settings: Settings, job_id: str, frames: list[tuple[int, dict[int, Any]]],
                        assembler: str) -> set[int]:
    """maybe_assemble for several frames of one job whose tiles this process
    finished together (a run's window of frames): one compare-and-set
    electing this process for those that are complete and nobody else
    assembles, their assembly (the tiles in ``frames``' local dicts from
    memory, the others from the store), one transaction marking them done,
    then the job's end if they were its last. Returns the frames it assembled."""
    if not frames:
        return set()
    with engine_for(settings.sqlalchemy_url).begin() as c:
        since = clock(c)  # the reaper compares it with its own reading of this clock
        won = set(c.execute(update(Frame).where(
            Frame.job_id == job_id, Frame.index.in_([f for f, _ in frames]),
            Frame.status.in_(FRAME.sources("assembling")), Frame.tiles_done >= Frame.tiles_total,
        ).values(status="assembling", assembler=assembler, assembling_since=since).returning(Frame.index)).scalars())
    known = _frames_known(settings, job_id, sorted(won)) if won else None
    figures = {f: assemble_frame(settings, job_id, f, local, commit=False, known=known) for f, local in frames
               if f in won}
    if figures:
        with engine_for(settings.sqlalchemy_url).begin() as c:
            # (One statement for the frames, executed for each: executemany.)
            done = (update(Frame).where(Frame.job_id == job_id, Frame.index == bindparam("f"),
                                        Frame.status == FRAME.step("assembling", "done"))
                    .values(status="done", figures=bindparam("fig", type_=Frame.figures.type),
                            assembly_s=bindparam("s"), finished=bindparam("at")))
            now = time.time()
            c.execute(done, [{"f": f, "fig": fig, "s": fig["assembly_s"], "at": now} for f, fig in figures.items()])
        store = store_for(settings)
        for f in figures:
            store.remove_tiles(job_id, f)
        finish_job_if_last(settings, job_id)
    return won


def finish_job_if_last(settings: Settings, job_id: str) -> None:
    """When every frame is done: the animation, then the job is done."""
    url = settings.sqlalchemy_url
    with engine_for(url).connect() as c:
        remaining = c.execute(select(func.count()).select_from(Frame).where(
            Frame.job_id == job_id, Frame.status != "done")).scalar()
        status = c.execute(select(Job.status).where(Job.id == job_id)).scalar()
    if remaining == 0 and status is not None and JOB.allowed(status, "done"):
        if not settings.files_on_request:
            build_animation(settings, job_id)
        store_for(settings).clean_finished_job(job_id)  # (every frame is done: no chunk is read again)
        with engine_for(url).begin() as c:
            c.execute(update(Job).where(Job.id == job_id, Job.status.in_(JOB.sources("done")))
                      .values(status="done", finished=time.time()))


def _gather(store: FrameStore, job_id: str, frame_index: int, rects, local: dict[int, Any], chunks: dict[int, str | None],
            frame_px: np.ndarray | None, px: np.ndarray | None) -> tuple[int, int, np.ndarray, np.ndarray | None]:
    """Copies every tile into ``px`` (unless it is ``frame_px`` already, or
    None: the frame's figures only): this process's tiles from memory, the
    others from their chunk files. Returns (escalations, root calls, [pixels
    per status code, hits], pixels per ladder level or None where a tile did
    not count them: a tile stored by an earlier version, which counted them
    from the pixels)."""
    stored: dict[int, dict[str, np.ndarray]] = {}
    for name in {chunks[i] for i in chunks if i not in local and chunks[i]}:
        stored.update(store.read_chunk(job_id, frame_index, name))
    escalations = calls = 0
    stats = np.zeros(len(STATUS_NAMES) + 1, np.int64)
    levels: np.ndarray | None = None
    counted = True  # every tile counted its ladder levels
    for i, (x0, y0, x1, y1) in enumerate(rects):
        if i in local:
            block, esc, n, st, lv = local[i]
        else:
            d = stored[i]
            block, (esc, n), st, lv = d.get("px"), d["meta"][:2], d["meta"][2:], d.get("levels")
        if px is not None and frame_px is None:
            px[y0:y1, x0:x1] = block
        escalations += int(esc)
        calls += int(n)
        stats += st
        if lv is None:
            counted = False
        elif counted:
            levels = np.array(lv, np.int64) if levels is None else levels + lv
    return escalations, calls, stats, levels if counted else None


def _write_files(settings: Settings, store: FrameStore, layout: JobLayout, index: int, result: FrameResult,
                 px: np.ndarray) -> None:
    """The frame's PNG, figures, thumbnail and GIF fragment, and its EXR
    unless it is written on request (Settings.exr_on_request)."""
    srgb = to_srgb8(result.rgba)
    # The frame's files as `argand render` writes them (the one writer).
    write_frame(result, layout.folder, index, exr=px, srgb8=srgb, compression=settings.exr_compression,
                with_exr=not settings.exr_on_request)
    derived.write_pictures(store, layout, index, srgb)
    store.write_atomic(store.prepare(layout.gif_fragment(index)), gif.encode_frame(srgb))


def _frames_known(settings: Settings, job_id: str, frames: list[int]) -> dict:
    """What assembling ``frames`` of a job reads from the database, in four
    queries for all of them: the job's row, each frame's (σ, δ), the sum of
    its tiles' render seconds and its tiles' chunk names; and the job's
    tiles' rectangles and engine options."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.width, Job.height, Job.tile, Job.method, Job.scene, Job.engine)
                        .where(Job.id == job_id)).one()
        bands = {i: (sg, dl) for i, sg, dl in c.execute(select(Frame.index, Frame.sigma, Frame.delta).where(
            Frame.job_id == job_id, Frame.index.in_(frames))).all()}
        mine = (Tile.job_id == job_id, Tile.frame_index.in_(frames))
        seconds = {f: sec or 0.0 for f, sec in c.execute(
            select(Tile.frame_index, func.sum(Tile.seconds)).where(*mine).group_by(Tile.frame_index)).all()}
        chunks: dict[int, dict[int, str | None]] = {}
        for f, t, name in c.execute(select(Tile.frame_index, Tile.tile_index, Tile.chunk).where(*mine)).all():
            chunks.setdefault(f, {})[t] = name
    missing = set(frames) - set(bands)
    if missing:
        raise NoResultFound(f"job {job_id} has no frame {min(missing)}")
    # (What every frame of the job shares, made once for all of them.)
    return {"job": job, "bands": bands, "seconds": seconds, "chunks": chunks,
            "rects": tile_rects(job.width, job.height, job.tile), "engine": EngineOptions.from_stored(job.engine)}


def assemble_frame(settings: Settings, job_id: str, frame_index: int, local: dict[int, Any] | None = None,
                   seconds: float | None = None, commit: bool = True, frame_px: np.ndarray | None = None,
                   known: dict | None = None) -> dict:
    """Tiles -> the frame's figures and files (idempotent; with
    files_on_request the figures and the JSON only). Tiles this process
    rendered are taken from memory, the others from the store; the EXR's
    interleaved buffer is filled directly. With ``commit`` the frame is
    marked done and its tile files dropped. Returns the frame's figures."""
    t_start = time.perf_counter()
    store, local = store_for(settings), local or {}
    if known is None:
        known = _frames_known(settings, job_id, [frame_index])
    job = known["job"]
    sigma, delta = known["bands"][frame_index]
    if seconds is None:
        seconds = known["seconds"].get(frame_index, 0.0)
    rects = known["rects"]
    chunks = {} if len(local) == len(rects) else known["chunks"].get(frame_index, {})
    w, h = job.width, job.height
    params = FrameParams(sigma=sigma, delta=delta, width=w, height=h, method=job.method, samples=samples_of(job.scene),
                         engine=known["engine"])
    layout = store.job(job_id)
    lazy = settings.files_on_request
    if lazy:
        # The figures only: the tiles' counts (their pixels were not kept).
        escalations, calls, stats, levels = _gather(store, job_id, frame_index, rects, local, chunks, None, None)
        # (Tiles stored by an earlier version kept their pixels and no
        # levels: that frame's files are written now, from its pixels.)
        lazy = levels is not None
    if lazy:
        result = FrameResult(params, np.empty((0, 0, 4), np.float32), {}, seconds, escalations, calls, stats=stats,
                             levels=levels)
        result.figures = frame_figures(result)
        t_encode = time.perf_counter()
        # (Its JSON too is written on its first request: derived.frame_file.)
    else:
        px = frame_px if frame_px is not None else np.empty((h, w, len(INTERLEAVED_CHANNELS)), np.float32)
        escalations, calls, stats, _levels = _gather(store, job_id, frame_index, rects, local, chunks, frame_px, px)
        aovs = {name: px[..., INTERLEAVED_CHANNELS.index(name)] for name in AOV_CHANNELS}
        result = FrameResult(params, px[..., :4], aovs, seconds, escalations, calls, stats=stats)
        result.figures = frame_figures(result)
        t_encode = time.perf_counter()
        _write_files(settings, store, layout, frame_index, result, px)
    t_end = time.perf_counter()
    # Where the assembler's time went (argand bench farm reports it).
    figures = dict(result.figures, assembly_s=t_end - t_start, encode_s=t_end - t_encode)  # (derived.ASSEMBLY_FIGURES)
    if commit:
        with engine_for(settings.sqlalchemy_url).begin() as c:
            c.execute(update(Frame).where(Frame.job_id == job_id, Frame.index == frame_index,
                                          Frame.status == FRAME.step("assembling", "done"))
                      .values(status="done", figures=figures, assembly_s=figures["assembly_s"], finished=time.time()))
        store.remove_tiles(job_id, frame_index)
    return figures


def build_animation(settings: Settings, job_id: str, fps: float = 8.0) -> None:
    """animation.gif, spliced from the frames' GIF fragments (no frame is
    encoded again)."""
    store = store_for(settings)
    layout = store.job(job_id)
    with engine_for(settings.sqlalchemy_url).connect() as c:
        n = c.execute(select(func.count()).select_from(Frame).where(Frame.job_id == job_id)).scalar()
    fragments = [layout.gif_fragment(i).read_bytes() for i in range(n)]
    store.write_atomic(layout.animation("gif"), gif.splice(fragments, fps=fps))


def animation_gif(settings: Settings, job_id: str, n_frames: int, fps: float = 8.0) -> None:
    """animation.gif of a done job, made on its first request where the
    assembler did not splice it (files_on_request): each frame's GIF
    fragment encoded from its PNG (made first where missing), then spliced
    as build_animation splices the assembler's, so the file is the same
    bytes either way. Two first requests at once each write a whole file;
    the last rename wins."""
    store = store_for(settings)
    layout = store.job(job_id)
    path = layout.animation("gif")
    if path.exists():
        return
    fragments = [gif.encode_frame(picture) for picture in _frame_pngs(settings, job_id, n_frames)]
    store.write_atomic(path, gif.splice(fragments, fps=fps))


def _frame_pngs(settings: Settings, job_id: str, n_frames: int):
    """The frames' PNGs as (h, w, 3) uint8, one at a time (each made first
    where it is not yet: argand.farm.derived)."""
    for path in derived.frame_files(settings, job_id, n_frames, "png"):
        yield oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8)[..., :3]


def animation_webp(settings: Settings, job_id: str, n_frames: int, fps: float = 8.0) -> bool:
    """animation.webp from the frames' PNGs, made once and kept (False: this
    installation's Pillow has no WebP)."""
    store = store_for(settings)
    layout = store.job(job_id)
    path = layout.animation("webp")
    if path.exists():
        return True
    data = gif.encode_animation_webp(list(_frame_pngs(settings, job_id, n_frames)), fps=fps)
    if data is None:
        return False
    store.write_atomic(path, data)
    return True


def animation_mp4(settings: Settings, job_id: str, n_frames: int, fps: float = 8.0) -> None:
    """animation.mp4 (H.264, yuv420p) from the frames' PNGs, read and encoded
    one at a time, made on first request and kept: encoding it is no step
    between the last frame and the job's end. Two first requests at once
    each write their own temporary file; the last rename wins, whole."""
    layout = store_for(settings).job(job_id)
    path = layout.animation("mp4")
    if path.exists():
        return
    with atomic_path(path) as tmp, Mp4Encoder(tmp, fps) as encoder:
        for picture in _frame_pngs(settings, job_id, n_frames):
            encoder.add(picture)


def atlas_png(settings: Settings, job_id: str) -> bool:
    """atlas.png of a finished grid job, from the frames' thumbnails, made on
    first request and kept (False: the job is not a grid of several σ and δ)."""
    store = store_for(settings)
    layout = store.job(job_id)
    path = layout.atlas()
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.scene_name, Job.width, Job.height).where(Job.id == job_id)).one()
        rows = c.execute(select(Frame.sigma_index, Frame.delta_index, Frame.sigma, Frame.delta)
                         .where(Frame.job_id == job_id).order_by(Frame.index)).all()
    grid = FrameSet.from_points([FramePoint(*r) for r in rows])
    if not grid.is_grid:
        return False
    if path.exists():
        return True
    size = cell_size(job.width, job.height)
    thumbnails = derived.frame_files(settings, job_id, len(grid), "thumbnail")
    cells = {i: scale_to_cell(oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8)[..., :3], size)
             for i, path in enumerate(thumbnails)}
    title = f"{job.scene_name}: {len(grid)} frames of {job.width}x{job.height}"
    store.write_atomic(path, draw_atlas(grid, cells, job.width, job.height, title=title))
    return True
