"""Any band (σ, δ) of a finished job, on demand: GET
/api/jobs/{id}/band.png and band.exr.

A band is decided from the job's root field (argand.render.field): the
primary roots of every sample, which the farm's workers recorded per tile
while rendering the job's frames (JobLayout.field_tile; the roots do not
depend on the band). The band is rendered from the job's own scene, size,
method, samples and tiling with the farm's engine options, the roots read
from the field instead of solved, so its pixels are the bits `argand render
--sigma S --delta D --tile T` writes for that scene and size: certified
decisions, escalated where a band needs it. Any pair within the band rule is
answered (the field holds every root, not only those of the rendered
bands). Where the store holds no field (a job rendered before fields, a
tile whose file was lost or damaged), the first band request solves the
roots and records them. The last fields (FIELD_CACHE_BYTES in all) stay in
memory, and the last BAND_CACHE answers (PNG bytes and figures), so going
back to a band is free.
"""

from __future__ import annotations

import tempfile
import threading
import time
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

from sqlalchemy import select

from argand.core import _core
from argand.farm.database import engine_for
from argand.farm.models import Job
from argand.farm.planning import samples_of
from argand.farm.settings import Settings
from argand.frames.angles import parse_angle
from argand.frames.frame_set import atlas_cuts, atlas_grid
from argand.media.frame_files import to_srgb8, write_exr, write_png
from argand.render.arguments import argument_histogram
from argand.render.convert import to_core_scene
from argand.farm.store import store_for
from argand.render.field import RootField, tape_of_stored
from argand.render.options import EngineOptions
from argand.render.frames import FrameParams, FrameResult, plan, render_bands, tiles
from argand.scene import scene_from_dict

#: Bands kept (PNG bytes and figures, some 100-400 KB each at 512x512).
BAND_CACHE = 48


class JobNotDone(Exception):
    """The job is not done: its bands are answered once it is."""


class NoJob(Exception):
    """No such job."""


@dataclass
class Band:
    """One band of a job: its PNG and its figures (certified share, status shares, seconds)."""

    sigma: float
    delta: float
    png: bytes
    figures: dict
    cached: bool = False
    result: FrameResult | None = field(default=None, repr=False)


_cache: OrderedDict[tuple, Band] = OrderedDict()
_lock = threading.Lock()


class KeyedLocks:
    """One lock per key, kept only while a thread holds it or waits for it:
    a long-running API answering bands of many jobs keeps no lock for a job
    nobody asks about any more."""

    def __init__(self) -> None:
        self._guard = threading.Lock()
        self._locks: dict[tuple, list] = {}  # key -> [lock, threads holding or waiting]

    def __len__(self) -> int:
        with self._guard:
            return len(self._locks)

    @contextmanager
    def hold(self, key: tuple) -> Iterator[None]:
        with self._guard:
            entry = self._locks.setdefault(key, [threading.Lock(), 0])
            entry[1] += 1
        try:
            with entry[0]:
                yield
        finally:
            with self._guard:
                entry[1] -= 1
                if entry[1] == 0:
                    del self._locks[key]


