"""Real ray polynomials: the polynomials the renderer solves, sampled from
every preset and from surfaces of degree 5 to 8, for the roots benchmark.

For each scene and a few deltas, a small frame is rendered to find the
pixels worth sampling: silhouettes (a hit beside a miss: rays tangent to
the surface, double roots), pixels the renderer could not certify (clusters,
singular lines), and random pixels; each sampled pixel's primary ray gives
one polynomial per object (``_core.primary_ray``,
``_core.ray_polynomial``).
"""

from __future__ import annotations

import math

import numpy as np

#: Surfaces of degree 5 to 8 beside the presets (degree 3 and 4), framed by
#: the default camera like the Bicube.
HIGH_DEGREE = {
    "quintic x^5+y^5+z^5+10xyz": "x^5 + y^5 + z^5 + 10*x*y*z - 1000",
    "sextic x^6+y^6+z^6": "x^6 + y^6 + z^6 - 20000",
    "sextic (x^2+y^2+z^2)^3-30(...)": "(x^2 + y^2 + z^2)^3 - 30*(x^2*y^2 + y^2*z^2 + z^2*x^2) - 100",
    "octic x^8+y^8+z^8+10x^2y^2z^2": "x^8 + y^8 + z^8 + x^2*y^2*z^2*10 - 1000000",
}
DELTAS = (0.0, math.pi / 18, math.pi / 9)
#: Pixel kinds sampled, in the order the report lists them.
KINDS = ("silhouette", "not certified", "random hit", "random")


def scenes() -> dict:
    """The paper's presets and the degree 5-8 surfaces, as Scene objects
    (the classic presets of degree 5-8 have their own table in
    argand.bench.render)."""
    from argand.scene import load_scene, scene_from_dict
    from argand.scene.presets import PAPER_PRESETS

    out = {name: load_scene(name) for name in PAPER_PRESETS}
    for name, surface in HIGH_DEGREE.items():
        out[name] = scene_from_dict({"objects": [{"surface": surface, "clip_radius": 8}]})
    return out


def _pick(rng: np.random.Generator, mask: np.ndarray, k: int) -> list[tuple[int, int]]:
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return []
    idx = rng.choice(len(xs), size=min(k, len(xs)), replace=False)
    return [(int(xs[i]), int(ys[i])) for i in idx]


def sample_pixels(alpha: np.ndarray, status: np.ndarray, rng: np.random.Generator, per_kind: int) -> dict[str, list]:
    """Pixels of each kind: silhouettes (a hit with a missed 4-neighbour),
    hits not certified (status != 0), random hits, random pixels."""
    hit = alpha > 0
    pad = np.pad(hit, 1, mode="edge")
    miss_beside = ~pad[:-2, 1:-1] | ~pad[2:, 1:-1] | ~pad[1:-1, :-2] | ~pad[1:-1, 2:]
    return {
        "silhouette": _pick(rng, hit & miss_beside, per_kind),
        "not certified": _pick(rng, hit & (status != 0), per_kind),
        "random hit": _pick(rng, hit, per_kind),
        "random": _pick(rng, np.ones_like(hit), per_kind),
    }


def ray_polynomials(per_kind: int = 40, size: int = 96, seed: int = 7) -> tuple[list[np.ndarray], list[dict]]:
    """The polynomials (lowest degree first) and, for each, where it came
    from: {scene, delta, kind, x, y, object, degree}."""
    from argand.core import _core
    from argand.render import FrameParams, render_frame
    from argand.render.convert import to_core_scene
    from argand.render.frames import plan

    rng = np.random.default_rng(seed)
    polys: list[np.ndarray] = []
    origin: list[dict] = []
    for name, scene in scenes().items():
        core_scene = to_core_scene(scene)
        for delta in DELTAS:
            params = FrameParams(delta=delta, width=size, height=size)
            frame = render_frame(scene, params, workers=1)
            fplan = plan(core_scene, params)
            picked = sample_pixels(frame.rgba[..., 3], frame.aovs["status"], rng, per_kind)
            for kind in KINDS:
                for x, y in picked[kind]:
                    eye, direction = _core.primary_ray(fplan, x, y)
                    for k, obj in enumerate(scene.objects):
                        c = np.asarray(_core.ray_polynomial(fplan, k, eye, direction), dtype=float)
                        if not np.any(c) or not np.all(np.isfinite(c)):
                            continue
                        # Exact-zero leading coefficients are roots at infinity; the
                        # contenders without that notion get the trimmed polynomial.
                        while len(c) > 1 and c[-1] == 0.0:
                            c = c[:-1]
                        if len(c) < 2:
                            continue
                        polys.append(c)
                        origin.append({"scene": name, "delta": delta, "kind": kind, "x": x, "y": y, "object": k,
                                       "degree": len(c) - 1})
    return polys, origin


def summary(origin: list[dict]) -> dict:
    """How many polynomials of each scene, kind and degree."""
    out: dict = {"by_scene": {}, "by_kind": {}, "by_degree": {}}
    for o in origin:
        for key, value in (("by_scene", o["scene"]), ("by_kind", o["kind"]), ("by_degree", str(o["degree"]))):
            out[key][value] = out[key].get(value, 0) + 1
    return out
