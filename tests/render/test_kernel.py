"""The primary rays' batched root kernel against the scalar reference.

render_tile solves runs of 32 samples' ray polynomials together with
find_roots_rows (EngineOptions(kernel="auto"), or a named instruction set)
or sample by sample with find_roots and neighbour seeds (kernel="scalar"). Both prove their decisions for the same exact ray polynomials, so
whole frames of the presets must agree on every pixel's status, hit or miss
and eligible count; the chosen roots agree to the width of their discs.
The batched frames' certified pixels are checked against the exact truth
(tests/helpers/pixel_truth.py) too.
"""

from __future__ import annotations

import dataclasses

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.frames import DOUBLE_DOUBLE_LEVEL, REBASED_LEVEL, plan
from argand.render.options import EngineOptions, engine_options_from_environment
from argand.scene import load_scene, scene_from_dict
from argand.scene.presets import CLASSIC_PRESETS, PAPER_PRESETS
from tests.helpers.pixel_truth import check_frame, sample_pixels

KERNELS = ["scalar", "sse2"] + [k for k in ("avx2", "avx512") if k == _core.batch_kernel() or
                                (k == "avx2" and _core.batch_kernel() == "avx512")]


def with_kernel(kernel: str, params: FrameParams) -> FrameParams:
    return dataclasses.replace(params, engine=EngineOptions(kernel=kernel))


def render_with(kernel: str, scene, params: FrameParams):
    params = with_kernel(kernel, params)
    assert _core.render_kernel(plan(to_core_scene(scene), params)) == kernel
    return render_frame(scene, params, workers=1)


def explain_with(kernel: str, scene, params: FrameParams, x: int, y: int, sample: int = 0) -> dict:
    from argand.render.explain import explain_pixel

    return explain_pixel(scene, with_kernel(kernel, params), x, y, sample=sample)


def assert_same_decisions(a, b, what: str, scene=None, params=None, kernels=("scalar", "scalar"),
                          loose: bool = False) -> int:
    """Same status, hit or miss and eligible count on every pixel; the
    chosen roots of certified hits the same root (or its conjugate). Returns the certified hits
    whose shown centres differ by more than 1e-6 relative (each checked:
    their two chosen discs, from explain_pixel, must meet). loose: the
    eligible counts may differ (a disc that is not the chosen one, e.g.
    straddling the clipping sphere, is proven eligible by one kernel's
    discs and not the other's), any number of chosen centres may differ by
    more than 1e-6 (wide discs at near-multiple roots), and a sample of 12
    of them is checked."""
    sa, sb = np.asarray(a.aovs["status"]), np.asarray(b.aovs["status"])
    diff = np.argwhere(sa != sb)
    assert diff.size == 0, f"{what}: statuses differ at {diff[:10].tolist()}"
    ha, hb = a.rgba[..., 3] > 0, b.rgba[..., 3] > 0
    diff = np.argwhere(ha != hb)
    assert diff.size == 0, f"{what}: hit/miss differ at {diff[:10].tolist()}"
    ca, cb = np.asarray(a.aovs["count"]), np.asarray(b.aovs["count"])
    assert loose or np.array_equal(ca, cb), f"{what}: eligible counts differ at {np.argwhere(ca != cb)[:10].tolist()}"
    # The chosen root of a certified hit is the same root, but the shown
    # centre is its disc's centre, and the two kernels' discs differ (a
    # near-double root's disc may be 1e-5 wide): where the centres differ
    # by more than 1e-6 relative, the two chosen discs must overlap.
    both = (sa == 0) & ha
    scale = np.maximum(1.0, np.abs(np.asarray(a.aovs["Z"])))
    far = np.zeros_like(both)
    for key in ("re", "im"):
        far |= both & (np.abs(np.asarray(a.aovs[key]) - np.asarray(b.aovs[key])) > 1e-6 * scale)
    # Most such pixels show the conjugate of the other kernel's root (a
    # member of a conjugate pair of equal modulus); the rest are wide discs
    # around the same root. Every one of the latter, and a sample of the
    # former, is checked on its discs.
    re_a, re_b = np.asarray(a.aovs["re"]), np.asarray(b.aovs["re"])
    im_a, im_b = np.asarray(a.aovs["im"]), np.asarray(b.aovs["im"])
    mirrored = (np.abs(re_a - re_b) <= 1e-6 * scale) & (np.abs(im_a + im_b) <= 1e-6 * scale)
    rest, flips = np.argwhere(far & ~mirrored), np.argwhere(far & mirrored)
    if loose:
        rest = rest[np.random.default_rng(16).permutation(len(rest))[:12]]
    sample = np.random.default_rng(15).permutation(len(flips))[:12]
    spots = np.concatenate([rest, flips[sample]]) if len(flips) else rest
    if spots.size:
        assert scene is not None, f"{what}: chosen roots differ at {spots[:10].tolist()}"
    assert len(rest) <= 60, f"{what}: {len(rest)} chosen roots differ beyond a conjugate"
    for y, x in spots:
        ea, eb = (explain_with(k, scene, params, int(x), int(y)) for k in kernels)
        da, db = ea["discs"][ea["chosen"]], eb["discs"][eb["chosen"]]
        # The same root, or its conjugate (a hit's root and its mirror twin
        # have the same modulus and are both eligible: which of the two the
        # pixel shows follows the order of the discs).
        reach = (da["radius"] + db["radius"]) * (1 + 1e-12)
        same = abs(da["center"] - db["center"]) <= reach
        twin = abs(da["center"] - db["center"].conjugate()) <= reach
        assert same or twin, (what, x, y, da, db)
    return int(far.sum())


