"""Frames: plan once in C++, render tiles (in threads, GIL released), assemble.

``render_tile(scene, params, rect) -> TileAOVs`` renders one tile from
scratch (scene, frame parameters, tile rectangle in, AOV arrays out). The
farm's workers plan a frame once (``plan``) and render their tiles with
``render_tile_into``, straight into the EXR's interleaved layout.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable, Iterable, Iterator, Sequence

import numpy as np

from argand.core import _core
from argand.render.exact import decide_pixel
from argand.render.field import RootField
from argand.render.options import EngineOptions

#: AOV names, in the order they are stored in EXR files after R, G, B, A
#: (the one channel list: the farm, the EXR writer and the tests read it).
#: ``escalation`` is the ladder level a pixel needed (LADDER_LEVEL_NAMES);
#: ``certified_share`` the share of the pixel's samples that are certified.
AOV_CHANNELS = tuple(name for name, _dtype in _core.AOVS)
#: Each AOV's array type as the renderer writes it (the EXR stores all as
#: float32): render.h's kAovs, the one table of them (_core.AOVS).
AOV_DTYPES = {name: np.dtype(dtype).type for name, dtype in _core.AOVS}

#: Pixel status codes (the ``status`` AOV), defined in C++ (render.h's
#: PixelStatus and kStatusNames); docs/rendering.md says what each one proves.
STATUS_NAMES: dict[int, str] = dict(_core.STATUS_NAMES)

#: Ladder levels (the ``escalation`` AOV): how far a pixel had to go before
#: its decision was proven (or the ladder ran out). Defined in C++.
LADDER_LEVEL_NAMES: dict[int, str] = dict(_core.LADDER_LEVEL_NAMES)
_LEVEL = {name: level for level, name in LADDER_LEVEL_NAMES.items()}
#: A cluster re-isolated in double from the ray polynomial about it, and
#: discs refined with double-double ray coefficients.
REBASED_LEVEL = _LEVEL["rebased ray"]
DOUBLE_DOUBLE_LEVEL = _LEVEL["double-double ray"]
#: The exact tier's levels (argand.render.exact decides the pixel on the exact
#: rational ray polynomial), and the level of a pixel the tier's per-tile
#: budget left undecided.
EXACT_LEVEL = _LEVEL["exact"]
EXACT_MULTIPLE_LEVEL = _LEVEL["exact: multiple root proven"]
EXACT_LEVELS = (EXACT_LEVEL, EXACT_MULTIPLE_LEVEL)
EXACT_OVER_CAP_LEVEL = _LEVEL["exact: over the work cap"]

#: The exact tier's bounds (defined in C++): the rays per 8x8 block of
#: samples it may take (a frame-aligned block, so the frame does not depend
#: on its tiling) and its highest working precision in bits, by default (FrameParams'
#: exact_pixels_per_block and exact_max_bits), and the largest precision a
#: frame may ask for.
EXACT_PIXELS_PER_BLOCK: int = _core.EXACT_PIXELS_PER_BLOCK
EXACT_DEFAULT_BITS: int = _core.EXACT_DEFAULT_BITS
EXACT_BITS_LIMIT: int = _core.EXACT_BITS_LIMIT

#: Most objects in one scene, the largest frame side, and the band rule (all
#: defined in C++, where plan_frame enforces them).
MAX_OBJECTS: int = _core.MAX_OBJECTS
MAX_FRAME_SIDE: int = _core.MAX_FRAME_SIDE
BAND_RULE: str = _core.BAND_RULE
#: Most samples per pixel (a square: 1, 4, 9, ..., MAX_SAMPLES).
MAX_SAMPLES: int = _core.MAX_SAMPLES


@dataclass(frozen=True)
class FrameParams:
    """What a frame needs beyond the scene."""

    sigma: float = 0.0
    delta: float = 0.0
    width: int = 256
    height: int = 256
    method: str = "auto"
    max_depth: int = 3
    hue_by_argument: bool = False
    #: Per pixel, a square (1, 4, ..., MAX_SAMPLES): a side x side grid of
    #: strata, each sampled at its centre.
    samples: int = 1
    #: The exact tier: at most this many rays per 8x8 block of samples (0:
    #: off), up to this many bits of precision.
    exact_pixels_per_block: int = EXACT_PIXELS_PER_BLOCK
    exact_max_bits: int = EXACT_DEFAULT_BITS
    #: The engine's modes (argand.render.options); the defaults unless a
    #: caller passes others (the CLI and the worker read them from the environment).
    engine: EngineOptions = field(default_factory=EngineOptions)

    def __post_init__(self) -> None:
        from argand.scene.model import check_samples

        check_samples(self.samples)
        if not (math.isfinite(self.sigma) and math.isfinite(self.delta)):
            raise ValueError("sigma and delta must be finite numbers")
        if not _core.band_rule_holds(float(self.sigma), float(self.delta)):
            raise ValueError(f"sigma = {self.sigma!r}, delta = {self.delta!r} breaks the band rule: {BAND_RULE}")
        if not (1 <= self.width <= MAX_FRAME_SIDE and 1 <= self.height <= MAX_FRAME_SIDE):
            side = MAX_FRAME_SIDE
            raise ValueError(f"frame size must be between 1x1 and {side}x{side}, got {self.width}x{self.height}")
        if not (isinstance(self.exact_pixels_per_block, int) and self.exact_pixels_per_block >= 0):
            raise ValueError(f"exact_pixels_per_block must be an integer >= 0 (0: no exact tier), "
                             f"got {self.exact_pixels_per_block!r}")
        if not (isinstance(self.exact_max_bits, int) and 64 <= self.exact_max_bits <= EXACT_BITS_LIMIT):
            raise ValueError(f"exact_max_bits must be an integer in 64..{EXACT_BITS_LIMIT}, got {self.exact_max_bits!r}")


@dataclass(frozen=True)
class TileRect:
    x0: int
    y0: int
    x1: int
    y1: int


@dataclass
class TileAOVs:
    """The AOVs of one tile: rgba (h, w, 4) and one (h, w) array per AOV."""

    rect: TileRect
    rgba: np.ndarray
    aovs: dict[str, np.ndarray]
    escalations: int
    root_calls: int


@dataclass
class FrameResult:
    params: FrameParams
    rgba: np.ndarray
    aovs: dict[str, np.ndarray]
    seconds: float
    escalations: int
    root_calls: int
    figures: dict[str, Any] = field(default_factory=dict)
    #: [pixels per status code 0..3, pixels that hit], when the renderer
    #: counted them (render_frame's and the farm's paths); else they are
    #: counted from the AOVs.
    stats: np.ndarray | None = None
    #: Pixels per ladder level (escalation code), when the renderer counted
    #: them (render_frame); else frame_figures counts the AOV.
    levels: np.ndarray | None = None

    @cached_property
    def status_counts(self) -> np.ndarray:
        """Pixels per status code (one pass over the status AOV)."""
        if self.stats is not None:
            return self.stats[: len(STATUS_NAMES)]
        st = np.asarray(self.aovs["status"]).astype(np.intp, copy=False).ravel()
        return np.bincount(st, minlength=len(STATUS_NAMES))

    @property
    def pixels(self) -> int:
        """The frame's pixel count (the shares' denominator; a result built
        from counts alone, the farm's figures of a frame whose files are made
        on request, holds no AOV to count)."""
        return self.params.width * self.params.height

    @property
    def hit_share(self) -> float:
        if self.stats is not None:
            return float(self.stats[len(STATUS_NAMES)] / max(1, self.pixels))
        return float(np.mean(self.rgba[..., 3] > 0))

    @property
    def certified_share(self) -> float:
        """Share of pixels with status 0 (the measured figure; a sampled
        pixel is certified when every one of its samples is)."""
        return float(self.status_counts[0] / max(1, self.pixels))

    def status_shares(self) -> dict[str, float]:
        n = max(1, self.pixels)
        return {name: float(self.status_counts[code] / n) for code, name in STATUS_NAMES.items()}


def plan(core_scene: dict, params: FrameParams) -> Any:
    """Per-frame setup in C++ (camera, Taylor expansion of every surface)."""
    return _core.plan_frame(
        core_scene,
        float(params.sigma),
        float(params.delta),
        int(params.width),
        int(params.height),
        params.method,
        int(params.max_depth),
        bool(params.hue_by_argument),
        exact_pixels_per_block=int(params.exact_pixels_per_block),
        exact_max_bits=int(params.exact_max_bits),
        samples=int(params.samples),
        kernel=params.engine.kernel,
        cull=params.engine.cull,
        real=params.engine.real,
        decide=params.engine.decide,
        shade=params.engine.shade,
    )


def render_tile_planned(frame_plan: Any, rect: TileRect) -> TileAOVs:
    out = _core.render_tile(frame_plan, rect.x0, rect.y0, rect.x1, rect.y1, exact=decide_pixel)
    aovs = {name: out[name] for name in AOV_CHANNELS}
    return TileAOVs(rect, out["rgba"], aovs, int(out["escalations"]), int(out["root_calls"]))


#: The farm's interleaved layout (the EXR's channel order); the C++ writer
#: (render_tile_into) must agree, which the import checks.
INTERLEAVED_CHANNELS = tuple(_core.INTERLEAVED_CHANNELS)  # R, G, B, A, then AOV_CHANNELS


def interleave(rgba: np.ndarray, aovs: Any) -> np.ndarray:
    """(h, w, 4) RGBA and the AOV planes (a mapping by name) -> one
    C-contiguous (h, w, len(INTERLEAVED_CHANNELS)) float32 array in that order."""
    # (Each plane assigned into one preallocated array, converted on the
    # way: half the time of np.stack over converted copies.)
    out = np.empty((*rgba.shape[:2], len(INTERLEAVED_CHANNELS)), np.float32)
    out[..., :4] = rgba
    for k, name in enumerate(AOV_CHANNELS):
        out[..., 4 + k] = aovs[name]
    return out


def render_tile_into(frame_plan: Any, rect: TileRect, out: np.ndarray, ox: int = 0,
                     oy: int = 0) -> tuple[int, int, np.ndarray]:
    """Renders ``rect`` into ``out[oy:, ox:]``, a C-contiguous
    (h, w, len(INTERLEAVED_CHANNELS)) float32 array in that order (count,
    status and escalation as floats, exactly). Returns (escalations, root_calls, stats) with stats
    = [pixels per status code 0..3, pixels that hit] (int64)."""
    esc, calls, counts, hits = _core.render_tile_into(frame_plan, rect.x0, rect.y0, rect.x1, rect.y1, out, ox, oy,
                                                      exact=decide_pixel)
    return int(esc), int(calls), np.array([*counts, hits], np.int64)


def render_tile_bands_into(frame_plans: Sequence[Any], rect: TileRect,
                           outs: Sequence[tuple[np.ndarray, int, int] | None],
                           record: list | None = None) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """render_tile_into for several bands of one tile at once (their plans
    differ in σ and δ only; _core.render_tile_bands solves the primary roots
    once): band b's pixels go into outs[b] = (out, ox, oy) as
    render_tile_into writes them, the same bits; outs[b] None: the band's
    figures only (the farm's frames whose files are made on request keep no
    pixels). Returns each band's (escalations, root_calls, stats, pixels per
    ladder level). ``record``: a list the tile's root field (bytes) is
    appended to."""
    h, w = rect.y1 - rect.y0, rect.x1 - rect.x0
    # (A band whose pixels are not kept gets no planes: the core counts its
    # figures without writing a pixel, some half of a band's cost.)
    planes = [None if target_at is None else
              (np.empty((h, w, 4), np.float32),) + tuple(np.empty((h, w), AOV_DTYPES[n]) for n in AOV_CHANNELS)
              for target_at in outs]
    figures = _core.render_tile_bands(list(frame_plans), rect.x0, rect.y0, rect.x1, rect.y1, planes, 0, 0,
                                      exact=decide_pixel, record=record is not None)
    if record is not None:
        figures, tape = figures
        record.append(tape)
    out = []
    for target_at, band, (esc, calls, counts, hits, levels) in zip(outs, planes, figures):
        if target_at is not None:
            block, ox, oy = target_at
            target = block[oy:oy + h, ox:ox + w]
            target[..., :4] = band[0]
            for k, plane in enumerate(band[1:]):
                target[..., 4 + k] = plane
        out.append((int(esc), int(calls), np.array([*counts, hits], np.int64), np.asarray(levels, np.int64)))
    return out


def render_tile(scene: Any, params: FrameParams, rect: TileRect) -> TileAOVs:
    """(scene, frame params, tile rectangle) -> AOV arrays. ``scene`` is a
    :class:`argand.scene.Scene` or an already converted core dict."""
    from argand.render.convert import to_core_scene

    return render_tile_planned(plan(to_core_scene(scene), params), rect)


#: A tile's side is a multiple of this, the renderer's seed block (render.h
#: kSeedBlock): neighbour seeds flow within frame-aligned blocks of 8 x 8
#: samples, so tiles that start on the block grid give a frame the same bits
#: whatever the tile size, thread or worker count. A tile of another size
#: would start inside a block and begin without the seeds its pixels get
#: in any other tiling (a cluster's centre or the conjugate the solver
#: lists first would then depend on the cut).
TILE_MULTIPLE = 8


def check_tile(size: int) -> int:
    """``size`` if it is a tile size the renderer takes (a positive multiple
    of TILE_MULTIPLE); else ValueError saying why."""
    if isinstance(size, bool) or not isinstance(size, int) or size < TILE_MULTIPLE or size % TILE_MULTIPLE:
        lower = max(TILE_MULTIPLE, size // TILE_MULTIPLE * TILE_MULTIPLE) if isinstance(size, int) else TILE_MULTIPLE
        raise ValueError(
            f"tile size must be a multiple of {TILE_MULTIPLE} pixels (got {size!r}; e.g. {lower} or "
            f"{lower + TILE_MULTIPLE}): tiles on the renderer's {TILE_MULTIPLE}x{TILE_MULTIPLE} seed blocks keep "
            f"a frame the same bits whatever its tiling")
    return size


def tiles(width: int, height: int, size: int) -> list[TileRect]:
    """The frame's tiles of ``size`` pixels, row by row: geometry only (a
    stored job keeps the tiling it was made with; what a new render may use
    is check_tile's)."""
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        raise ValueError(f"tile size must be a positive integer, got {size!r}")
    return [
        TileRect(x, y, min(x + size, width), min(y + size, height))
        for y in range(0, height, size)
        for x in range(0, width, size)
    ]


