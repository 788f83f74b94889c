"""Tracer::decide's fast path against its full path, and against the truth.

decide takes a fast path for the common pixel (every object's roots
complete, the result certified): the same proven predicates computed more
cheaply (pixel_decision.h, *_fast), over the live discs only, realness by
the mirror test only where the band verdict depends on it. Every pixel must
come out exactly as the full path decides it (EngineOptions(decide="full"), the
reference): every AOV equal to the bit, on every preset, at bands on and
off the real axis (sigma > 0, delta = 0, the whole half-plane), with the
batched and the scalar root kernel, 1 and 4 samples, random surfaces with
clusters and products (double roots), clipping spheres. The fast path's
certified pixels are also checked against the exact truth
(tests/helpers/pixel_truth.py). The C++ side compares each fast predicate with its
reference on random and edge discs (core/tests/render_test.cpp,
test_fast_decisions).
"""

from __future__ import annotations

import dataclasses

import math
import os

import numpy as np
import pytest

from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions
from argand.scene import load_scene
from argand.scene.presets import CLASSIC_PRESETS, PAPER_PRESETS
from tests.helpers.pixel_truth import check_frame, sample_pixels
from tests.helpers.random_surfaces import FAMILIES, random_scene

BANDS = ((0.0, 0.0), (0.0, math.pi / 9), (0.3, math.pi / 4), (1.0, 0.0), (0.0, math.pi), (0.2, math.pi - 0.2))


def render_with(scene, params: FrameParams, kernel: str = "auto", decide: str = "fast"):
    engine = EngineOptions(kernel=kernel, decide=decide)
    return render_frame(scene, dataclasses.replace(params, engine=engine), workers=1)


def assert_identical(a, b, what: str) -> None:
    assert a.rgba.tobytes() == b.rgba.tobytes(), f"{what}: rgba differs"
    assert set(a.aovs) == set(b.aovs)
    for key in a.aovs:
        x, y = np.asarray(a.aovs[key]), np.asarray(b.aovs[key])
        assert x.shape == y.shape and x.tobytes() == y.tobytes(), (
            f"{what}: {key} differs at {np.argwhere(x != y)[:10].tolist()}")


def fast_and_full(scene, params: FrameParams, kernel: str = "auto"):
    fast = render_with(scene, params, kernel, "fast")
    full = render_with(scene, params, kernel, "full")
    return fast, full


@pytest.mark.parametrize("name", PAPER_PRESETS + CLASSIC_PRESETS)
def test_fast_path_is_the_full_path_on_every_preset(name):
    scene = load_scene(name)
    for sigma, delta in BANDS:
        for kernel in ("auto", "scalar"):
            params = FrameParams(sigma=sigma, delta=delta, width=29, height=21)
            fast, full = fast_and_full(scene, params, kernel)
            assert_identical(fast, full, f"{name} sigma={sigma} delta={delta} kernel={kernel}")
    params = FrameParams(sigma=0.0, delta=math.pi / 9, width=13, height=11, samples=4)
    fast, full = fast_and_full(scene, params)
    assert_identical(fast, full, f"{name} 4 samples")


@pytest.mark.parametrize("family", FAMILIES)
def test_fast_path_is_the_full_path_on_random_surfaces(family):
    # Products and near-products give double roots (clusters, blocked
    # choices); every surface has a clipping sphere.
    for degree in range(2, 9):
        scene = random_scene(family, degree, seed=degree + 11)
        for sigma, delta in ((0.0, 0.0), (0.0, math.pi / 18), (0.3, math.pi / 4)):
            params = FrameParams(sigma=sigma, delta=delta, width=17, height=15)
            fast, full = fast_and_full(scene, params)
            assert_identical(fast, full, f"random {family} degree {degree} sigma={sigma} delta={delta}")


def test_the_fast_path_is_taken_and_frames_are_mostly_certified():
    # (Not vacuous: the fast path decides only certified pixels, and most
    # pixels of a preset are certified.)
    scene = load_scene("chmutov-octic")
    fast = render_with(scene, FrameParams(delta=math.pi / 9, width=24, height=24))
    status = np.asarray(fast.aovs["status"])
    assert (status == 0).mean() > 0.9


@pytest.mark.parametrize("name,delta", [("whitney-in-sphere", math.pi / 9), ("chmutov-octic", math.pi / 9),
                                        ("bicube", 0.0), ("steiner", math.pi / 18)])
