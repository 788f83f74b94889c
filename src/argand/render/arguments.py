"""Where in (σ, δ) a scene's picture can change: the arguments |arg t| of
the roots of the primary rays of an evenly spread grid of its pixels.

A band [σ, σ + δ] shows a pixel's root of least modulus among those whose
argument lies in the band, so the picture changes only where σ or σ + δ
crosses the argument of some pixel's root. The histogram of those arguments
says which bands are worth looking at (the job page draws it under the
sliders) and where an atlas should put its cuts (argand.frames.frame_set.
atlas_cuts: dense where the roots are, `argand render --atlas N
--atlas-layout roots` and a job's ``atlas_layout: "roots"``).

Each object's ray polynomial is solved with proven discs
(argand.core.find_roots, coefficient radii included); a verified disc counts
its roots, at the argument of its centre, when its centre's point lies
inside the object's clipping sphere (the roots a frame can show). The
histogram describes where to look; it proves nothing about a frame (frames
are decided by the renderer, pixel by pixel).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from argand.core import _core, find_roots
from argand.render.frames import FrameParams, plan

#: Pixels per side of the grid whose roots are read, and the bins over [0, π].
ARGUMENT_GRID = 48
ARGUMENT_BINS = 90


def inside_clip(obj: Any, origin, direction, centres) -> np.ndarray:
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


def argument_histogram(core_scene: Any, width: int, height: int, grid: int = ARGUMENT_GRID,
                       bins: int = ARGUMENT_BINS) -> dict:
    """The histogram over [0, π] of the roots' |arg t| on a grid x grid
    subset of the frame's pixels (pixel centres, evenly spread): ``edges``
    (bins + 1), ``counts`` (roots per bin, a cluster's count included),
    ``pixels`` read, ``roots`` counted, ``unverified_roots`` left out, and
    of the counted roots those whose argument is exactly 0 (``at_zero``: real,
    t > 0, in the first bin) or exactly π (``at_pi``: real, t < 0, in the
    last): every atlas has cuts there already."""
    frame_plan = plan(core_scene, FrameParams(width=width, height=height))
    xs = sorted({min(width - 1, int((i + 0.5) * width / grid)) for i in range(grid)})
    ys = sorted({min(height - 1, int((j + 0.5) * height / grid)) for j in range(grid)})
    args: list[float] = []
    weights: list[int] = []
    unverified = 0
    ends = [0, 0]  # roots proven real: argument exactly 0 (t > 0) or exactly π (t < 0)
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
                theta = np.abs(np.angle(roots.center[ok]))
                args += theta.tolist()
                weights += roots.count[ok].tolist()
                ends[0] += int(np.sum(roots.count[ok][theta == 0.0]))
                ends[1] += int(np.sum(roots.count[ok][theta == math.pi]))
    counts, edges = np.histogram(args, bins=bins, range=(0.0, math.pi), weights=weights)
    return {"edges": edges.tolist(), "counts": counts.astype(int).tolist(), "pixels": len(xs) * len(ys),
            "roots": int(sum(weights)), "unverified_roots": unverified, "at_zero": ends[0], "at_pi": ends[1]}
