"""Rays that provably miss an object's clipping sphere are not solved
(detail::ray_misses_sphere): the object is a proven miss along them, since
the sphere keeps only roots whose point o' + |t| d' lies inside it.

The claim is checked here against exact rational arithmetic on the very
doubles of each pixel's ray (no renderer code in the truth), for cameras
inside, outside and grazing the sphere, with transformed objects; and the
frames with culling (the default) against EngineOptions(cull=False), which solves
and decides every ray disc by disc."""

from __future__ import annotations

from dataclasses import replace

import math
from fractions import Fraction

import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions, engine_options_from_environment
from argand.render.convert import to_core_scene
from argand.render.explain import explain_pixel, format_explanation
from argand.render.frames import plan
from argand.scene import load_scene, scene_from_dict

BARTH_SEXTIC = (
    "4*(2.618033988749895^2*x^2-y^2)*(2.618033988749895^2*y^2-z^2)*(2.618033988749895^2*z^2-x^2)"
    "-(1+2*2.618033988749895)*(x^2+y^2+z^2-1)^2"
)


def exact_min_distance_squared(core_object, origin, direction) -> Fraction:
    """min over s >= 0 of |o' + s d'|^2 for the exact object-space ray of
    the world ray (origin, direction) (the doubles, taken exactly)."""
    L = [Fraction(v) for v in core_object.linear]
    T = [Fraction(v) for v in core_object.translate]
    o = [sum(L[3 * r + c] * (Fraction(origin[c]) - T[c]) for c in range(3)) for r in range(3)]
    d = [sum(L[3 * r + c] * Fraction(direction[c]) for c in range(3)) for r in range(3)]
    oo = sum(v * v for v in o)
    od = sum(a * b for a, b in zip(o, d))
    dd = sum(v * v for v in d)
    if od >= 0:
        return oo
    return oo - od * od / dd


def cases():
    """(id, scene) pairs: transformed objects, cameras far, near, grazing
    and inside the sphere (a seeded family, not one example)."""
    rng = np.random.default_rng(20261202)
    out = [("bicube-default", load_scene("bicube"))]
    for i in range(5):
        clip = float(rng.uniform(1.2, 3.0))
        distance = clip * float(rng.choice([0.5, 1.05, 2.0, 6.0]))  # (0.5: the camera inside)
        position = rng.normal(size=3)
        position = position / np.linalg.norm(position) * distance
        # Look at a point on or near the sphere's edge, so that the frame
        # holds rays on both sides of it and some grazing it.
        look = rng.normal(size=3)
        look = look / np.linalg.norm(look) * clip * float(rng.uniform(0.0, 1.3))
        surface = ["x^4 + y^4 + z^4 - 1", BARTH_SEXTIC, "x^2 + y^2 - z^2 - 0.25"][i % 3]
        out.append((f"family{i}", scene_from_dict({
            "objects": [{"surface": surface, "clip_radius": clip,
                         "transform": {"rotate": [float(v) for v in rng.uniform(0, 90, 3)],
                                       "translate": [float(v) for v in rng.uniform(-0.3, 0.3, 3)],
                                       "scale": float(rng.uniform(0.7, 1.4))}}],
            "camera": {"position": [float(v) for v in position], "look_at": [float(v) for v in look], "fov": 50},
        })))
    return out


CASES = cases()


def check_culled_pixels(scene) -> int:
    """Explains every pixel of a 20x20 frame: each culled pixel's ray
    misses the sphere exactly, and each ray that clears it by a millionth of
    its radius is culled. Returns the number culled."""
    size = 20
    params = FrameParams(delta=math.pi / 9, width=size, height=size)
    frame_plan = plan(to_core_scene(scene), params)
    core = to_core_scene(scene).objects[0]
    radius = Fraction(core.clip_radius)
    culled = clear = clear_culled = 0
    for y in range(size):
        for x in range(size):
            e = explain_pixel(scene, params, x, y)
            origin, direction = _core.primary_ray(frame_plan, x, y)
            dist2 = exact_min_distance_squared(core, origin, direction)
            poly = e["polynomials"][0]
            if poly["outside_sphere"]:
                culled += 1
                assert dist2 > radius * radius, (x, y)  # the claim, exactly
                assert e["status"] == 0 and not e["hit"] and e["discs"] == [] and not poly["complete"]
            if dist2 > radius * radius * Fraction(1 + 10**-6) ** 2:
                clear += 1
                clear_culled += poly["outside_sphere"]
    # Tight: every ray that clears the sphere by a millionth of its radius
    # is culled (none does from a camera inside the sphere).
    assert clear_culled == clear
    return culled