def test_fast_path_certified_pixels_against_the_truth(name, delta):
    scene = load_scene(name)
    params = FrameParams(sigma=0.0, delta=delta, width=24, height=24)
    result = render_with(scene, params, decide="fast")
    check = check_frame(scene, params, result, sample_pixels(24, 24, 60, seed=7))
    wrong = [f"({x}, {y}): {p}" for x, y, problems in check.disagreements for p in problems if "wrong: " in p]
    assert not wrong, "\n".join(wrong)
    assert check.certified > 0


def test_explain_still_shows_every_disc():
    # --explain decides its pixel on the full path: every disc's verdicts,
    # and the same decision as the rendered (fast path) frame.
    from argand.render.explain import explain_pixel

    scene = load_scene("bicube")
    params = FrameParams(sigma=0.0, delta=math.pi / 9, width=16, height=16)
    result = render_with(scene, params, decide="fast")
    status = np.asarray(result.aovs["status"])
    proven_out = 0
    for x, y in ((8, 8), (3, 12), (12, 4)):
        e = explain_pixel(scene, params, x, y)
        assert e["status"] == int(status[y, x])
        # Every disc, proven out of the band or not (bicube: no roots at
        # infinity, so the counts add up to the degree).
        degree = sum(len(p["coeffs"]) - 1 for p in e["polynomials"])
        assert sum(d["count"] for d in e["discs"]) == degree
        proven_out += sum(d["in_band"] == "no" for d in e["discs"])
    assert proven_out > 0  # (the fast path keeps no such disc)


# decide_fast's verdicts come four discs per AVX2 vector where it runs
# (classify_discs_avx2: quick tests as lane masks, the scalar reference for a
# disc they leave undecided) and one disc at a time otherwise
# (EngineOptions(decide="fast-scalar")). Scenes whose discs sit on the quick tests'
# edges: a clipping sphere cutting through the real surface and through its
# complex roots' shell (the sphere test straddles), double roots (count 2
# discs, a cluster) and near-double roots, at bands whose edges pass through
# the roots' arguments (sigma > 0, delta = 0, the whole half-plane).
EDGE_SCENES = {
    "bicube-cut": 'objects:\n  - surface: "x^4 + y^4 + z^4 - 1000"\n    clip_radius: 6.2\n',
    "bicube-shell": 'objects:\n  - surface: "x^4 + y^4 + z^4 - 1000"\n    clip_radius: 7.45\n',
    "double-sphere": 'objects:\n  - surface: "(x^2 + y^2 + z^2 - 9)^2"\n    clip_radius: 8\n',
    "near-double": 'objects:\n  - surface: "(x^2 + y^2 + z^2 - 9)^2 - 0.0001"\n    clip_radius: 3.0001\n',
    "two-objects": ('objects:\n  - surface: "x^4 + y^4 + z^4 - 1000"\n    clip_radius: 7\n'
                    '  - surface: "x^2 + y^2 + z^2 - 30"\n'),
}
EDGE_BANDS = ((0.0, 0.0), (0.0, math.pi / 9), (0.35, 0.0), (0.4, 0.5), (0.0, math.pi), (1e-300, 0.3),
              (math.pi / 9, math.pi / 18))


@pytest.mark.parametrize("name", sorted(EDGE_SCENES))
@pytest.mark.parametrize("mode", ["fast", "fast-scalar"])
def test_quick_verdicts_at_their_edges(tmp_path, name, mode):
    path = tmp_path / f"{name}.yaml"
    path.write_text(EDGE_SCENES[name])
    scene = load_scene(str(path))
    for sigma, delta in EDGE_BANDS:
        for kernel in ("auto", "scalar"):
            params = FrameParams(sigma=sigma, delta=delta, width=23, height=19)
            fast = render_with(scene, params, kernel, mode)
            full = render_with(scene, params, kernel, "full")
            assert_identical(fast, full, f"{name} {mode} sigma={sigma} delta={delta} kernel={kernel}")


@pytest.mark.parametrize("name", PAPER_PRESETS + CLASSIC_PRESETS)
def test_scalar_verdicts_are_the_full_path_on_every_preset(name):
    # (The vector form is the default; the scalar form serves machines
    # without AVX2.)
    scene = load_scene(name)
    for sigma, delta in ((0.0, math.pi / 9), (0.3, math.pi / 4), (1.0, 0.0)):
        params = FrameParams(sigma=sigma, delta=delta, width=21, height=15)
        fast = render_with(scene, params, decide="fast-scalar")
        full = render_with(scene, params, decide="full")
        assert_identical(fast, full, f"{name} fast-scalar sigma={sigma} delta={delta}")