def assert_same_values(a, b, where: np.ndarray, what: str) -> None:
    """The numbers the pixels in ``where`` (certified hits in both frames)
    show are the same bits in both: the root rounded to float32 whatever
    disc proved it (Tracer::show_float), and the colour shaded at it."""
    assert where.any(), f"{what}: no certified hit to compare"
    for key in ("Z", "re", "im", "arg"):
        x, y = np.asarray(a.aovs[key])[where], np.asarray(b.aovs[key])[where]
        differ = x.view(np.uint32) != y.view(np.uint32)
        assert not differ.any(), f"{what}: {key} differs in {int(differ.sum())} certified hits, e.g. " \
            f"{np.argwhere(where)[differ][:3].tolist()}"
    differ = (a.rgba[where] != b.rgba[where]).any(axis=-1)
    assert not differ.any(), f"{what}: colour differs in {int(differ.sum())} certified hits"


@pytest.mark.parametrize("name", PAPER_PRESETS + CLASSIC_PRESETS)
@pytest.mark.parametrize("delta", [0.0, math.pi / 9])
def test_presets_batched_equals_scalar(name, delta):
    scene = load_scene(name)
    params = FrameParams(delta=delta, width=48, height=40)
    scalar = render_with("scalar", scene, params)
    best = _core.batch_kernel()
    batched = render_with(best, scene, params)
    assert_same_decisions(scalar, batched, f"{name} delta={delta:.4f} scalar vs {best}", scene, params,
                          ("scalar", best))
    # A hit on a one-root disc that no other disc's mirror image meets is a
    # real root, proven, and writes im = 0 on both paths (the scalar one
    # wrote find_roots' centre, im some 1e-10, on hundreds of a preset's
    # pixels at delta = pi/9). (On product surfaces a near pair may keep one
    # kernel's disc from the proof and not the other's: presets only.)
    both = (scalar.aovs["status"] == 0) & (batched.aovs["status"] == 0) & (scalar.rgba[..., 3] > 0) \
        & (batched.rgba[..., 3] > 0)
    real_a, real_b = np.asarray(scalar.aovs["im"]) == 0, np.asarray(batched.aovs["im"]) == 0
    assert np.array_equal(real_a[both], real_b[both]), np.argwhere(both & (real_a != real_b))[:5].tolist()
    assert_same_values(scalar, batched, both, f"{name} delta={delta:.4f}")
    # Both frames prove what they claim: their certified pixels against the truth.
    for frame in (batched, scalar):
        check = check_frame(scene, params, frame, sample_pixels(params.width, params.height, 60, seed=15))
        assert check.wrong == 0, check.disagreements[:3]


