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

import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import select

from argand.farm.database import engine_for
from argand.farm.models import Job
from argand.farm.planning import samples_of
from argand.farm.settings import Settings
from argand.frames.angles import parse_angle
from argand.media.frame_files import to_srgb8, write_exr, write_png
from argand.render.frames import FrameParams, FrameResult, render_frame
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