def band_params(settings: Settings, job_id: str, sigma_text: str, delta_text: str) -> tuple:
    """(scene, FrameParams, tile size) of the band of a done job. Raises
    NoJob, JobNotDone, or ValueError naming what is wrong with σ or δ (the
    band rule, an angle that does not parse)."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.status, Job.scene, Job.width, Job.height, Job.method, Job.tile, Job.engine)
                        .where(Job.id == job_id)).first()
    if job is None:
        raise NoJob(job_id)
    if job.status != "done":
        raise JobNotDone(f"job {job_id} is {job.status}: its bands are answered once it is done")
    sigma = _angle("sigma", sigma_text)
    delta = _angle("delta", delta_text)
    params = FrameParams(sigma=sigma, delta=delta, width=job.width, height=job.height, method=job.method,
                         samples=samples_of(job.scene), engine=EngineOptions.from_stored(job.engine))
    return scene_from_dict(job.scene), params, job.tile


def _angle(name: str, text: str) -> float:
    symbol = {"sigma": "σ", "delta": "δ"}[name]
    try:
        return parse_angle(text)
    except ValueError as exc:
        raise ValueError(f"{symbol} ({name}={text!r}): {exc}") from None


#: Root fields kept in memory, in bytes (a 512x512 job's field is some 10-40 MB).
FIELD_CACHE_BYTES = 384 << 20

_fields: OrderedDict[tuple, RootField] = OrderedDict()
_field_locks = KeyedLocks()  # one solve per job when its first requests come together


def stored_field(settings: Settings, job_id: str, frame_plan, width: int, height: int, tile: int) -> RootField | None:
    """The job's root field as its workers stored it, or None where a tile's
    file is missing or does not match its checksum (or was recorded for
    other rays: the farm's engine options changed since)."""
    layout = store_for(settings).job(job_id)
    field = RootField(int(_core.rays_fingerprint(frame_plan)), width, height, tile)
    for i, r in enumerate(tiles(width, height, tile)):
        try:
            field.tiles[(r.x0, r.y0, r.x1, r.y1)] = tape_of_stored(layout.field_tile(i).read_bytes())
        except (OSError, ValueError):
            return None
    return field


def _job_field(settings: Settings, job_id: str, scene, params: FrameParams, tile: int) -> tuple[RootField | None, str]:
    """The job's field from memory or the store, or (None, "solved") when
    the caller must record one (then _keep_field)."""
    key = (settings.sqlalchemy_url, job_id, params.engine)
    with _lock:
        hit = _fields.get(key)
        if hit is not None:
            _fields.move_to_end(key)
            return hit, "memory"
    frame_plan = plan(to_core_scene(scene), params)
    field = stored_field(settings, job_id, frame_plan, params.width, params.height, tile)
    if field is None:
        return None, "solved"
    _keep_field(key, field)
    return field, "store"


def _keep_field(key: tuple, field: RootField) -> None:
    with _lock:
        _fields[key] = field
        _fields.move_to_end(key)
        while len(_fields) > 1 and sum(f.nbytes for f in _fields.values()) > FIELD_CACHE_BYTES:
            _fields.popitem(last=False)


def render_band(settings: Settings, job_id: str, scene, params: FrameParams, tile: int) -> tuple[FrameResult, str]:
    """The band's frame, from the job's root field (recorded now if there
    is none yet), and where the field came from: memory, store or solved."""
    key = (settings.sqlalchemy_url, job_id, params.engine)
    with _field_locks.hold(key):
        field, source = _job_field(settings, job_id, scene, params, tile)
        if field is not None:
            try:
                return render_bands(scene, [params], tile=tile, field=field, any_tile=True)[0], source
            except ValueError:  # a field of other rays: solve again below
                with _lock:
                    _fields.pop(key, None)
        recorded = RootField(0, 0, 0, 0)
        result = render_bands(scene, [params], tile=tile, record=recorded, any_tile=True)[0]
        _keep_field(key, recorded)
        return result, "solved"


def band(settings: Settings, job_id: str, sigma_text: str, delta_text: str, keep_result: bool = False) -> Band:
    """The band's PNG and figures, from the cache or rendered now. With
    keep_result, the whole FrameResult too (for the EXR; never cached)."""
    scene, params, tile = band_params(settings, job_id, sigma_text, delta_text)
    key = (settings.sqlalchemy_url, job_id, params.sigma, params.delta, params.engine)
    if not keep_result:
        with _lock:
            hit = _cache.get(key)
            if hit is not None:
                _cache.move_to_end(key)
                return Band(hit.sigma, hit.delta, hit.png, hit.figures, cached=True)
    start = time.perf_counter()
    result, source = render_band(settings, job_id, scene, params, tile)
    png = _png_bytes(result)
    figures = {"certified_share": result.certified_share, "status_shares": result.status_shares(),
               "seconds": time.perf_counter() - start, "field": source}
    out = Band(params.sigma, params.delta, png, figures)
    with _lock:
        _cache[key] = out
        _cache.move_to_end(key)
        while len(_cache) > BAND_CACHE:
            _cache.popitem(last=False)
    if keep_result:
        return Band(out.sigma, out.delta, png, figures, result=result)
    return out


def _png_bytes(result: FrameResult) -> bytes:
    with tempfile.TemporaryDirectory(prefix="argand-band-") as tmp:
        path = Path(tmp) / "band.png"
        write_png(to_srgb8(result.rgba), path)
        return path.read_bytes()


def exr_bytes(result: FrameResult, compression: str) -> bytes:
    """The band's EXR (every AOV, the status channel included), as `argand render` writes it."""
    with tempfile.TemporaryDirectory(prefix="argand-band-") as tmp:
        path = Path(tmp) / "band.exr"
        write_exr(result, path, compression=compression)
        return path.read_bytes()


def root_arguments(settings: Settings, job_id: str, atlas: int | None = None) -> dict:
    """Where in (σ, δ) a job's picture can change
    (argand.render.arguments.argument_histogram on the job's scene and size)
    and, with ``atlas`` (N steps), the atlas laid out where those roots are
    (argand.frames.frame_set.atlas_cuts: its cuts and its bands as [σ, δ]
    pairs in frame order). Raises NoJob."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.scene, Job.width, Job.height).where(Job.id == job_id)).first()
    if job is None:
        raise NoJob(job_id)
    out = argument_histogram(to_core_scene(scene_from_dict(job.scene)), job.width, job.height)
    if atlas is not None:
        cuts = atlas_cuts(out["edges"], out["counts"], atlas, at_zero=out["at_zero"], at_pi=out["at_pi"])
        out["atlas"] = {"steps": atlas, "cuts": list(cuts),
                        "bands": [[p.sigma, p.delta] for p in atlas_grid(atlas, cuts).points]}
    return out