def render_frame(
    scene: Any,
    params: FrameParams,
    tile: int = 64,
    workers: int | None = None,
    on_tile: Callable[[TileAOVs], None] | None = None,
) -> FrameResult:
    """Renders a whole frame locally on ``workers`` threads (default: all
    cores); the C++ tile renderer releases the GIL."""
    return render_bands(scene, [params], tile=tile, workers=workers, on_tile=on_tile)[0]


class _FramePlanes:
    """A frame's arrays, written tile by tile by _core.render_tile_bands
    (every AOV of every pixel, so they start unset), and its figures as the
    tiles counted them while writing their pixels (no pass over the AOVs)."""

    def __init__(self, params: FrameParams) -> None:
        w, h = params.width, params.height
        self.params = params
        self.rgba = np.empty((h, w, 4), np.float32)
        self.aovs = {name: np.empty((h, w), AOV_DTYPES[name]) for name in AOV_CHANNELS}
        self.planes = (self.rgba,) + tuple(self.aovs[name] for name in AOV_CHANNELS)
        self.escalations = self.calls = 0
        self.stats = np.zeros(len(STATUS_NAMES) + 1, np.int64)
        self.levels = np.zeros(8, np.int64)

    def add(self, figures: tuple) -> None:
        esc, n_calls, by_status, hits, by_level = figures
        self.escalations += esc
        self.calls += n_calls
        self.stats[: len(STATUS_NAMES)] += by_status
        self.stats[len(STATUS_NAMES)] += hits
        self.levels[:] += by_level

    def tile(self, r: TileRect, esc: int, n_calls: int) -> TileAOVs:
        # (Views of the frame's arrays: the tile's pixels, as rendered.)
        return TileAOVs(r, self.rgba[r.y0 : r.y1, r.x0 : r.x1],
                        {name: self.aovs[name][r.y0 : r.y1, r.x0 : r.x1] for name in AOV_CHANNELS}, esc, n_calls)

    def result(self, seconds: float) -> FrameResult:
        out = FrameResult(self.params, self.rgba, self.aovs, seconds, self.escalations, self.calls, stats=self.stats,
                          levels=self.levels)
        out.figures = frame_figures(out)
        return out


