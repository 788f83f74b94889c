"""A batch lane whose Smith discs are proven but overlap (near-double roots:
a ray through a node of Endrass's octic, say) keeps its own discs merged into
cluster discs (SoaRows::provisional) instead of solving the row again. Where
those discs do not decide the pixel, the ladder's double-double level comes
first (the cluster re-isolated from them), and the row is solved as before
(Tracer::settle) only where that does not decide either.

The merged discs are checked here against the exact truth: for every pixel
whose explanation shows them, each disc holds exactly its count of the roots
of the exact rational ray polynomial of the pixel's own doubles
(python-flint), and the pixel's decision agrees with the scalar kernel's."""

from __future__ import annotations

import dataclasses

import math

import flint
import numpy as np
import pytest
from tests.helpers.pixel_truth import Precision, exact, object_ray, ray_polynomial, scene_objects

from argand.render import FrameParams, render_frame
from argand.render.options import EngineOptions
from argand.render.explain import explain_pixel, format_explanation
from argand.render.frames import DOUBLE_DOUBLE_LEVEL, EXACT_MULTIPLE_LEVEL, REBASED_LEVEL
from argand.scene import load_scene, scene_from_dict


def roots_in_disc(poly: flint.fmpq_poly, center: complex, radius: float) -> int | None:
    """How many roots (with multiplicity) of poly lie in the closed disc;
    None if a root ball straddles its edge at every precision tried."""
    c = flint.acb(exact(center.real), exact(center.imag))
    r = flint.arb(exact(radius))
    for prec in (128, 256, 1024):
        with Precision(prec):
            inside = 0
            undecided = False
            for ball, mult in poly.complex_roots():
                dist = abs(ball - c)
                if dist <= r:
                    inside += int(mult)
                elif not dist > r:
                    undecided = True
                    break
            if not undecided:
                return inside
    return None


#: Scenes whose rays meet near-double roots behind the visible surface:
#: Endrass's octic (168 nodes), a shell of two spheres 5e-5 apart inside a
#: third (every ray through the shell), two spheres 0.001 apart with a plane.
SCENES = {
    "endrass-octic": lambda: load_scene("endrass-octic"),
    "shell": lambda: scene_from_dict({"objects": [{
        "surface": "(x^2+y^2+z^2-1)*(x^2+y^2+z^2-1.0001)*(x^2+y^2+z^2-4)", "clip_radius": 2.5}]}),
    "shifted": lambda: scene_from_dict({"objects": [{
        "surface": "(x^2+y^2+z^2-1)*((x-0.001)^2+y^2+z^2-1)*(x^2+y^2+z^2-4)*(x+2*y+3*z-10)",
        "clip_radius": 2.5, "transform": {"rotate": [20, 35, 10]}}]}),
}


@pytest.mark.parametrize("name, size, delta", [
    ("endrass-octic", 40, math.pi / 9),
    ("endrass-octic", 33, 0.0),
    ("shell", 24, math.pi / 9),
    ("shifted", 31, 0.0),
])
def test_merged_lane_discs_hold_exactly_their_counts(name, size, delta):
    scene = SCENES[name]()
    params = FrameParams(delta=delta, width=size, height=size)
    objects = scene_objects(scene)
    merged_rows = clusters = settled = by_ladder = 0
    problems = []
    for y in range(size):
        for x in range(size):
            e = explain_pixel(scene, params, x, y)
            for k, poly in enumerate(e["polynomials"]):
                assert not (poly["provisional"] and poly["settled"])
                settled += poly["settled"]
                if not poly["provisional"]:
                    continue
                merged_rows += 1
                by_ladder += e["escalation"] in (REBASED_LEVEL, DOUBLE_DOUBLE_LEVEL) and e["status"] == 0
                oo, od = object_ray(objects[k], e["origin"], e["direction"])
                exact_poly = ray_polynomial(objects[k], oo, od)
                discs = [d for d in e["discs"] if d["object"] == k]
                assert sum(d["count"] for d in discs) == exact_poly.degree()
                for d in discs:
                    clusters += d["count"] > 1
                    got = roots_in_disc(exact_poly, d["center"], d["radius"])
                    if got != d["count"]:
                        problems.append(f"pixel ({x}, {y}) object {k}: disc {d['center']} r {d['radius']:.3e} "
                                        f"count {d['count']} holds {got} exact roots")
    assert not problems, "\n".join(problems[:10])
    # (Not vacuous: every scene gives merged rows with clusters; on
    # Endrass's octic some pixels need more than the merged discs, and the
    # ladder (the rebased ray, double-double) decides them from those discs,
    # with no row solved again.)
    assert merged_rows >= 10 and clusters >= 10, (merged_rows, clusters)
    if name == "endrass-octic":
        assert by_ladder >= 5 and settled == 0, (by_ladder, settled)


