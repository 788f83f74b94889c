"""What a certified pixel proves, checked from outside: the band rule and its
edges, the exact ray polynomial of a pixel's own doubles against the
renderer's coefficients and radii, certified pixels of degree 6 and 8
surfaces against the exact truth (python-flint), two grazing Bicube
pixels, the escalation channel, --explain, and the object limit."""

from __future__ import annotations

import math
import subprocess
import sys
from fractions import Fraction

import flint
import numpy as np
import pytest
from tests.render.test_frames import exact_ray_polynomial, reference_pixel

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.explain import explain_pixel
from argand.render.frames import (
    BAND_RULE,
    DOUBLE_DOUBLE_LEVEL,
    LADDER_LEVEL_NAMES,
    MAX_OBJECTS,
    REBASED_LEVEL,
    plan,
)
from argand.scene import SceneError, load_scene, scene_from_dict

PI = math.pi  # the double just below pi

# Classic surfaces of degree 6 and 8 (many grazing rays and near-multiple roots).
CHMUTOV_OCTIC = (
    "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2"
    " + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 3"
)
BARTH_SEXTIC = (
    "4*(2.618033988749895*x^2 - y^2)*(2.618033988749895*y^2 - z^2)*(2.618033988749895*z^2 - x^2)"
    " - 4.23606797749979*(x^2 + y^2 + z^2 - 1)^2"
)


def surface(text: str, clip: float, **extra) -> object:
    return scene_from_dict({"objects": [{"surface": text, "clip_radius": clip}], **extra})


# ---------------------------------------------------------------------------
# The band rule
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "sigma, delta",
    [(-0.5, 0.2), (-1e-300, 0.0), (0.1, -1e-300), (0.0, math.nextafter(PI, 4.0)), (PI, 1.3e-16), (2.0, 1.2)],
)
def test_band_rule_refuses_bands_outside_zero_pi(sigma, delta):
    with pytest.raises(ValueError, match="band rule") as info:
        FrameParams(sigma=sigma, delta=delta)
    assert BAND_RULE in str(info.value)
    # The C++ plan refuses it too (the rule is defined there once).
    with pytest.raises(ValueError, match="band rule"):
        _core.plan_frame(to_core_scene(load_scene("bicube")), sigma, delta, 4, 4)


@pytest.mark.parametrize("sigma, delta", [(0.0, 0.0), (0.0, PI), (PI, 0.0), (PI, 1e-16), (1.5, PI - 1.5), (0.3, 0.2)])
def test_band_rule_accepts_bands_inside_zero_pi(sigma, delta):
    FrameParams(sigma=sigma, delta=delta)


def test_cli_refuses_a_negative_sigma_with_the_rule():
    r = subprocess.run([sys.executable, "-m", "argand.cli", "render", "bicube", "--sigma=-0.5", "--delta", "0.2",
                        "--size", "8x8", "--explain", "1,1"], capture_output=True, text=True)
    assert r.returncode != 0
    assert BAND_RULE in " ".join((r.stdout + r.stderr).split())  # (the console wraps lines)


def test_a_band_off_the_real_axis_certifies_no_real_root():
    """A band off the real axis holds no real root: sigma = 0.3, delta = 0.2
    shows only complex roots of |arg| in [0.3, 0.5], in conjugate pairs."""
    sigma, delta = 0.3, 0.2
    r = render_frame(load_scene("bicube"), FrameParams(sigma=sigma, delta=delta, width=33, height=33), workers=1)
    cert = (r.aovs["status"] == 0) & (r.rgba[..., 3] > 0)
    assert cert.any()
    arg = np.abs(r.aovs["arg"][cert].astype(np.float64))
    assert np.all(arg >= sigma - 1e-6) and np.all(arg <= sigma + delta + 1e-6)
    assert np.all(r.aovs["count"][cert] % 2 == 0)
    assert np.all(r.aovs["im"][cert] != 0)


def test_negative_real_roots_are_never_in_the_band_and_positive_ones_only_at_sigma_zero():
    """Camera inside a sphere: every ray has one positive and one negative real
    root. sigma = 0: the positive one (arg 0) at any delta up to fl(pi); the
    negative one (arg pi) is never in a band, since sigma + delta = pi exactly
    is not a sum of two doubles. sigma > 0: no hit."""
    scene = scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 4"}],
                             "camera": {"position": [0.1, -0.2, 0.3], "look_at": [1, 0, 0]}})
    for delta in (0.0, 1.0, PI):
        r = render_frame(scene, FrameParams(delta=delta, width=9, height=9), workers=1)
        assert np.all(r.aovs["status"] == 0)
        assert np.all(r.rgba[..., 3] > 0)
        assert np.all(r.aovs["arg"] == 0) and np.all(r.aovs["re"] > 0)
        assert np.all(r.aovs["count"] == 1)
    r = render_frame(scene, FrameParams(sigma=1e-300, delta=PI - 1e-300, width=9, height=9), workers=1)
    assert np.all(r.aovs["status"] == 0) and not np.any(r.rgba[..., 3] > 0)