def test_a_ray_is_culled_only_where_it_exactly_misses_the_sphere():
    counts = {name: check_culled_pixels(scene) for name, scene in CASES}
    # (Not vacuous: frames that cull much, little and nothing.)
    assert max(counts.values()) > 100 and min(counts.values()) < 20, counts


@pytest.mark.parametrize("kernel", ["auto", "scalar"])
@pytest.mark.parametrize("name, kw", [
    ("bicube", dict(delta=math.pi / 9)),
    ("whitney-in-sphere", dict(delta=math.pi / 4, samples=4)),
    ("steiner", dict(sigma=0.4, delta=0.5)),
    ("barth-sextic", dict(delta=0.0)),
    ("family0", dict(delta=math.pi / 9)),
    ("family4", dict(delta=0.0)),
    ("family3", dict(delta=math.pi / 6, samples=4)),
])
def test_culling_changes_no_decision_but_certified_misses(name, kw, kernel):
    scene = dict(CASES).get(name) or load_scene(name)
    params = FrameParams(width=41, height=29, **kw)
    off = render_frame(scene, replace(params, engine=EngineOptions(kernel=kernel, cull=False)), workers=1)
    on = render_frame(scene, replace(params, engine=EngineOptions(kernel=kernel, cull=True)), workers=1)
    s_off, s_on = np.asarray(off.aovs["status"]), np.asarray(on.aovs["status"])
    hit_off, hit_on = off.rgba[..., 3] > 0, on.rgba[..., 3] > 0
    same = (s_off == s_on) & (hit_off == hit_on)
    # Where they differ, culling proved a miss the discs left open.
    assert np.all(same | ((s_on == 0) & ~hit_on & (s_off != 0)))
    assert np.all(hit_on <= hit_off)
    assert on.root_calls < off.root_calls  # (not vacuous: some rays culled)
    # A certified pixel shows the same root, up to its conjugate (a seeded
    # object of degree > 4 may start the next row's lanes elsewhere, so its
    # discs' centres may move within their proven discs).
    both = (s_off == 0) & (s_on == 0) & hit_on
    z_off = off.aovs["re"][both] + 1j * np.abs(off.aovs["im"][both])
    z_on = on.aovs["re"][both] + 1j * np.abs(on.aovs["im"][both])
    assert np.allclose(z_on, z_off, rtol=1e-5, atol=1e-6)
    if max(o.polynomial.degree for o in scene.objects) <= 4:
        # No seeds: the very same bits, but the ladder level of a culled
        # pixel (nothing solved, so nothing escalated).
        culled = np.asarray(on.aovs["count"]) == 0
        assert np.array_equal(on.rgba, off.rgba)
        for aov in ("Z", "arg", "re", "im", "count", "status", "certified_share"):
            assert np.array_equal(np.asarray(on.aovs[aov]), np.asarray(off.aovs[aov]), equal_nan=True), aov
        assert np.array_equal(np.asarray(on.aovs["escalation"])[~culled], np.asarray(off.aovs["escalation"])[~culled])


def test_explain_says_why_a_culled_object_has_no_discs():
    scene = load_scene("bicube")
    params = FrameParams(delta=math.pi / 9, width=32, height=32)
    e = explain_pixel(scene, params, 0, 0)  # (a corner: far outside the sphere)
    assert e["polynomials"][0]["outside_sphere"] and e["discs"] == [] and e["status"] == 0 and not e["hit"]
    text = "\n".join(format_explanation(e))
    assert "not solved: the ray provably misses the object's clipping sphere" in text
    e = explain_pixel(scene, params, 16, 16)  # (the centre: through the surface)
    assert not e["polynomials"][0]["outside_sphere"] and e["hit"]
    assert "not solved" not in "\n".join(format_explanation(e))


def test_a_bad_cull_setting_is_refused():
    with pytest.raises(ValueError, match="ARGAND_CULL=sometimes: use on or off"):
        engine_options_from_environment({"ARGAND_CULL": "sometimes"})
    with pytest.raises(ValueError, match="cull='off': use True or False"):
        EngineOptions(cull="off")