def test_a_true_double_root_is_solved_again_then_proven_by_the_exact_tier():
    """The first root a ray meets is a double root of the exact polynomial
    (the sphere of radius 2 squared): no solve splits it, neither double-
    double from the merged discs nor the row solved again (settle), and the
    exact tier proves its multiplicity (EXACT_MULTIPLE_LEVEL, status 1). Batched and
    scalar kernels agree on every pixel's status and hit."""
    scene = scene_from_dict({"objects": [{"surface": "(x^2+y^2+z^2-4)^2*(x^2+y^2+z^2-1)", "clip_radius": 2.5}]})
    params = FrameParams(delta=0.0, width=21, height=21)
    e = explain_pixel(scene, params, 10, 10)
    assert e["polynomials"][0]["settled"] and e["escalation"] == EXACT_MULTIPLE_LEVEL and e["status"] == 1 and e["hit"], \
        format_explanation(e)
    # (The pixel shows the exact tier's root rounded to float32, as every hit.)
    assert e["exact"]["multiple"] and e["root"].real == float(np.float32(e["exact"]["root"].real))
    batched = render_frame(scene, params, workers=1)
    scalar = render_frame(scene, dataclasses.replace(params, engine=EngineOptions(kernel="scalar")), workers=1)
    assert np.array_equal(batched.aovs["status"], scalar.aovs["status"])
    assert np.array_equal(batched.rgba[..., 3] > 0, scalar.rgba[..., 3] > 0)
    assert np.count_nonzero(np.asarray(batched.aovs["escalation"]) == EXACT_MULTIPLE_LEVEL) >= 50


@pytest.mark.parametrize("name", sorted(SCENES))
def test_merged_discs_change_no_decision_against_the_scalar_kernel(name):
    scene = SCENES[name]()
    params = FrameParams(delta=math.pi / 9, width=96, height=96)
    batched = render_frame(scene, params, workers=1)
    scalar = render_frame(scene, dataclasses.replace(params, engine=EngineOptions(kernel="scalar")), workers=1)
    assert np.array_equal(batched.aovs["status"], scalar.aovs["status"])
    assert np.array_equal(batched.rgba[..., 3] > 0, scalar.rgba[..., 3] > 0)
    assert batched.certified_share == 1.0


def test_explain_says_when_merged_discs_decided_or_did_not():
    """Endrass's octic: the merged discs decide most pixels of their rows
    alone, the ladder's rebased ray polynomial (or double-double) from them
    the rest; a true double root (the sphere of radius 2 squared) has its
    row solved again."""
    said = set()
    cases = [(load_scene("endrass-octic"), 40, [(x, y) for y in range(40) for x in range(40)]),
             (scene_from_dict({"objects": [{"surface": "(x^2+y^2+z^2-4)^2*(x^2+y^2+z^2-1)", "clip_radius": 2.5}]}),
              21, [(10, 10), (8, 12)])]
    for scene, size, pixels in cases:
        params = FrameParams(delta=0.0, width=size, height=size)
        for x, y in pixels:
            e = explain_pixel(scene, params, x, y)
            poly = e["polynomials"][0]
            text = "\n".join(format_explanation(e))
            alone = "merged where they overlap" in text and "they decided the pixel" in text
            rebased = "merged where they overlap" in text and "rebased level re-isolated the clusters" in text
            with_dd = "merged where they overlap" in text and "else double-double coefficients" in text
            again = ("did not decide the pixel, nor did the ladder's re-isolation from them" in text
                     and "so the row was solved again" in text)
            assert alone + rebased + with_dd <= 1
            assert (alone or rebased or with_dd) == poly["provisional"] and again == poly["settled"]
            assert rebased == (poly["provisional"] and e["escalation"] == REBASED_LEVEL)
            assert with_dd == (poly["provisional"] and e["escalation"] >= DOUBLE_DOUBLE_LEVEL)
            said |= {"merged"} if alone else set()
            said |= {"merged, rebased"} if rebased else set()
            said |= {"settled"} if again else set()
    assert said == {"merged", "merged, rebased", "settled"}


@pytest.mark.parametrize("kernel", ["auto", "scalar"])
@pytest.mark.parametrize("name, sigma, delta", [
    ("chmutov-octic", 0.0, math.pi / 9),
    ("barth-sextic", 0.0, math.pi / 9),
    ("togliatti", 0.3, 0.6),
    ("endrass-octic", 0.0, 0.0),
])
def test_a_disc_the_batch_flags_real_holds_one_real_root(name, sigma, delta, kernel):
    """The batch flags a one-root disc real where no other disc can meet its
    mirror image (real_by_mirror, once per sample for every band): every
    such disc an explanation shows holds exactly one root of the pixel's
    exact rational ray polynomial (python-flint), and that root is real
    (Arb isolates a real root of an integer polynomial with an imaginary
    part of exactly zero). A pixel showing such a root writes im = 0. The
    scalar kernel (Tracer::solve) flags its discs the same way."""
    scene = load_scene(name)
    size = 23
    params = FrameParams(sigma=sigma, delta=delta, width=size, height=size, engine=EngineOptions(kernel=kernel))
    objects = scene_objects(scene)
    frame = render_frame(scene, params, workers=1)
    flagged = zero_written = 0
    for y in range(0, size, 2):
        for x in range(0, size, 2):
            e = explain_pixel(scene, params, x, y)
            poly = ray_polynomial(objects[0], *object_ray(objects[0], e["origin"], e["direction"]))
            for i, d in enumerate(e["discs"]):
                if not (d["real"] and d["count"] == 1):
                    continue
                flagged += 1
                c = flint.acb(exact(d["center"].real), exact(d["center"].imag))
                r = flint.arb(exact(d["radius"]))
                with Precision(256):
                    inside = [ball for ball, mult in poly.complex_roots() for _ in range(int(mult)) if abs(ball - c) < r]
                assert len(inside) == 1 and inside[0].imag.is_zero(), (x, y, d, inside)
                if i == e["chosen"] and e["status"] == 0 and e["hit"]:
                    assert frame.aovs["im"][y, x] == 0.0, (x, y)
                    zero_written += 1
    assert flagged >= 20, flagged
    if sigma == 0.0:  # (the band holds the positive real axis: real roots are shown)
        assert zero_written >= 5, zero_written