def same_rays(a: FrameParams, b: FrameParams) -> bool:
    """Whether two frames differ in their band (σ, δ) only: then they share
    their rays and roots, and render_bands renders them together."""
    return dataclasses.replace(b, sigma=a.sigma, delta=a.delta) == a


def render_bands(
    scene: Any,
    params: Sequence[FrameParams],
    tile: int = 64,
    workers: int | None = None,
    on_tile: Callable[[TileAOVs], None] | None = None,
    field: RootField | None = None,
    record: RootField | None = None,
    any_tile: bool = False,
) -> list[FrameResult]:
    """Renders frames that differ only in their band (σ, δ) together: each
    tile's primary roots are solved once for all of them (the roots do not
    depend on the band), then every band is decided, escalated and shaded
    on its own. Each frame is, to the bit, what render_frame gives for its
    parameters alone. Raises ValueError if the frames differ in anything but
    σ and δ. A frame's seconds are the bands' shared time, divided evenly.

    ``field``: a root field recorded for these rays with this tile size
    (RootField.covers): the roots are read from it, not solved (the same
    bits). ``record``: an empty RootField(fingerprint=0, ...) that receives
    the tiles' fields as they are solved (its fingerprint and size set).
    ``any_tile``: take a tile size that is not a multiple of TILE_MULTIPLE
    (a job stored before tiles had to be, rendered again with its own tiling)."""
    from argand.render.convert import to_core_scene

    if not params:
        return []
    first = params[0]
    for p in params[1:]:
        if not same_rays(first, p):
            raise ValueError("render_bands: the frames must differ in sigma and delta only")
    start = time.perf_counter()
    core_scene = to_core_scene(scene)
    plans = [plan(core_scene, p) for p in params]
    frames = [_FramePlanes(p) for p in params]
    if not any_tile:
        check_tile(tile)
    rects = tiles(first.width, first.height, tile)
    n_workers = max(1, workers or os.cpu_count() or 1)
    if field is not None and not field.covers(plans[0], tile):
        raise ValueError("render_bands: the root field was recorded for other rays or another tile size")
    if record is not None:
        record.fingerprint = int(_core.rays_fingerprint(plans[0]))
        record.width, record.height, record.tile = first.width, first.height, tile
        record.tiles.clear()

    def render(r: TileRect) -> tuple:
        outs = [f.planes for f in frames]
        if record is not None:
            figures, tape = _core.render_tile_bands(plans, r.x0, r.y0, r.x1, r.y1, outs, exact=decide_pixel,
                                                    record=True)
            record.tiles[(r.x0, r.y0, r.x1, r.y1)] = tape
            return r, figures
        tape = field.tiles[(r.x0, r.y0, r.x1, r.y1)] if field is not None else None
        return r, _core.render_tile_bands(plans, r.x0, r.y0, r.x1, r.y1, outs, exact=decide_pixel, field=tape)

    def place(done: tuple) -> None:
        r, figures = done
        for frame, fig in zip(frames, figures):
            frame.add(fig)
            if on_tile:
                on_tile(frame.tile(r, fig[0], fig[1]))

    if n_workers == 1:
        for r in rects:
            place(render(r))
    else:
        with ThreadPoolExecutor(n_workers) as pool:
            for done in pool.map(render, rects):
                place(done)
    seconds = (time.perf_counter() - start) / len(params)
    return [f.result(seconds) for f in frames]