@pytest.mark.parametrize("kernel", KERNELS[1:])
def test_every_instruction_set_gives_the_same_frame(kernel):
    """The batched instruction sets run the same operations lane by lane:
    identical frames, to the bit."""
    scene = load_scene("chmutov-octic")
    params = FrameParams(delta=math.pi / 18, width=40, height=24, samples=4)
    ref = render_with("sse2", scene, params)
    other = render_with(kernel, scene, params)
    for key in ("status", "count", "re", "im", "Z", "escalation"):
        assert np.array_equal(np.asarray(ref.aovs[key]), np.asarray(other.aovs[key]), equal_nan=True), key
    assert np.array_equal(ref.rgba, other.rgba)


def test_samples_and_tiles_batched_equals_scalar():
    """Antialiased frames (runs of samples cross pixel boundaries) and a tile
    size that does not divide the runs of 32."""
    scene = load_scene("whitney")
    params = FrameParams(delta=math.pi / 18, width=37, height=21, samples=9)
    best = _core.batch_kernel()
    assert_same_decisions(render_with("scalar", scene, params), render_with(best, scene, params), "whitney samples=9")


def test_explain_pixel_replays_the_batched_kernel():
    """explain_pixel gives the pixel render_tile gave it, with either kernel."""
    scene = load_scene("barth-sextic")
    # 70 x 70 in tiles of 64: pixels in the second row and column of tiles
    # replay their seeds from that tile's first row and column.
    params = FrameParams(delta=math.pi / 18, width=70, height=70)
    for kernel in ("scalar", _core.batch_kernel()):
        frame = render_with(kernel, scene, params)
        for x, y in [(15, 11), (3, 50), (29, 2), (20, 37), (5, 66), (66, 66), (40, 65), (67, 30)]:
            e = explain_with(kernel, scene, params, x, y)
            assert e["status"] == frame.aovs["status"][y, x]
            assert e["escalation"] == frame.aovs["escalation"][y, x]
            assert e["hit"] == bool(frame.rgba[y, x, 3] > 0)
            if e["hit"]:
                assert np.float32(e["root"].real) == frame.aovs["re"][y, x]


def test_bad_kernel_names_are_refused_before_any_work():
    with pytest.raises(ValueError, match="ARGAND_KERNEL=avx9000: use one of auto, scalar, sse2, avx2, avx512"):
        engine_options_from_environment({"ARGAND_KERNEL": "avx9000"})
    with pytest.raises(ValueError, match="kernel='avx9000'"):
        EngineOptions(kernel="avx9000")
    # The CLI reads the environment once, at start, and says what is wrong.
    env = dict(os.environ, ARGAND_KERNEL="avx9000")
    run = subprocess.run([sys.executable, "-m", "argand.cli", "render", "whitney", "--size", "8x8", "--out", "/nonexistent"],
                         env=env, capture_output=True, text=True)
    assert run.returncode != 0
    assert "ARGAND_KERNEL=avx9000: use one of" in run.stdout + run.stderr


