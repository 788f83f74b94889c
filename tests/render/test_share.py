"""The certified share: at least 99.9% of pixels certified at every
delta in [0, pi/4] on surfaces of degree 2 to 8 (random dense ones, random
products of quadrics and planes with their singular curves), and 100% on
the presets (the paper's and the classic degree 5-8 ones). Whether the
certified pixels are right is tests/render/test_truth.py's business (the exact
checker); this checks that the proofs reach the pixels."""

from __future__ import annotations

import math

import pytest

import tests.helpers.random_surfaces as rs

from argand.render.frames import FrameParams, render_frame
from argand.scene import load_scene
from argand.scene.presets import PRESETS

DELTAS = (0.0, math.pi / 8, math.pi / 4)


@pytest.mark.parametrize("degree", range(2, 9))
def test_random_surfaces_of_degree_2_to_8_are_certified_at_every_delta_up_to_pi_4(degree):
    for family in rs.FAMILIES:
        scene = rs.random_scene(family, degree, 7)
        for delta in DELTAS:
            r = render_frame(scene, FrameParams(sigma=0.0, delta=delta, width=32, height=32), workers=1)
            assert r.certified_share >= 0.999, (family, degree, delta, r.status_shares)


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_is_fully_certified_at_pi_4(name):
    for sigma, delta in ((0.0, math.pi / 4), (math.pi / 6, math.pi / 4)):
        r = render_frame(load_scene(name), FrameParams(sigma=sigma, delta=delta, width=33, height=33), workers=1)
        assert r.certified_share == 1.0, (name, sigma, delta, r.status_shares)