def frame_figures(result: FrameResult) -> dict[str, Any]:
    p = result.params
    n = p.width * p.height
    if result.levels is not None:
        levels = result.levels
    else:
        levels = np.bincount(np.asarray(result.aovs["escalation"]).astype(np.intp, copy=False).ravel(),
                             minlength=len(LADDER_LEVEL_NAMES))
    exact = int(sum(levels[k] for k in EXACT_LEVELS))
    return {
        "sigma": p.sigma,
        "delta": p.delta,
        "width": p.width,
        "height": p.height,
        "method": p.method,
        "samples": p.samples,
        "seconds": result.seconds,
        "ns_per_pixel": result.seconds / n * 1e9,
        "ns_per_sample": result.seconds / (n * p.samples) * 1e9,
        "certified_share": result.certified_share,
        "status_shares": result.status_shares(),
        "hit_share": result.hit_share,
        "escalations": result.escalations,
        "escalated_share": result.escalations / n,
        # Pixels per ladder level (LADDER_LEVEL_NAMES), and the exact tier's
        # share: pixels it decided or tried (EXACT_LEVELS), multiple roots it
        # proved, pixels its per-block budget left out.
        "escalation_levels": {LADDER_LEVEL_NAMES[k]: int(levels[k]) for k in range(len(LADDER_LEVEL_NAMES))},
        "exact_pixels": exact,
        "exact_share": exact / n,
        "exact_multiple_roots": int(levels[EXACT_MULTIPLE_LEVEL]),
        "exact_over_cap": int(levels[EXACT_OVER_CAP_LEVEL]),
        "exact_pixels_per_block": p.exact_pixels_per_block,
        "exact_max_bits": p.exact_max_bits,
        "root_calls": result.root_calls,
    }


def delta_sweep(start: float, stop: float, count: int) -> list[float]:
    """``count`` values from start to stop inclusive (one if count == 1)."""
    if count < 1:
        raise ValueError("the number of frames must be >= 1")
    if count == 1:
        return [float(start)]
    return [float(v) for v in np.linspace(start, stop, count)]


def render_frames(
    scene: Any, params_list: Iterable[FrameParams], tile: int = 64, workers: int | None = None,
    bands_at_once: int = 32,
) -> Iterator[FrameResult]:
    """The frames of ``params_list`` in order, rendered ``bands_at_once`` at
    a time where they differ only in σ and δ (render_bands)."""
    batch: list[FrameParams] = []
    for p in params_list:
        if batch and (len(batch) == bands_at_once or
                      not same_rays(batch[0], p)):
            yield from render_bands(scene, batch, tile=tile, workers=workers)
            batch = []
        batch.append(p)
    if batch:
        yield from render_bands(scene, batch, tile=tile, workers=workers)