def test_the_engine_options_are_recorded_in_each_exr(tmp_path):
    from argand.media.frame_files import write_exr
    import OpenImageIO as oiio

    params = FrameParams(delta=0.3, width=8, height=8, engine=EngineOptions(kernel="scalar", cull=False, decide="full"))
    write_exr(render_frame(load_scene("bicube"), params, workers=1), tmp_path / "f.exr")
    spec = oiio.ImageInput.open(str(tmp_path / "f.exr")).spec()
    assert {k: spec.get_string_attribute(f"argand:engine:{k}") for k in ("kernel", "cull", "decide", "shade")} == {
        "kernel": "scalar", "cull": "false", "decide": "full", "shade": "fast"}


@pytest.mark.parametrize("samples", [1, 4])
@pytest.mark.parametrize("power, coeff, scale, kernel", [(2, "6.5e289", 1e-9, "scalar"), (2, "6.5e289", 1e-9, "best"),
                                                         (6, "1e200", 1.55e-18, "scalar")])
def test_non_finite_ray_polynomials_start_on_the_first_level(power, coeff, scale, kernel, samples):
    """A sample whose ray polynomial overflows (a coefficient not finite:
    nothing solved, status unverified) is on the ladder's first level,
    whatever the sample traced before it in the same slot had: here the
    root tier's double-double (the exact double roots of a doubled plane),
    or, sixfold with the scalar kernel, the neighbour's seeds (a seeded
    sample whose decision is not proven is retried without seeds; a
    non-finite one used none).

    The plane x + y + z = 1, to the power 2 or 6 and scaled by a huge
    coefficient, seen from the origin in tiny object units: along a unit
    world direction d the ray polynomial is coeff (1 - s t / scale)^power
    with s = dx + dy + dz, whose top coefficient overflows in the middle
    of the frame (s near sqrt 3) and is finite towards the edges."""
    scene = scene_from_dict({
        "objects": [{"surface": f"{coeff}*(x + y + z - 1)^{power}", "transform": {"scale": scale}}],
        "camera": {"position": [0.0, 0.0, 0.0], "look_at": [1.0, 1.0, 1.0]},
    })
    params = FrameParams(width=16, height=16, samples=samples, exact_pixels_per_block=0)
    kernel = _core.batch_kernel() if kernel == "best" else kernel
    frame = render_with(kernel, scene, params)
    status, level = np.asarray(frame.aovs["status"]), np.asarray(frame.aovs["escalation"])
    assert (level[status == 1] > 0).sum() >= 10, "the finite rays no longer climb the ladder"
    # The pixels every sample of which overflows (explain_pixel's roots
    # status 1, NonFinite); a pixel with finite samples too may climb.
    non_finite = [(y, x) for y, x in np.argwhere(status == 2)
                  if all(explain_with(kernel, scene, params, int(x), int(y), s)["polynomials"][0]["roots_status"] == 1
                         for s in range(samples))]
    assert len(non_finite) >= 10, "no longer enough overflowing pixels"
    for y, x in non_finite:
        assert status[y, x] == 2 and level[y, x] == 0, (y, x, status[y, x], level[y, x])


