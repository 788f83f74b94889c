"""The ladder's rebased level (core/src/render/ladder.cpp's rebase): a primary
ray whose batched discs left a cluster is solved again in double from its
ray polynomial expanded about the cluster, q(s) = p(t0 + s)
(ray_polynomial.cpp's rebased_ray_polynomial), before any double-double.

What is proven: every coefficient of q lies within its radius of the exact
q, for the exact doubles of the ray (checked here with python-flint on the
exact rational ray polynomial, shifted exactly); the pixels the level
decides agree with the exact truth (tests/helpers/pixel_truth.py).
"""

from __future__ import annotations

import math
import zlib

import flint
import numpy as np
import pytest
from tests.helpers.pixel_truth import check_frame, exact, object_ray, ray_polynomial, scene_objects
from tests.helpers.random_surfaces import FAMILIES, random_scene

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.frames import DOUBLE_DOUBLE_LEVEL, REBASED_LEVEL, plan
from argand.render.options import EngineOptions
from argand.scene import load_scene, scene_from_dict

BARTH_SEXTIC = (
    "4*(2.618033988749895*x^2 - y^2)*(2.618033988749895*y^2 - z^2)*(2.618033988749895*z^2 - x^2)"
    " - 4.23606797749979*(x^2 + y^2 + z^2 - 1)^2"
)


def scenes():
    """Random surfaces of every family and degree 2-12 (object = world), and
    transformed ones (a rotation with a translation: a linear part that is
    not a signed permutation, so the direction carries its own error)."""
    out = [(f"{family}-{degree}-{seed}", random_scene(family, degree, seed))
           for family in FAMILIES for degree in (2, 3, 5, 8, 12) for seed in (1, 2)]
    out.append(("barth-moved", to_core_scene(scene_from_dict({"objects": [{
        "surface": BARTH_SEXTIC, "clip_radius": 2,
        "transform": {"rotate": [10, 20, 30], "translate": [0.1, -0.2, 0.3]}}]}))))
    endrass = load_scene("endrass-octic")
    out.append(("endrass", to_core_scene(endrass)))
    return out


def starts(rng: np.random.Generator, distance: float, p_roots: np.ndarray) -> list[float]:
    """Expansion points: the eye (and the zeros and least subnormal beside
    it), the scene's distance, random ones on both sides, far away (the
    powers of t0 up to 1e360 overflow at degree 12: then every radius must
    be infinite, no claim), and the real parts of the ray's roots (where the
    ladder expands: a cluster's centre)."""
    out = [0.0, -0.0, 5e-324, distance, float(rng.uniform(0.0, 2.0 * distance)), -float(rng.uniform(0.0, distance)),
           1.0e3, 1.0e30]
    out += [float(z.real) for z in p_roots[:3]]
    return out


@pytest.mark.parametrize("name, scene", scenes(), ids=lambda v: v if isinstance(v, str) else "")
def test_rebased_coefficients_hold_the_exact_polynomial_about_t0(name, scene):
    rng = np.random.default_rng(zlib.crc32(name.encode()))  # (str hashes vary per process)
    size = 7
    frame_plan = plan(scene, FrameParams(width=size, height=size))
    obj = scene_objects(scene)[0]
    n = scene.objects[0].degree
    checked = 0
    for _ in range(4):
        x, y = (int(v) for v in rng.integers(0, size, 2))
        origin, direction = _core.primary_ray(frame_plan, x, y)
        oo, od = object_ray(obj, origin, direction)
        p = ray_polynomial(obj, oo, od)
        approx = np.array([float(p[k]) for k in range(n + 1)])
        roots = np.roots(approx[::-1]) if np.any(approx[1:]) else np.array([])
        for t0 in starts(rng, float(np.linalg.norm(origin)), roots):
            c, r = _core.rebased_ray_polynomial(frame_plan, 0, direction, t0)
            assert len(c) == len(r) == n + 1
            q = p(flint.fmpq_poly([exact(t0), 1]))  # p(t0 + s), exactly
            if not np.all(np.isfinite(r)):
                assert np.all(np.isinf(r)), (name, t0, r)  # (overflow: every radius infinite)
                assert abs(t0) > 1e20, (name, t0)
                continue
            for k in range(n + 1):
                assert r[k] >= 0.0, (name, t0, k)
                assert abs(q[k] - exact(c[k])) <= exact(r[k]), (name, x, y, t0, k, float(q[k]), c[k], r[k])
            checked += 1
    assert checked >= 4 * 7


@pytest.mark.parametrize("t0", [math.nan, math.inf, -math.inf, 1e300])
def test_a_start_that_is_not_finite_or_overflows_claims_nothing(t0):
    scene = load_scene("endrass-octic")
    frame_plan = plan(to_core_scene(scene), FrameParams(width=5, height=5))
    _, direction = _core.primary_ray(frame_plan, 2, 2)
    c, r = _core.rebased_ray_polynomial(frame_plan, 0, direction, t0)
    assert len(c) == 9 and np.all(np.isinf(r))


def test_rebased_radii_are_those_of_the_surface_not_of_the_eye():
    """About a point inside the surface's clip ball, a cluster's coefficients
    carry radii of the surface's own size: on Endrass's octic at a pixel the
    batch left with a cluster, the constant term's radius shrinks from about
    1e-3 (the expansion about the eye: terms up to 1e9) to about 1e-11."""
    scene = load_scene("endrass-octic")
    params = FrameParams(width=40, height=40)
    frame = render_frame(scene, params, workers=1)
    level = np.asarray(frame.aovs["escalation"])
    spots = np.argwhere(level == REBASED_LEVEL)
    assert len(spots) >= 3
    frame_plan = plan(to_core_scene(scene), params)
    for y, x in spots[:3]:
        origin, direction = _core.primary_ray(frame_plan, int(x), int(y))
        _, eye_r = _core.ray_polynomial(frame_plan, 0, origin, direction, with_radius=True)
        t0 = -float(np.dot(origin, direction))  # (the ray's point nearest the surface's centre)
        _, near_r = _core.rebased_ray_polynomial(frame_plan, 0, direction, t0)
        assert near_r[0] < 1e-6 * eye_r[0], (x, y, near_r[0], eye_r[0])


@pytest.mark.parametrize("kernel", ["auto", "scalar"])
@pytest.mark.parametrize("delta", [0.0, math.pi / 18])
def test_the_rebased_level_decides_endrass_clusters_and_agrees_with_the_truth(kernel, delta):
    """Endrass's octic has 168 nodes; rays near them meet near-double roots
    that the eye's expansion merges into clusters. The rebased level
    separates nearly all of them in double (double-double is left for a
    few), and every pixel it decides is what the exact truth says."""
    scene = load_scene("endrass-octic")
    params = FrameParams(delta=delta, width=64, height=64, engine=EngineOptions(kernel=kernel))
    frame = render_frame(scene, params, workers=1)
    level = np.asarray(frame.aovs["escalation"])
    rebased = np.argwhere(level == REBASED_LEVEL)
    dd = int(np.count_nonzero(level == DOUBLE_DOUBLE_LEVEL))
    assert len(rebased) >= 10 and len(rebased) >= 3 * dd, (len(rebased), dd)
    assert frame.certified_share == 1.0
    check = check_frame(scene, params, frame, [(int(x), int(y)) for y, x in rebased[:: max(1, len(rebased) // 40)]])
    assert check.certified >= 10 and check.wrong == 0, check.disagreements[:3]
