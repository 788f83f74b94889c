"""The real-root path (EngineOptions(real=True), core/src/roots_real.h):
where a pixel needs only real roots (sigma = delta = 0, or an object with
space: real) the primary rays isolate the real roots inside the clipping
sphere instead of every complex root.

Held to: the same status and hit in every pixel as the complex path
(EngineOptions(real=False), the default), on the presets, random surfaces of
degree 2-12 of every family (products and near-products give double roots
and tangent rays), views whose centre row runs along a singular curve or a
tangency, and real objects in a complex band; every certified pixel it
decides checked against the exact truth (python-flint on the exact ray
polynomial of the pixel's doubles), no wrong pixel and no value rougher than
the complex path's; and it really is taken (not a vacuous comparison)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions, engine_options_from_environment, engine_environment
from argand.render.convert import to_core_scene
from argand.scene import load_scene, scene_from_dict
from tests.helpers.pixel_truth import check_frame, sample_pixels
from tests.helpers.random_surfaces import FAMILIES, random_scene

PRESETS = ("whitney", "plucker", "bicube", "mitchell", "steiner", "togliatti", "barth-sextic", "chmutov-septic",
           "chmutov-octic", "endrass-octic")

#: Odd sizes put the centre row exactly in a plane holding a singular curve
#: or a tangency (the peers benchmark's special views).
SPECIAL = {
    "steiner-axes": {
        "objects": [{"surface": "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2", "clip_radius": 1.2}],
        "camera": {"position": [3.0, 2.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0]},
    },
    "whitney-axis": {
        "objects": [{"surface": "x^2*z + y^2", "clip_radius": 2}],
        "camera": {"position": [5.5, 0.0, 2.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0]},
    },
    "torus-tangent": {
        "objects": [{"surface": "(x^2 + y^2 + z^2 + 3)^2 - 16*(x^2 + y^2)", "clip_radius": 3.5}],
        "camera": {"position": [6.0, 0.0, 1.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0]},
    },
}


def both(scene, params: FrameParams):
    complex_ = render_frame(scene, params, workers=1)
    real = render_frame(scene, FrameParams(**{**params.__dict__, "engine": EngineOptions(real=True)}), workers=1)
    return complex_, real


def assert_same_decisions(a, b, what: str) -> None:
    sa, sb = np.asarray(a.aovs["status"]), np.asarray(b.aovs["status"])
    ha, hb = np.asarray(a.rgba)[..., 3] > 0, np.asarray(b.rgba)[..., 3] > 0
    assert (sa == sb).all(), f"{what}: status differs in {(sa != sb).sum()} pixels"
    assert (ha == hb).all(), f"{what}: hit differs in {(ha != hb).sum()} pixels"


def assert_truthful(scene, params, result, pixels, what: str) -> int:
    check = check_frame(scene, params, result, pixels)
    wrong = [f"({x}, {y}): {p}" for x, y, problems in check.disagreements for p in problems if "wrong: " in p]
    assert not wrong, what + "\n" + "\n".join(wrong)
    return check.certified


def imprecise(scene, params, result, pixels) -> set:
    check = check_frame(scene, params, result, pixels)
    return {(x, y) for x, y, problems in check.disagreements if problems and not any("wrong: " in p for p in problems)}


def differing(a, b) -> list[tuple[int, int]]:
    """Pixels whose Z or count differ between two frames (where the two
    paths' values part, the truth decides which is right)."""
    za, zb = np.asarray(a.aovs["Z"]), np.asarray(b.aovs["Z"])
    with np.errstate(invalid="ignore"):
        dz = ~((za == zb) | (np.isinf(za) & np.isinf(zb)))
    dc = np.asarray(a.aovs["count"]) != np.asarray(b.aovs["count"])
    ys, xs = np.nonzero(dz | dc)
    return list(zip(xs.tolist(), ys.tolist()))


@pytest.mark.parametrize("name", PRESETS)
def test_presets_decide_as_the_complex_path_and_agree_with_the_truth(name):
    scene = load_scene(name)
    params = FrameParams(sigma=0.0, delta=0.0, width=48, height=40)
    complex_, real = both(scene, params)
    assert_same_decisions(complex_, real, name)
    pixels = sorted(set(sample_pixels(48, 40, 80, seed=3)) | set(differing(complex_, real)[:60]))
    assert assert_truthful(scene, params, real, pixels, name) > 0
    # No value rougher than the complex path's where the two differ.
    assert imprecise(scene, params, real, pixels) <= imprecise(scene, params, complex_, pixels)
    # And the values are the same bits: a certified hit shows its root
    # rounded to float32 whichever path's disc proved it (Tracer::show_float).
    certified = lambda f: (np.asarray(f.aovs["status"]) == 0) & (f.rgba[..., 3] > 0)  # noqa: E731
    where = certified(complex_) & certified(real)
    assert where.any()
    for key in ("Z", "re", "im", "arg"):
        a, b = np.asarray(complex_.aovs[key])[where], np.asarray(real.aovs[key])[where]
        assert np.array_equal(a.view(np.uint32), b.view(np.uint32)), (name, key, int((a != b).sum()))
    assert np.array_equal(complex_.rgba[where], real.rgba[where]), name


def test_the_real_path_is_taken_and_proves_most_pixels():
    # (Not vacuous: --explain shows the discs the pixel was decided from;
    # with the real path most hit pixels hold real discs only, where the
    # complex path always holds the quartic's complex pair beside them.)
    from argand.render.explain import explain_pixel

    scene = load_scene("bicube")
    real_only = {True: 0, False: 0}
    for real in (True, False):
        params = FrameParams(sigma=0.0, delta=0.0, width=64, height=64, engine=EngineOptions(real=real))
        for x in range(2, 64, 6):
            for y in range(2, 64, 6):
                e = explain_pixel(scene, params, x, y)
                if e["hit"]:
                    real_only[real] += all(d["real"] and d["center"].imag == 0 for d in e["discs"])
    assert real_only[True] > 20
    assert real_only[False] == 0
    complex_, real = both(scene, FrameParams(sigma=0.0, delta=0.0, width=64, height=64))
    assert (np.asarray(real.aovs["status"]) == 0).mean() > 0.95


@pytest.mark.parametrize("family", FAMILIES)
def test_random_surfaces_of_degree_2_to_12(family):
    for degree in range(2, 13):
        scene = random_scene(family, degree, seed=degree + 41)
        params = FrameParams(sigma=0.0, delta=0.0, width=19, height=17)
        complex_, real = both(scene, params)
        what = f"random {family} degree {degree}"
        assert_same_decisions(complex_, real, what)
        pixels = sorted(set(sample_pixels(19, 17, 25, seed=degree)) | set(differing(complex_, real)[:25]))
        assert_truthful(scene, params, real, pixels, what)


@pytest.mark.parametrize("name", sorted(SPECIAL))
def test_singular_curves_and_tangent_rays_along_the_centre_row(name):
    scene = scene_from_dict(SPECIAL[name])
    params = FrameParams(sigma=0.0, delta=0.0, width=41, height=41)
    complex_, real = both(scene, params)
    assert_same_decisions(complex_, real, name)
    centre_row = [(x, 20) for x in range(41)]
    assert_truthful(scene, params, real, centre_row + sample_pixels(41, 41, 40, seed=5), name)


def test_real_objects_in_a_complex_band_and_samples():
    # A real object (space: real) takes the real path whatever the band; a
    # complex one beside it keeps every root. Four samples per pixel.
    scene = scene_from_dict({
        "objects": [
            {"surface": "x^4 + y^4 + z^4 - 1", "clip_radius": 1.5, "space": "real"},
            {"surface": "x^2 + y^2 + z^2 - 0.36", "clip_radius": 1.5,
             "transform": {"translate": [0.0, 0.9, 0.4]}},
        ],
        "camera": {"position": [4.0, 3.0, 2.0], "look_at": [0.0, 0.0, 0.0]},
    })
    for sigma, delta, samples in ((0.0, math.pi / 9, 1), (0.4, 0.5, 4), (0.0, 0.0, 4)):
        params = FrameParams(sigma=sigma, delta=delta, width=23, height=21, samples=samples)
        complex_, real = both(scene, params)
        assert_same_decisions(complex_, real, f"sigma={sigma} delta={delta} samples={samples}")
        if samples == 1:
            assert_truthful(scene, params, real, sample_pixels(23, 21, 60, seed=9), f"sigma={sigma} delta={delta}")


def test_tile_size_and_kernel_do_not_change_the_frame():
    scene = load_scene("chmutov-octic")
    frames = []
    for tile, kernel in ((16, "auto"), (64, "auto"), (32, "sse2")):
        params = FrameParams(sigma=0.0, delta=0.0, width=64, height=48, engine=EngineOptions(real=True, kernel=kernel))
        frames.append(render_frame(scene, params, tile=tile, workers=1))
    for other in frames[1:]:
        assert np.array_equal(np.asarray(frames[0].rgba), np.asarray(other.rgba))
        for channel in ("Z", "status", "count"):
            assert np.array_equal(np.asarray(frames[0].aovs[channel]), np.asarray(other.aovs[channel]))


def test_the_option_from_the_environment_and_back():
    assert engine_options_from_environment({"ARGAND_REAL": "on"}).real is True
    assert engine_options_from_environment({}).real is False
    assert engine_environment(EngineOptions(real=True))["ARGAND_REAL"] == "on"
    with pytest.raises(ValueError, match="ARGAND_REAL=maybe: use on or off"):
        engine_options_from_environment({"ARGAND_REAL": "maybe"})
    with pytest.raises(ValueError, match="engine option real="):
        EngineOptions(real="yes")
    # The plan records it (and a frame's EXR metadata with it).
    from argand.render.frames import plan

    planned = plan(to_core_scene(load_scene("bicube")), FrameParams(width=8, height=8, engine=EngineOptions(real=True)))
    assert planned.engine["real"] is True
    assert EngineOptions(real=True).metadata()["argand:engine:real"] == "true"