# ---------------------------------------------------------------------------
# The ray polynomial: the renderer's coefficients and radii hold the exact one
# ---------------------------------------------------------------------------


def test_coefficient_radii_hold_the_exact_ray_polynomial_of_the_pixels_doubles():
    scene = scene_from_dict({"objects": [{"surface": BARTH_SEXTIC, "clip_radius": 2,
                                          "transform": {"rotate": [10, 20, 30], "translate": [0.1, -0.2, 0.3]}}]})
    params = FrameParams(width=7, height=7)
    frame_plan = plan(to_core_scene(scene), params)
    core = to_core_scene(scene).objects[0]
    L = [Fraction(v) for v in core.linear]
    T = [Fraction(v) for v in core.translate]
    terms = {(a, b, c): Fraction(v) for a, b, c, v in core.terms}
    for y in range(7):
        for x in range(7):
            e = explain_pixel(scene, params, x, y)
            origin, direction = _core.primary_ray(frame_plan, x, y)
            assert list(e["origin"]) == list(origin) and list(e["direction"]) == list(direction)
            # Object-space origin and direction in exact rationals.
            o = [sum(L[3 * r + c] * (Fraction(origin[c]) - T[c]) for c in range(3)) for r in range(3)]
            d = [sum(L[3 * r + c] * Fraction(direction[c]) for c in range(3)) for r in range(3)]
            exact = exact_ray_polynomial(terms, o, d)
            poly = e["polynomials"][0]
            for k, (c, rad) in enumerate(zip(poly["coeffs"], poly["radius"])):
                assert abs(exact[k] - Fraction(c)) <= Fraction(rad), (x, y, k)
                assert rad <= 1e-9 * (1 + abs(float(exact[k])))  # loose: cancellation in the sum


# ---------------------------------------------------------------------------
# Certified pixels against the exact truth, degree 6 and 8
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("text, clip", [(CHMUTOV_OCTIC, 1.5), (BARTH_SEXTIC, 2.0)], ids=["chmutov8", "barth6"])
@pytest.mark.parametrize("delta", [0.0, math.pi / 36, math.pi / 4])
def test_certified_pixels_of_degree_6_and_8_agree_with_the_exact_truth(text, clip, delta):
    scene = surface(text, clip)
    size = 10
    params = FrameParams(delta=delta, width=size, height=size)
    result = render_frame(scene, params, workers=1)
    frame_plan = plan(to_core_scene(scene), params)
    certified = 0
    for y in range(size):
        for x in range(size):
            if int(result.aovs["status"][y, x]) != 0:
                continue
            certified += 1
            origin, direction = _core.primary_ray(frame_plan, x, y)
            hit, best, _clear = reference_pixel(scene, origin, direction, 0.0, delta)
            assert bool(result.rgba[y, x, 3] > 0) == hit, (x, y)
            if hit:
                got = complex(float(result.aovs["re"][y, x]), float(result.aovs["im"][y, x]))
                assert min(abs(got - best), abs(got - best.conjugate())) <= 1e-5 * (1 + abs(best)), (x, y)
    assert certified >= 0.999 * size * size


# ---------------------------------------------------------------------------
# Two grazing Bicube pixels: near-tangent rays must never be certified
# with the opposite answer.
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("look_z", [6.551739800272524, 6.551739800272756])
def test_bicube_grazing_pixels_are_right_or_not_certified(look_z):
    scene = scene_from_dict({
        "objects": [{"surface": "x^4 + y^4 + z^4 - 1000", "clip_radius": 8}],
        "camera": {"position": [18.252658929852675, 12.780649375053615, 12.864739360717584],
                   "look_at": [0, 0, look_z], "up": [0, 0, 1], "fov": 40},
    })
    params = FrameParams(width=257, height=257)
    e = explain_pixel(scene, params, 128, 128)
    origin, direction = e["origin"], e["direction"]
    # The exact answer (python-flint on the exact ray polynomial): two real
    # roots near t = 27.589 (a hit) for the first, a complex pair (a miss)
    # for the second.
    exact_hit, _best, _clear = reference_pixel(scene, origin, direction, 0.0, 0.0)
    assert exact_hit == (look_z == 6.551739800272524)
    if e["status"] == 0:
        assert e["hit"] == exact_hit
    # Pinned: the double discs leave a cluster (two real roots 3e-6 apart, or
    # a complex pair of imaginary part 5.6e-8); the ladder re-isolates the
    # roots (the rebased ray polynomial, or double-double) and certifies the
    # exact answer.
    assert e["status"] == 0 and e["escalation"] in (REBASED_LEVEL, DOUBLE_DOUBLE_LEVEL)