def test_lane_parallel_ray_polynomials_are_the_scalar_ones(tmp_path):
    """The batched path's ray polynomials come from
    primary_ray_polynomial_run (runs of 32 cells, lane by lane), the scalar
    path's from primary_ray_polynomial: explain_pixel reports each, and they
    agree to the bit, for objects with a general (rotated, scaled) linear
    part, another rotation and the identity; and the pixels render_tile
    gave in runs of 32 are those explain_pixel replays in runs of one."""
    path = tmp_path / "rotated.yaml"
    path.write_text(
        "objects:\n"
        '  - surface: "(x^2 + 2.25*y^2 + z^2 - 1)^3 - x^2*z^3 - 0.1125*y^2*z^3"\n'
        "    clip_radius: 2\n"
        "    transform: {rotate: [20, 35, 10], scale: 1.3, translate: [0.1, -0.2, 0.05]}\n"
        '  - surface: "x^4 + y^4 + z^4 - 2*x^2*y^2 - 0.7"\n'
        "    clip_radius: 2\n"
        "    transform: {rotate: [90, 0, 180], translate: [0.4, 0.3, -0.1]}\n"
        '  - surface: "x^3 - 3*x*y^2 + z^3 - 0.4"\n'
        "    clip_radius: 1.5\n"
    )
    scene = load_scene(path)
    params = FrameParams(delta=math.pi / 9, width=37, height=23)
    best = _core.batch_kernel()
    frame = render_with(best, scene, params)
    for x, y in [(0, 0), (18, 11), (36, 22), (31, 5), (32, 17), (7, 20)]:
        eb = explain_with(best, scene, params, x, y)
        es = explain_with("scalar", scene, params, x, y)
        assert len(eb["polynomials"]) == len(es["polynomials"]) == 3
        for pb, ps in zip(eb["polynomials"], es["polynomials"]):
            assert np.array(pb["coeffs"]).tobytes() == np.array(ps["coeffs"]).tobytes(), (x, y, pb["object"])
            assert np.array(pb["radius"]).tobytes() == np.array(ps["radius"]).tobytes(), (x, y, pb["object"])
        assert eb["status"] == frame.aovs["status"][y, x]
        assert eb["hit"] == bool(frame.rgba[y, x, 3] > 0)
        if eb["hit"]:
            assert np.float32(eb["root"].real) == frame.aovs["re"][y, x]


