"""How a job becomes work (pure functions, no I/O): a frame's C++ plan (the
submission's check and the worker's first step alike), the tile rectangles,
the frames' sending order, and runs of tiles of one frame."""

from __future__ import annotations

from typing import Any, Sequence

from argand.render.convert import to_core_scene
from argand.render.frames import FrameParams, plan, tiles
from argand.render.options import EngineOptions
from argand.scene import Scene, scene_from_dict

Rect = tuple[int, int, int, int]

#: A job's tile size, in pixels (a side).
MIN_TILE, MAX_TILE = 8, 4096


def core_scene_of(scene: Scene | dict) -> Any:
    """A job's scene, validated (a submission's) or as stored (a worker's),
    as the renderer takes it: the one way for both."""
    return to_core_scene(scene if isinstance(scene, Scene) else scene_from_dict(scene))


def frame_plan(core_scene: Any, sigma: float, delta: float, width: int, height: int, method: str, samples: int = 1,
               engine: EngineOptions = EngineOptions()):
    """A frame's C++ plan: what a worker builds before its first tile, and
    what a submission builds for every frame, so that a frame that cannot be
    planned (the band rule, a camera or a coefficient out of range) is
    refused at the door instead of failing in a worker. Raises ValueError."""
    return plan(core_scene, FrameParams(sigma=sigma, delta=delta, width=width, height=height, method=method,
                                        samples=samples, engine=engine))


def preview_order(n_frames: int, stride: int = 4, positions: Sequence[tuple[int, int]] | None = None) -> list[int]:
    """Every stride-th frame first, then the gaps: a coarse preview of the
    whole animation appears early. On a grid (``positions``: each frame's
    (row, column), more than one of each) every fourth frame is every other
    row and column: the frames at (even, even) first, then (even, odd),
    (odd, even) and (odd, odd), each in frame order, so a coarse atlas fills
    in early; a single row or column is a sweep as above."""
    if positions is not None and len({r for r, _ in positions}) > 1 and len({c for _, c in positions}) > 1:
        if len(positions) != n_frames:
            raise ValueError(f"{len(positions)} positions for {n_frames} frames")
        phase = [(r % 2, c % 2) for r, c in positions]
        return [i for p in ((0, 0), (0, 1), (1, 0), (1, 1)) for i in range(n_frames) if phase[i] == p]
    order: list[int] = []
    for start in range(stride):
        order += list(range(start, n_frames, stride))
    return order


def tile_rects(width: int, height: int, tile: int) -> list[Rect]:
    """A stored job's tiles (argand.render.frames.tiles, whose order gives
    the tile indices) as (x0, y0, x1, y1). Any size a job was stored with
    is taken (a job submitted before tiles were multiples of 8 goes on with
    its own tiling); new jobs are checked at submission (check_tile)."""
    return [(r.x0, r.y0, r.x1, r.y1) for r in tiles(width, height, tile)]


def _area(rect: Rect) -> int:
    x0, y0, x1, y1 = rect
    return (x1 - x0) * (y1 - y0)


def batch_runs(tile_indices: list[int], rects: list[Rect], target_pixels: int) -> list[list[int]]:
    """Splits a frame's tile indices (in order) into runs of about
    ``target_pixels`` pixels (one tile at least)."""
    runs: list[list[int]] = []
    run: list[int] = []
    pixels = 0
    for t in tile_indices:
        run.append(t)
        pixels += _area(rects[t])
        if pixels >= target_pixels:
            runs.append(run)
            run, pixels = [], 0
    if run:
        runs.append(run)
    return runs


def plan_runs(by_frame: dict[int, list[int]], n_frames: int, rects: list[Rect], batch_pixels: int,
              workers: int, positions: Sequence[tuple[int, int]] | None = None,
              window: int = 1) -> list[tuple[int, list[int]]]:
    """The messages, in sending order, as (frame, tiles): frames in preview
    order, runs of at most ``batch_pixels``, small enough that every worker
    gets four or more; ``positions``: the frames' grid places (preview_order).
    (Cutting the last runs smaller, so that the workers
    finish together, was measured: the tiles' trip through the store costs
    what the balance saves, 36 frames of 512x512 on two workers.)

    ``window`` > 1 (the farm's frames keep only their figures, and a run
    renders its tiles of ``window`` frames at once: settings.run_bands):
    in each window of frames, a tile's message goes to the first frame of
    the window where the tile is queued, and carries the same tile of the
    window's later frames (claimed with it, tile_work.claim_siblings: one
    solve a tile for the window). Every queued (frame, tile) is so covered
    by one message, and the runs are cut so that every worker gets four or
    more."""
    if window <= 1:
        pixels = sum(_area(rects[t]) for ts in by_frame.values() for t in ts)
        target = max(1, min(batch_pixels, pixels // (4 * workers)))
        return [(f, run) for f in preview_order(n_frames, positions=positions)
                for run in batch_runs(by_frame.get(f, []), rects, target)]
    leads: dict[int, list[int]] = {}
    for start in range(0, n_frames, window):
        first: dict[int, int] = {}
        for f in range(start, min(n_frames, start + window)):
            for t in by_frame.get(f, []):
                first.setdefault(t, f)
        for t, f in sorted(first.items()):
            leads.setdefault(f, []).append(t)
    pixels = sum(_area(rects[t]) for ts in leads.values() for t in ts)
    target = max(1, min(max(1, batch_pixels * 4 // window), pixels // (4 * workers)))
    return [(f, run) for f in sorted(leads) for run in batch_runs(leads[f], rects, target)]


def batch_pixels(rays: int, scene: dict) -> int:
    """A message's most pixels for a job: ``rays`` (settings.batch_pixels) traced rays,
    so a job of N samples per pixel gets runs N times fewer pixels (a
    message's time, and so the time limits, stay what they are at 1)."""
    return max(1, rays // samples_of(scene))


def samples_of(scene: dict) -> int:
    """A job's samples per pixel: its stored scene's (argand.scene.Scene.samples;
    the HTTP field ``samples`` is stored there)."""
    return int(scene.get("samples", 1))
