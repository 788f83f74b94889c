"""Any band (σ, δ) of a finished job, on demand (argand.farm.bands): the
picture and the EXR with every AOV, the certified figures in headers."""

from __future__ import annotations

import json

from fastapi import APIRouter, HTTPException, Query
from fastapi.responses import Response

from argand.api.deps import JobIdDep, SettingsDep
from argand.api.routes.frames import binary
from argand.api.schemas import MAX_ATLAS_STEPS
from argand.farm.bands import Band, JobNotDone, NoJob, band, exr_bytes, root_arguments

router = APIRouter(prefix="/api/jobs/{job_id}", tags=["bands"])

SIGMA = Query(..., description="Start of the band, an angle as written (0.35, pi/9, 2*pi/3); σ ≥ 0 and σ + δ ≤ π.",
              max_length=64)
DELTA = Query(..., description="Width of the band, an angle as written; δ ≥ 0.", max_length=64)


def _band(settings, job_id: str, sigma: str, delta: str, keep_result: bool = False) -> Band:
    try:
        return band(settings, job_id, sigma, delta, keep_result)
    except NoJob:
        raise HTTPException(404, detail=f"no job {job_id!r}") from None
    except JobNotDone as exc:
        raise HTTPException(409, detail=str(exc)) from None
    except ValueError as exc:
        raise HTTPException(422, detail=str(exc)) from None


def _headers(b: Band) -> dict[str, str]:
    return {"X-Argand-Sigma": repr(b.sigma), "X-Argand-Delta": repr(b.delta),
            "X-Argand-Certified-Share": repr(float(b.figures["certified_share"])),
            "X-Argand-Status-Shares": json.dumps(b.figures["status_shares"], separators=(",", ":")),
            "X-Argand-Render-Seconds": f"{b.figures['seconds']:.4f}", "X-Argand-Cache": "hit" if b.cached else "miss",
            "X-Argand-Root-Field": b.figures.get("field", ""),
            "Cache-Control": "private, max-age=3600"}


@router.get("/band.png", **binary("image/png", "The band's picture (certified decisions), figures in X-Argand-* headers"))
def band_png(job_id: JobIdDep, settings: SettingsDep, sigma: str = SIGMA, delta: str = DELTA):
    """Any band of a done job, within the band rule, decided from the job's
    root field: what `argand render --sigma S --delta D --tile T` shows for
    the job's scene, size and tile size. 409 while the job is not done; 422
    for a pair outside the band rule. X-Argand-Root-Field says where the
    roots came from (memory, store, or solved for this request)."""
    b = _band(settings, job_id, sigma, delta)
    return Response(b.png, media_type="image/png", headers=_headers(b))


@router.get("/band.exr", **binary("image/x-exr", "The band's EXR (every AOV, the status channel included)"))
def band_exr(job_id: JobIdDep, settings: SettingsDep, sigma: str = SIGMA, delta: str = DELTA):
    """The band's EXR, as `argand render` writes a frame: R, G, B, A and
    every AOV (Z, arg, re, im, count, status, escalation, certified_share)."""
    b = _band(settings, job_id, sigma, delta, keep_result=True)
    return Response(exr_bytes(b.result, settings.exr_compression), media_type="image/x-exr", headers=_headers(b))


@router.get("/arguments")
def arguments(job_id: JobIdDep, settings: SettingsDep,
              atlas: int | None = Query(None, ge=1, le=MAX_ATLAS_STEPS, description=(
                  "Also the atlas of N steps laid out where these roots are: its cuts and bands"))) -> dict:
    """Where the job's picture can change along σ and δ: a histogram over
    [0, π] of the arguments |arg t| of the roots of the primary rays of an
    evenly spread subset of its pixels (proven discs; see
    argand.farm.bands.root_arguments); with ``atlas``, the atlas of that
    many steps laid out where the roots are ("atlas": steps, cuts, and its
    bands as [σ, δ] in frame order; the job page shows them as a contact
    sheet from band.png)."""
    try:
        return root_arguments(settings, job_id, atlas)
    except NoJob:
        raise HTTPException(404, detail=f"no job {job_id!r}") from None