# ---------------------------------------------------------------------------
# The ladder, explain, limits
# ---------------------------------------------------------------------------


def test_explain_runs_render_tiles_path():
    scene = surface(BARTH_SEXTIC, 2.0)
    params = FrameParams(delta=math.pi / 18, width=20, height=20)
    result = render_frame(scene, params, tile=8, workers=1)
    for y in range(0, 20, 3):
        for x in range(0, 20, 3):
            e = explain_pixel(scene, params, x, y, tile=8)
            assert e["status"] == int(result.aovs["status"][y, x])
            assert e["escalation"] == int(result.aovs["escalation"][y, x])
            assert e["hit"] == bool(result.rgba[y, x, 3] > 0)
            if e["hit"]:
                # The root shown: a point of the chosen disc (or of its
                # conjugate: the upper one), or the exact tier's root,
                # rounded to float32 (Tracer::show_root).
                z = e["root"]
                assert z.imag >= 0
                assert float(np.float32(z.real)) == z.real and float(np.float32(z.imag)) == z.imag
                if e["chosen"] >= 0:
                    disc = e["discs"][e["chosen"]]
                    centre = disc["center"]
                    reach = disc["radius"] * (1 + 1e-12) + 2.0 ** -23 * abs(z)
                    assert min(abs(z - centre), abs(z - centre.conjugate())) <= reach, (x, y, z, disc)
                assert np.float32(z.real) == result.aovs["re"][y, x] and np.float32(z.imag) == result.aovs["im"][y, x]


def test_escalation_channel_and_figures():
    r = render_frame(surface("(x^2 + 2.25*y^2 + z^2 - 1)^3 - x^2*z^3 - 0.1125*y^2*z^3", 2.0),
                     FrameParams(width=24, height=24), workers=1)
    esc = r.aovs["escalation"]
    assert esc.dtype == np.uint8 and set(np.unique(esc)) <= set(LADDER_LEVEL_NAMES)
    assert r.figures["escalations"] == int(np.count_nonzero(esc))
    assert r.figures["escalated_share"] == pytest.approx(np.count_nonzero(esc) / esc.size)


def test_cli_explain_prints_the_ray_polynomial_discs_and_status():
    r = subprocess.run([sys.executable, "-m", "argand.cli", "render", "bicube", "--size", "33x33", "--delta", "0.1",
                        "--explain", "16,10"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "ray origin" in out and "ray direction" in out and "c_4 =" in out and "r_4 =" in out
    assert "discs" in out and "status " in out and "ladder level" in out
    bad = subprocess.run([sys.executable, "-m", "argand.cli", "render", "bicube", "--size", "33x33",
                          "--explain", "40,1"], capture_output=True, text=True)
    assert bad.returncode != 0 and "not inside" in " ".join((bad.stdout + bad.stderr).split())


def test_scenes_with_more_objects_than_sixteen_render_and_above_the_limit_are_refused():
    objects = [{"surface": "x^2 + y^2 + z^2 - 0.25", "transform": {"translate": [0.3 * i - 2.5, 0, 0]}}
               for i in range(18)]
    scene = scene_from_dict({"objects": objects, "camera": {"position": [0, -8, 0], "look_at": [0, 0, 0]}})
    r = render_frame(scene, FrameParams(width=24, height=12), workers=1)
    assert r.certified_share == 1.0 and r.hit_share > 0
    assert MAX_OBJECTS == _core.MAX_OBJECTS >= 18
    with pytest.raises(SceneError, match=f"at most {MAX_OBJECTS}"):
        scene_from_dict({"objects": [objects[0]] * (MAX_OBJECTS + 1)})
    core = to_core_scene(scene)
    with pytest.raises(ValueError, match=f"SceneSpec.objects: 36 items; at most {MAX_OBJECTS}"):
        core.objects = list(core.objects) * 2  # 36 objects straight to the typed scene
    for obj in list(core.objects):
        core.objects.append(obj)  # past the setter: the C++ plan refuses
    assert len(core.objects) == 36
    with pytest.raises(ValueError, match=f"at most {MAX_OBJECTS}"):
        _core.plan_frame(core, 0.0, 0.0, 4, 4)
