"""Shading's fast paths against its plain per-pixel code, to the bit.

shade() computes the normal of a real root (t.im = 0) in real arithmetic
where gradient_real proves the bits equal the complex gradient(), keeps the
eye in object space and the directional lights normalised once per frame,
and skips std::pow / std::exp / std::atan2 where their value is fixed by
C11 Annex F. EngineOptions(shade="reference") runs the plain code (gradient(),
every call made): every AOV must be the same bytes."""

from __future__ import annotations

import dataclasses

import glob
import math
import os

import numpy as np
import pytest

from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions
from argand.scene import load_scene, scene_from_dict
from argand.scene.presets import PRESETS

SCENES = list(PRESETS) + sorted(glob.glob(os.path.join(os.path.dirname(__file__), "..", "..", "docs", "scenes", "*.yaml")))


def _render(scene, params, reference):
    engine = EngineOptions(shade="reference" if reference else "fast")
    return render_frame(scene, dataclasses.replace(params, engine=engine), workers=1)


def _assert_same(scene, params):
    fast, ref = _render(scene, params, False), _render(scene, params, True)
    assert fast.rgba.tobytes() == ref.rgba.tobytes()
    assert set(fast.aovs) == set(ref.aovs)
    for k in fast.aovs:
        assert np.asarray(fast.aovs[k]).tobytes() == np.asarray(ref.aovs[k]).tobytes(), k
    return fast


@pytest.mark.parametrize("name", SCENES, ids=lambda n: os.path.basename(n))
@pytest.mark.parametrize("delta", [0.0, math.pi / 9])
def test_fast_shading_equals_the_reference_to_the_bit(name, delta):
    _assert_same(load_scene(name), FrameParams(delta=delta, width=37, height=29))


@pytest.mark.parametrize("name", ["bicube", "whitney", "whitney-in-sphere"])
def test_hue_by_argument_and_samples_equal_the_reference(name):
    _assert_same(load_scene(name), FrameParams(delta=math.pi / 9, width=23, height=19, hue_by_argument=True))
    _assert_same(load_scene(name), FrameParams(sigma=0.2, delta=math.pi / 9, width=17, height=13, samples=4))


def test_both_gradient_paths_run_on_bicube():
    # Real roots (the real-arithmetic gradient) and complex roots (the
    # complex one) both shade in this frame, and it equals the reference.
    r = _assert_same(load_scene("bicube"), FrameParams(delta=math.pi / 9, width=48, height=48))
    hit = r.rgba[..., 3] > 0
    im = np.asarray(r.aovs["im"])
    assert np.sum(hit & (im == 0)) > 50
    assert np.sum(hit & (im != 0)) > 50


def test_argument_of_real_roots_is_the_librarys_atan2():
    # write_pixel skips atan2 for a real root: +-0 or +-pi, the values
    # C's atan2 returns (numpy calls it for float64).
    r = render_frame(load_scene("whitney"), FrameParams(delta=math.pi / 9, width=48, height=48), workers=1)
    hit = r.rgba[..., 3] > 0
    re, im, arg = (np.asarray(r.aovs[k]) for k in ("re", "im", "arg"))
    real = hit & (im == 0) & (re != 0)
    assert np.sum(real & (re > 0)) > 50  # (a chosen real root lies ahead: t > 0)
    want = np.arctan2(im[real].astype(np.float64), re[real].astype(np.float64)).astype(np.float32)
    assert want.tobytes() == arg[real].tobytes()
    assert set(np.unique(np.abs(arg[real]))) <= {np.float32(0.0), np.float32(math.pi)}
    # The other branch (t < 0, not chosen in these frames) returns
    # copysign(pi, y) for the double nearest pi, as atan2 does.
    for x in (-1e-300, -0.5, -3.0, -1e300, -math.inf):
        assert np.arctan2(0.0, x) == math.pi and np.arctan2(-0.0, x) == -math.pi
        assert np.arctan2(0.0, -x) == 0.0 and math.copysign(1.0, np.arctan2(-0.0, -x)) == -1.0


def test_reflective_transparent_point_lit_and_axis_hits_equal_the_reference():
    # A real mirror sphere and a transparent cube-ish surface under a point
    # light (the per-pixel light direction), seen from the y axis with an
    # odd width: the middle column's hit points have x = 0 exactly, where
    # the real-arithmetic gradient declines (a zero coordinate) and the
    # complex one runs.
    scene = scene_from_dict(
        {
            "objects": [
                {"surface": "x^2 + y^2 + z^2 - 1", "space": "real", "material": {"reflectivity": 0.5}},
                {
                    "surface": "x^4 + y^4 + z^4 - 5",
                    "space": "real",
                    "material": {"transparency": 0.6, "reflectivity": 0.2, "ior": 1.4},
                },
                {"surface": "x^3 + y^2*z - 3*z^3 - 0.5"},
            ],
            "lights": [{"position": [2, -3, 4]}, {"direction": [-1, -1, 2]}],
            "camera": {"position": [0, -6, 0], "look_at": [0, 0, 0], "up": [0, 0, 1]},
        }
    )
    r = _assert_same(scene, FrameParams(delta=math.pi / 9, width=31, height=21))
    assert np.sum(r.rgba[..., 3] > 0) > 100
    r = _assert_same(scene, FrameParams(delta=0.0, width=31, height=21, max_depth=1))
    assert np.sum(r.rgba[..., 3] > 0) > 100


def test_identity_and_transformed_objects_equal_the_reference():
    # shade() skips the matrix products of an identity linear when every
    # component is finite and nonzero. Seen from the y axis at odd sizes, the
    # middle column's and middle row's directions have an exactly zero
    # component (the products run there); a translated object keeps the
    # identity linear with another origin; a rotated and scaled object takes
    # the products everywhere; a 90-degree rotation is a signed permutation
    # with -0 / +0 entries (not the identity bit for bit).
    scene = scene_from_dict(
        {
            "objects": [
                {"surface": "x^3 + y^2*z - 3*z^3 - 0.5", "clip_radius": 2.0},
                {"surface": "x^2 + y^2 + z^2 - 0.3", "transform": {"translate": [1.5, 0, 0.5]}},
                {"surface": "x^4 + y^4 + z^4 - 0.2", "transform": {"rotate": [20, 35, 10], "scale": 0.7,
                                                                    "translate": [-1.4, 0.5, -0.6]}},
                {"surface": "x^2*y - z^3 + y^3 - 0.1", "space": "real",
                 "transform": {"rotate": [90, 0, 0], "translate": [0.2, 0.3, -1.5]}},
            ],
            "camera": {"position": [0, -6, 0], "look_at": [0, 0, 0], "up": [0, 0, 1]},
        }
    )
    for delta in (0.0, math.pi / 9):
        r = _assert_same(scene, FrameParams(delta=delta, width=33, height=25))
        assert np.sum(r.rgba[..., 3] > 0) > 100
    r = _assert_same(scene, FrameParams(sigma=0.2, delta=math.pi / 9, width=21, height=15, samples=4, hue_by_argument=True))
    assert np.sum(r.rgba[..., 3] > 0) > 50
