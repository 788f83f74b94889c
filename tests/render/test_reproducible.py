"""A frame's bits do not depend on how it was cut or which batched kernel
solved it, and a certified pixel writes its root, not the solver's
approximation.

* Neighbour seeds flow within frame-aligned blocks of kSeedBlock samples
  (render.h, FrameParams::seed_from_neighbour), so a frame cut into tiles
  whose sides are multiples of 8 is the same bits, every channel, whatever
  the tile size and the number of threads; the batched kernels (sse2,
  avx2, avx512 where the CPU runs them) give the same bits too. The scalar
  kernel is another algorithm (find_roots sample by sample, the
  reference): its frames equal each other across tilings, not the batched
  ones.
* A wide disc of one root writes that root (polish.h: Newton's iteration in
  double-double on the proven coefficients), checked against python-flint's
  roots of the exact ray polynomial on a degree-12 product of three tori.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, primary_ray, render_frame
from argand.render.frames import AOV_CHANNELS
from argand.render.options import EngineOptions
from argand.scene import load_scene, scene_from_dict
from argand.scene.presets import PRESETS
from tests.helpers.pixel_truth import pixel_truth, sample_pixels, scene_objects
from tests.helpers.random_surfaces import FAMILIES, random_scene

BATCHED = ["sse2"] + [k for k in ("avx2", "avx512") if k == _core.batch_kernel() or
                      (k == "avx2" and _core.batch_kernel() == "avx512")]


def differences(a, b) -> dict[str, int]:
    """Pixels whose bits differ, per channel (NaN == NaN: bits, not values)."""
    out = {"rgba": int(np.sum(np.any(a.rgba.view(np.uint32) != b.rgba.view(np.uint32), axis=-1)))}
    for k in AOV_CHANNELS:
        x, y = np.ascontiguousarray(a.aovs[k]), np.ascontiguousarray(b.aovs[k])
        out[k] = int(np.sum(x.view(np.uint8).reshape(*x.shape, -1) != y.view(np.uint8).reshape(*y.shape, -1)))
    return {k: v for k, v in out.items() if v}


def same_whatever_the_cut(scene, params: FrameParams, tiles=(8, 16, 24, 32, 64), workers=(1, 2)) -> None:
    reference = render_frame(scene, params, tile=tiles[-1], workers=1)
    for tile in tiles[:-1]:
        for n in workers:
            assert differences(render_frame(scene, params, tile=tile, workers=n), reference) == {}, (tile, n)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_is_the_same_whatever_the_tile_size(name):
    scene = load_scene(name)
    same_whatever_the_cut(scene, FrameParams(sigma=0.1, delta=math.pi / 9, width=75, height=53, samples=scene.samples))


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("degree", [2, 5, 8, 12])
def test_random_surfaces_are_the_same_whatever_the_tile_size_and_batched_kernel(family, degree):
    scene = random_scene(family, degree, seed=degree * 13 + 5)
    frames = [render_frame(scene, FrameParams(delta=0.4, width=45, height=37, engine=EngineOptions(kernel=k)),
                           tile=t, workers=1) for k in BATCHED for t in (8, 16, 40)]
    for f in frames[1:]:
        assert differences(f, frames[0]) == {}


@pytest.mark.parametrize("samples", [4, 9])
def test_samples_and_the_scalar_kernel_are_the_same_whatever_the_tile_size(samples):
    scene = load_scene("chmutov-octic")
    same_whatever_the_cut(scene, FrameParams(delta=math.pi / 18, width=41, height=35, samples=samples),
                          tiles=(8, 16, 32), workers=(2,))
    same_whatever_the_cut(scene, FrameParams(delta=math.pi / 18, width=41, height=35,
                                             engine=EngineOptions(kernel="scalar")), tiles=(8, 24, 64), workers=(1,))


def test_a_certified_pixel_writes_its_root_not_the_solvers_approximation():
    """Degree 12, three tori: the batched lanes stop with wide discs (radius
    up to some 1e-2) around centres up to 2e-4 off; the Z AOV of a certified
    hit is the exact root's modulus to float32 accuracy at the 99th
    percentile and 1e-4 at worst (before polishing: 5.8e-5 and 2.2e-4)."""
    torus = lambda cx, R, r: f"((x-{cx})^2 + y^2 + z^2 + {R * R - r * r})^2 - {4 * R * R}*((x-{cx})^2 + y^2)"  # noqa: E731
    surface = "(" + ")*(".join(torus(cx, 1, r) for cx, r in ((-1.2, 0.35), (0, 0.3), (1.2, 0.35))) + ")"
    scene = scene_from_dict({"objects": [{"surface": surface, "clip_radius": 3.5}],
                             "camera": {"position": [0.5, 2.5, 5.5], "look_at": [0, 0, 0]}})
    width = 96
    params = FrameParams(delta=math.pi / 12, width=width, height=width)
    frame = render_frame(scene, params, tile=32)
    objects = scene_objects(scene)
    errors = []
    for x, y in sample_pixels(width, width, 400, seed=2):
        if frame.aovs["status"][y, x] != 0 or frame.rgba[y, x, 3] == 0:
            continue
        origin, direction = primary_ray(scene, width, width, x, y)
        truth = pixel_truth(scene, params.sigma, params.delta, origin, direction, objects)
        assert truth.decision == "hit"
        exact = float(truth.root.modulus.mid())
        errors.append(abs(float(frame.aovs["Z"][y, x]) - exact) / exact)
    assert len(errors) > 200
    assert np.percentile(errors, 99) < 1e-5 and max(errors) < 1e-4, (np.percentile(errors, [50, 90, 99]), max(errors))


def test_a_tile_off_the_seed_blocks_is_refused_everywhere_with_the_reason():
    """A tile whose side is not a multiple of the seed block would start
    inside a block, its pixels without the seeds they get in any other
    tiling: the frame's bits would depend on the cut (a cluster's centre,
    which conjugate is listed first). The library, the CLI and the farm's
    settings refuse it, naming the rule and the nearest sizes."""
    import subprocess
    import sys
    from pathlib import Path

    from argand.farm.settings import Settings
    from argand.render.frames import TILE_MULTIPLE, check_tile

    scene = load_scene("chmutov-octic")
    params = FrameParams(delta=math.pi / 18, width=40, height=24)
    for bad in (1, 7, 12, 20, 50, 4095):
        with pytest.raises(ValueError, match=f"multiple of {TILE_MULTIPLE}"):
            render_frame(scene, params, tile=bad, workers=1)
    assert [check_tile(t) for t in (8, 16, 24, 4096)] == [8, 16, 24, 4096]
    with pytest.raises(ValueError, match=r"got 20; e\.g\. 16 or 24"):
        check_tile(20)
    with pytest.raises(ValueError, match="multiple of 8"):
        Settings(default_tile=20)
    argand = str(Path(sys.executable).with_name("argand"))
    r = subprocess.run([argand, "render", "whitney", "--size", "8x8", "--tile", "20", "--out", "unused"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "multiple of 8" in r.stderr and "16 or 24" in r.stderr, r.stderr


def case_scene(case: str, seed_of):
    """A preset's name, or FAMILY-DEGREE: that family's random surface of
    that degree, seeded with seed_of(degree)."""
    family, _, degree = case.rpartition("-")
    if family in FAMILIES:
        return random_scene(family, int(degree), seed=seed_of(int(degree)))
    return load_scene(case)


@pytest.mark.parametrize("case", ["chmutov-octic", "barth-sextic", "togliatti", "steiner", "endrass-octic",
                                  *[f"{family}-{degree}" for family in FAMILIES for degree in (4, 7, 10)]])
def test_a_certified_hit_on_the_real_surface_writes_a_real_root(case):
    """At sigma = delta = 0 a certified hit's root is proven real (the band
    is the positive real axis: a disc is in it only once proven real), so
    its value is written on the real line: im = 0 and arg = 0 exactly, and
    re = Z the exact root's value to float32 accuracy (python-flint on the
    exact ray polynomial), however wide the solver's disc was and wherever
    its centre lay off the axis, and however ill-conditioned (close to
    others on a near-product surface, or on an octic seen from afar, whose
    ray polynomial's rounding to doubles moves it by up to 1e-4: such a
    root is polished with F evaluated at the point)."""
    scene = case_scene(case, lambda degree: degree * 7 + 3)
    width, height = 61, 47
    params = FrameParams(sigma=0.0, delta=0.0, width=width, height=height)
    frame = render_frame(scene, params, tile=16, workers=1)
    status, z = frame.aovs["status"], frame.aovs["Z"]
    hits = (status == 0) & (frame.rgba[..., 3] > 0)
    assert hits.sum() > 50, case
    assert np.all(frame.aovs["im"][hits] == 0) and np.all(frame.aovs["arg"][hits] == 0)
    assert np.array_equal(frame.aovs["re"][hits], z[hits])
    objects = scene_objects(scene)
    ys, xs = np.nonzero(hits)
    pick = np.random.default_rng(5).choice(len(xs), size=min(40, len(xs)), replace=False)
    errors = []
    for x, y in zip(xs[pick], ys[pick]):
        origin, direction = primary_ray(scene, width, height, int(x), int(y))
        truth = pixel_truth(scene, 0.0, 0.0, origin, direction, objects)
        assert truth.decision == "hit", (x, y)
        exact = float(truth.root.modulus.mid())
        errors.append(abs(float(z[y, x]) - exact) / exact)
    # (float32's rounding of Z is 2^-24 relative at most)
    assert max(errors) <= 2 ** -22, (np.percentile(errors, [50, 90]), max(errors))


@pytest.mark.parametrize("case", ["chmutov-octic", "endrass-octic", "barth-sextic", "whitney", "bicube",
                                  *[f"{family}-{degree}" for family in FAMILIES for degree in (5, 8, 12)]])
def test_every_certified_hit_writes_its_exact_root_to_float32(case):
    """In complex bands too (σ = 0 and σ > 0), a certified hit's re, im and
    Z are the exact root's (python-flint on the exact ray polynomial, either
    conjugate) to float32 accuracy, 2^-22 of |t|: the solver's disc centre
    polished, and an ill-conditioned root (one that the double ray
    polynomial's rounding moves by more than a float32 shows) polished with
    F at the point along the ray. Of a conjugate pair, the upper root (im
    >= 0) is written."""
    scene = case_scene(case, lambda degree: degree * 11 + 1)
    width, height = 45, 37
    objects = scene_objects(scene)
    checked = 0
    for sigma, delta in ((0.0, math.pi / 12), (0.3, 0.6)):
        params = FrameParams(sigma=sigma, delta=delta, width=width, height=height)
        frame = render_frame(scene, params, tile=16, workers=1)
        hits = (frame.aovs["status"] == 0) & (frame.rgba[..., 3] > 0)
        # Of a conjugate pair (the band holds both), the upper root is written, whatever the kernel's order.
        shown = frame.rgba[..., 3] > 0
        assert np.all(frame.aovs["im"][shown] >= 0) and np.all(frame.aovs["arg"][shown] >= 0), (sigma, delta)
        ys, xs = np.nonzero(hits)
        pick = np.random.default_rng(9).choice(len(xs), size=min(30, len(xs)), replace=False)
        for x, y in zip(xs[pick], ys[pick]):
            origin, direction = primary_ray(scene, width, height, int(x), int(y))
            truth = pixel_truth(scene, sigma, delta, origin, direction, objects)
            assert truth.decision == "hit", (sigma, delta, x, y)
            root = truth.root
            size = float(root.modulus.mid())
            re, im, z = (float(frame.aovs[k][y, x]) for k in ("re", "im", "Z"))
            exact_re, exact_im = float(root.ball.real.mid()), float(root.ball.imag.mid())
            error = max(abs(re - exact_re), min(abs(im - exact_im), abs(im + exact_im)), abs(z - size)) / size
            assert error <= 2 ** -22, (sigma, delta, x, y, error, truth.describe())
            checked += 1
    assert checked >= 20, checked


def test_a_certified_hit_on_a_real_object_in_a_complex_band_writes_a_real_root():
    """An object with space: real has the positive real axis for its band in
    every frame: its certified hits write im = 0 (and Z = re) even where σ
    and δ open a complex band for the object beside it, whose hits keep
    their imaginary parts. Which object a pixel shows comes from the exact
    truth (python-flint), not from the renderer."""
    torus = "((x-0.4)^2+y^2+z^2+1.19)^2 - 4*1.44*((x-0.4)^2+y^2)"  # R = 1.2, r = 0.5
    scene = scene_from_dict({"objects": [{"surface": "x^2*z + y^2", "clip_radius": 1.6},
                                         {"surface": torus, "space": "real", "clip_radius": 2.5}],
                             "camera": {"position": [1.5, 3.0, 5.0], "look_at": [0, 0, 0]}})
    width = height = 61
    params = FrameParams(sigma=0.1, delta=0.5, width=width, height=height)
    frame = render_frame(scene, params, tile=16, workers=1)
    hits = (frame.aovs["status"] == 0) & (frame.rgba[..., 3] > 0)
    objects = scene_objects(scene)
    shown = {0: 0, 1: 0}
    ys, xs = np.nonzero(hits)
    for x, y in list(zip(xs.tolist(), ys.tolist()))[::7]:
        origin, direction = primary_ray(scene, width, height, x, y)
        truth = pixel_truth(scene, params.sigma, params.delta, origin, direction, objects)
        assert truth.decision == "hit", (x, y)
        shown[truth.root.object] += 1
        if truth.root.object == 1:
            assert frame.aovs["im"][y, x] == 0 and frame.aovs["re"][y, x] == frame.aovs["Z"][y, x], (x, y)
            exact = float(truth.root.modulus.mid())
            assert abs(float(frame.aovs["Z"][y, x]) - exact) <= 2 ** -23 * exact, (x, y)
    assert shown[0] > 20 and shown[1] > 100, shown
    assert np.any(frame.aovs["im"][hits] != 0)  # (the complex object's hits)
