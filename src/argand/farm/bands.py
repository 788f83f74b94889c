"""Any band (σ, δ) of a finished job, on demand: GET
/api/jobs/{id}/band.png and band.exr.

The band is rendered from the job's own scene, size, method and samples
with the farm's engine options, by the same renderer as every frame
(argand.render.frames.render_frame), so its pixels are those `argand
render --sigma S --delta D` writes for that scene and size: certified
decisions, escalated where a band needs it. Any pair within the band rule
is answered (nothing limits it to the bands the job rendered: the roots of
every pixel are solved again for the request, in the API's process, on
all its cores). The last BAND_CACHE answers are kept (PNG bytes and
figures), so going back to a band is free.
"""

from __future__ import annotations

import math
import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from sqlalchemy import select

from argand.core import _core, find_roots
from argand.farm.database import engine_for
from argand.farm.models import Job
from argand.farm.planning import samples_of
from argand.farm.settings import Settings
from argand.frames.angles import parse_angle
from argand.media.frame_files import to_srgb8, write_exr, write_png
from argand.render.convert import to_core_scene
from argand.render.frames import FrameParams, FrameResult, plan, render_frame
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


def band_params(settings: Settings, job_id: str, sigma_text: str, delta_text: str) -> tuple:
    """(scene, FrameParams) of the band of a done job. Raises NoJob,
    JobNotDone, or ValueError naming what is wrong with σ or δ (the band
    rule, an angle that does not parse)."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.status, Job.scene, Job.width, Job.height, Job.method).where(Job.id == job_id)).first()
    if job is None:
        raise NoJob(job_id)
    if job.status != "done":
        raise JobNotDone(f"job {job_id} is {job.status}: its bands are answered once it is done")
    sigma = _angle("sigma", sigma_text)
    delta = _angle("delta", delta_text)
    params = FrameParams(sigma=sigma, delta=delta, width=job.width, height=job.height, method=job.method,
                         samples=samples_of(job.scene), engine=settings.engine)
    return scene_from_dict(job.scene), params


def _angle(name: str, text: str) -> float:
    symbol = {"sigma": "σ", "delta": "δ"}[name]
    try:
        return parse_angle(text)
    except ValueError as exc:
        raise ValueError(f"{symbol} ({name}={text!r}): {exc}") from None


def band(settings: Settings, job_id: str, sigma_text: str, delta_text: str, keep_result: bool = False) -> Band:
    """The band's PNG and figures, from the cache or rendered now. With
    keep_result, the whole FrameResult too (for the EXR; never cached)."""
    scene, params = band_params(settings, job_id, sigma_text, delta_text)
    key = (settings.sqlalchemy_url, job_id, params.sigma, params.delta, params.engine)
    if not keep_result:
        with _lock:
            hit = _cache.get(key)
            if hit is not None:
                _cache.move_to_end(key)
                return Band(hit.sigma, hit.delta, hit.png, hit.figures, cached=True)
    start = time.perf_counter()
    result = render_frame(scene, params)
    png = _png_bytes(result)
    figures = {"certified_share": result.certified_share, "status_shares": result.status_shares(),
               "seconds": time.perf_counter() - start}
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


#: Pixels per side of the grid whose roots root_arguments reads, and its bins over [0, π].
ARGUMENT_GRID = 48
ARGUMENT_BINS = 90


def inside_clip(obj, origin, direction, centres):
    """Which roots' points lie inside the object's clipping sphere (all
    when it has none): the point at distance |t| along the ray, in object
    space (object = linear (world - translate)), at the disc's centre."""
    radius = float(obj.clip_radius)
    if radius <= 0.0:
        return np.ones(len(centres), bool)
    linear = np.asarray(obj.linear, float).reshape(3, 3)
    o = linear @ (np.asarray(origin, float) - np.asarray(obj.translate, float))
    d = linear @ np.asarray(direction, float)
    points = o[None, :] + np.abs(centres)[:, None] * d[None, :]
    return np.einsum("ij,ij->i", points, points) <= radius * radius


def root_arguments(settings: Settings, job_id: str, grid: int = ARGUMENT_GRID, bins: int = ARGUMENT_BINS) -> dict:
    """Where in (σ, δ) a job's picture can change: the arguments |arg t| of
    the roots of the primary rays of a grid x grid subset of its pixels
    (evenly spread, pixel centres), each object's ray polynomial solved
    with proven discs (argand.core.find_roots, coefficient radii included);
    a verified disc counts its roots, at the argument of its centre, when
    its centre's point lies inside the object's clipping sphere (the roots
    a frame can show). A band's picture changes only where σ or σ + δ
    crosses such a root's argument, so the histogram shows which bands are
    worth looking at. Raises NoJob."""
    with engine_for(settings.sqlalchemy_url).connect() as c:
        job = c.execute(select(Job.scene, Job.width, Job.height).where(Job.id == job_id)).first()
    if job is None:
        raise NoJob(job_id)
    core_scene = to_core_scene(scene_from_dict(job.scene))
    frame_plan = plan(core_scene, FrameParams(width=job.width, height=job.height))
    xs = sorted({min(job.width - 1, int((i + 0.5) * job.width / grid)) for i in range(grid)})
    ys = sorted({min(job.height - 1, int((j + 0.5) * job.height / grid)) for j in range(grid)})
    args: list[float] = []
    weights: list[int] = []
    unverified = 0
    for y in ys:
        for x in xs:
            origin, direction = _core.primary_ray(frame_plan, x, y, 0)
            for obj in range(len(core_scene.objects)):
                coeffs, radius = _core.ray_polynomial(frame_plan, obj, origin, direction, True)
                if not (np.all(np.isfinite(coeffs)) and coeffs[-1] != 0.0):
                    continue
                roots = find_roots(coeffs, radius=radius)
                ok = roots.verified & inside_clip(core_scene.objects[obj], origin, direction, roots.center)
                unverified += int(np.sum(roots.count[~roots.verified]))
                args += np.abs(np.angle(roots.center[ok])).tolist()
                weights += roots.count[ok].tolist()
    counts, edges = np.histogram(args, bins=bins, range=(0.0, math.pi), weights=weights)
    return {"edges": edges.tolist(), "counts": counts.astype(int).tolist(), "pixels": len(xs) * len(ys),
            "roots": int(sum(weights)), "unverified_roots": unverified}