def test_refined_batched_pixels_replay():
    """Pixels that climb to the rebased or double-double ray (refine changes
    a batched object's discs, on render_tile's own copy of the batch's
    discs) give explain_pixel's decisions, and those of the first pixels of
    the same runs of 32, which read the batch's discs unchanged, too."""
    scene = load_scene("endrass-octic")
    params = FrameParams(delta=0.0, width=48, height=40)
    best = _core.batch_kernel()
    frame = render_with(best, scene, params)
    level = np.asarray(frame.aovs["escalation"])
    climbed = np.isin(level, (REBASED_LEVEL, DOUBLE_DOUBLE_LEVEL))
    spots = np.argwhere(climbed)
    assert len(spots) >= 5, "the scene no longer reaches the rebased or double-double ray"
    spots = list(spots[:: max(1, len(spots) // 6)])
    # Neighbours in the same run of 32 (the row's samples 0..31, 32..47).
    spots += [np.array([y, x + 1]) for y, x in spots[:3] if x + 1 < params.width]
    for y, x in spots:
        e = explain_with(best, scene, params, int(x), int(y))
        assert e["escalation"] == level[y, x]
        assert e["status"] == frame.aovs["status"][y, x]
        assert e["hit"] == bool(frame.rgba[y, x, 3] > 0)
        if e["hit"]:
            assert np.float32(e["root"].real) == frame.aovs["re"][y, x]
            assert np.float32(e["root"].imag) == frame.aovs["im"][y, x]
    check = check_frame(scene, params, frame, [(int(x), int(y)) for y, x in np.argwhere(climbed)])
    assert check.wrong == 0, check.disagreements[:3]


def _high_degree_scene(name: str):
    """Surfaces of degree 9 to 12 (the batched kernel's degrees above the presets')."""
    from argand.scene import scene_from_dict
    from tests.helpers.random_surfaces import random_scene

    if name.startswith("dense-"):
        return random_scene("dense", int(name.split("-")[1]), seed=0)
    spheres = "(x^2+y^2+z^2-1)*((x-0.5)^2+y^2+z^2-0.8)*(x^2+(y-0.4)^2+z^2-0.6)*(x^2+y^2+(z+0.3)^2-0.9)"
    surfaces = {
        "x10": "x^10 + y^10 + z^10 - 1",
        "x12": "x^12 + y^12 + z^12 - 0.5*x^2*y^2*z^2 - 1",
        "spheres-planes-9": spheres + "*(x+y+z-0.2)",
        "spheres-planes-11": spheres + "*(x+y+z-0.2)*(x-y+0.3)*(z-0.05)",
    }
    return scene_from_dict({"objects": [{"surface": surfaces[name], "clip_radius": 2.0}],
                            "camera": {"position": [5.0, 3.0, 2.0], "look_at": [0.0, 0.0, 0.0]}})


@pytest.mark.parametrize("name", ["x10", "x12", "spheres-planes-9", "spheres-planes-11", "dense-10", "dense-12"])
def test_degrees_9_to_12_batched_equals_scalar(name):
    """Objects of degree 9 to 12 go through the batched kernel too (runs of
    32 primary rays, lane-parallel ray polynomials, seeds from the sample
    above): the same decisions as the scalar path on every pixel, certified
    pixels right against the exact truth, and explain_pixel replays the
    batched pixel with the scalar path's ray polynomial, bit for bit."""
    scene = _high_degree_scene(name)
    params = FrameParams(delta=math.pi / 9, width=40, height=30)
    best = _core.batch_kernel()
    scalar = render_with("scalar", scene, params)
    batched = render_with(best, scene, params)
    assert_same_decisions(scalar, batched, f"{name} scalar vs {best}", scene, params, ("scalar", best), loose=True)
    certified = lambda f: (np.asarray(f.aovs["status"]) == 0) & (f.rgba[..., 3] > 0)  # noqa: E731
    assert_same_values(scalar, batched, certified(scalar) & certified(batched), f"{name} scalar vs {best}")
    check = check_frame(scene, params, batched, sample_pixels(params.width, params.height, 25, seed=15))
    assert check.wrong == 0, check.disagreements[:3]
    for x, y in [(20, 15), (33, 7), (5, 26)]:
        eb, es = explain_with(best, scene, params, x, y), explain_with("scalar", scene, params, x, y)
        for pb, ps in zip(eb["polynomials"], es["polynomials"]):
            assert np.array(pb["coeffs"]).tobytes() == np.array(ps["coeffs"]).tobytes(), (name, x, y)
        assert eb["status"] == batched.aovs["status"][y, x]
        assert eb["hit"] == bool(batched.rgba[y, x, 3] > 0)


@pytest.mark.parametrize("seed", range(6))
def test_random_surfaces_show_the_same_values_on_every_kernel(seed):
    """Random surfaces of every family and degree 3 to 12, in a random band,
    cut into random tiles on one or two threads: every certified hit shows
    the same float32 values and colour on the scalar and the batched
    kernel, and on the real-root path at sigma = delta = 0 (Tracer::show_root:
    the root rounded to float32, from a start that does not depend on the
    disc), although their discs differ."""
    from tests.helpers.random_surfaces import FAMILIES, random_scene

    rng = np.random.default_rng([seed, 77])
    family = FAMILIES[seed % len(FAMILIES)]
    degree = int(rng.integers(3, 13))
    scene = random_scene(family, degree, seed=1000 + seed)
    sigma, delta = (0.0, 0.0) if seed % 3 == 0 else (float(rng.uniform(0, 0.6)), float(rng.uniform(0.1, 0.8)))
    params = FrameParams(sigma=sigma, delta=delta, width=40, height=36)
    best = _core.batch_kernel()
    frames = {"scalar": render_frame(scene, with_kernel("scalar", params), tile=16, workers=1),
              best: render_frame(scene, with_kernel(best, params), tile=int(rng.choice([8, 32, 64])), workers=2)}
    if sigma == delta == 0.0:
        frames["real"] = render_frame(scene, dataclasses.replace(params, engine=EngineOptions(real=True)), workers=1)
    certified = {k: (np.asarray(f.aovs["status"]) == 0) & (f.rgba[..., 3] > 0) for k, f in frames.items()}
    for k in frames:
        if k != best:
            assert_same_values(frames[best], frames[k], certified[best] & certified[k],
                               f"{family} degree {degree} sigma={sigma:.3f} delta={delta:.3f}: {best} vs {k}")
