"""The pixel truth in pixel_truth.py must decide pixels right and catch false
claims, or a green render suite proves nothing. Every case here has its
answer worked out by hand (spheres and planes along axis-parallel rays),
including answers that sit within one double of a band edge or exactly on
the clipping sphere."""

from __future__ import annotations

import math

import flint
import pytest

from argand.core import _core

from tests.helpers.pixel_truth import check_pixel, is_wrong, object_ray, pixel_truth, ray_polynomial, scene_objects

IDENTITY = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
UNIT_SPHERE = [(2, 0, 0, 1.0), (0, 2, 0, 1.0), (0, 0, 2, 1.0), (0, 0, 0, -1.0)]
UP = (0.0, 0.0, 1.0)


def scene(*objects: dict) -> _core.SceneSpec:
    """The typed core scene of these objects (terms, and optionally linear,
    translate, complex, clip_radius)."""
    def surface(o: dict) -> _core.SurfaceSpec:
        return _core.SurfaceSpec(terms=o["terms"], degree=max(i + j + k for i, j, k, _ in o["terms"]),
                                 linear=o.get("linear", IDENTITY), translate=o.get("translate", [0.0, 0.0, 0.0]),
                                 complex_space=o.get("complex", True), clip_radius=o.get("clip_radius", 0.0))
    return _core.SceneSpec(objects=[surface(o) for o in objects])


def sphere(**extra) -> dict:
    return dict({"terms": UNIT_SPHERE}, **extra)


def plane_z(height: float, **extra) -> dict:
    """z - height = 0."""
    return dict({"terms": [(0, 0, 1, 1.0), (0, 0, 0, -height)]}, **extra)


def hit_at(truth, t: complex, obj: int = 0) -> None:
    assert truth.decision == "hit", truth.describe()
    assert truth.root.object == obj
    t = complex(t)
    gap = min(abs(truth.root.ball - flint.acb(t.real, s * t.imag)) for s in (1, -1))
    assert gap < 1e-15 * abs(t), truth.describe()


def below_pi_times(x: float, q: flint.fmpq) -> bool:
    """x < q pi, decided at 128 bits."""
    old, flint.ctx.prec = flint.ctx.prec, 128
    try:
        return bool(flint.arb(x) < flint.arb.pi() * q)
    finally:
        flint.ctx.prec = old


def only(problems: list[str], needle: str) -> None:
    assert len(problems) == 1 and needle in problems[0], problems


# --- the exact polynomial ----------------------------------------------------


def test_ray_polynomial_is_exact_for_a_transformed_object():
    # Object space = 2 (world - (1, 0, 0)): the unit sphere becomes the world
    # sphere of radius 1/2 about (1, 0, 0). From (1, 0, -3) along +z:
    # object ray (0, 0, -6) + t (0, 0, 2), p(t) = (2t - 6)^2 - 1 = 4t^2 - 24t + 35.
    obj = scene_objects(scene(sphere(linear=[2.0, 0, 0, 0, 2.0, 0, 0, 0, 2.0], translate=[1.0, 0, 0])))[0]
    oo, od = object_ray(obj, (1.0, 0.0, -3.0), UP)
    assert ray_polynomial(obj, oo, od) == flint.fmpq_poly([35, -24, 4])
    # Every double at its exact value: 0.1 is not 1/10.
    obj = scene_objects(scene({"terms": [(1, 0, 0, 1.0)]}))[0]
    oo, od = object_ray(obj, (0.1, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert ray_polynomial(obj, oo, od)[0] == flint.fmpq(*(0.1).as_integer_ratio()) != flint.fmpq(1, 10)


# --- decisions worked out by hand -------------------------------------------


def test_real_hit_is_the_nearer_positive_root():
    # (t - 3)^2 - 1: roots 2 and 4.
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 0.0, -3.0), UP)
    hit_at(truth, 2)
    assert truth.root.real and truth.root.multiplicity == 1


def test_a_ray_that_misses_in_real_space_hits_in_complex_space():
    # 4 + (t - 3)^2 - 1: roots 3 +- i sqrt(3), argument pi/6, modulus sqrt(12).
    o = (0.0, 2.0, -3.0)
    assert pixel_truth(scene(sphere()), 0.0, 0.0, o, UP).decision == "miss"
    truth = pixel_truth(scene(sphere()), 0.0, math.pi / 2, o, UP)
    hit_at(truth, complex(3, math.sqrt(3)))
    assert truth.root.modulus.overlaps(flint.arb(12).sqrt())
    # A real object shows only positive real roots, whatever the band.
    assert pixel_truth(scene(sphere(complex=False)), 0.0, math.pi / 2, o, UP).decision == "miss"


def test_band_edges_are_decided_to_the_last_bit():
    # The root's argument is exactly pi/6; the double nearest pi/6 is below it.
    o = (0.0, 2.0, -3.0)
    edge = math.pi / 6
    assert below_pi_times(edge, flint.fmpq(1, 6))
    assert pixel_truth(scene(sphere()), edge, 0.0, o, UP).decision == "miss"
    # [edge, edge + 2 ulps] contains pi/6; [prev(edge), edge] does not.
    assert pixel_truth(scene(sphere()), edge, 2 * math.ulp(edge), o, UP).decision == "hit"
    below = math.nextafter(edge, 0.0)
    assert pixel_truth(scene(sphere()), below, edge - below, o, UP).decision == "miss"
    # The conjugate band [-sigma - delta, -sigma] holds the conjugate root.
    assert pixel_truth(scene(sphere()), -math.pi / 6 - 1e-9, 2e-9, o, UP).decision == "hit"


def test_negative_real_roots_have_argument_exactly_pi():
    # From (0, 0, 3) along +z: roots -2 and -4. math.pi is below pi.
    o = (0.0, 0.0, 3.0)
    assert pixel_truth(scene(sphere()), 0.0, 0.0, o, UP).decision == "miss"
    assert below_pi_times(math.pi, flint.fmpq(1))
    assert pixel_truth(scene(sphere()), 0.0, math.pi, o, UP).decision == "miss"
    hit_at(pixel_truth(scene(sphere()), 0.0, math.nextafter(math.pi, 4.0), o, UP), -2)
    hit_at(pixel_truth(scene(sphere()), 3.0, 0.2, o, UP), -2)


def test_the_band_is_taken_modulo_two_pi():
    o = (0.0, 0.0, -3.0)  # real roots 2 and 4: argument 0
    # [-0.5, -0.3] and its conjugate [0.3, 0.5] do not hold 0: a negative sigma
    # is not folded onto the real axis.
    assert pixel_truth(scene(sphere()), -0.5, 0.2, o, UP).decision == "miss"
    # [2 pi - 0.1, 2 pi + 0.1] holds 0 + 2 pi.
    hit_at(pixel_truth(scene(sphere()), 2 * math.pi - 0.1, 0.2, o, UP), 2)
    # sigma = 0 is an edge that holds 0 exactly.
    hit_at(pixel_truth(scene(sphere()), 0.0, 0.0, o, UP), 2)
    assert pixel_truth(scene(sphere()), 1e-300, 0.1, o, UP).decision == "miss"


def test_roots_at_t_zero_are_excluded():
    # The camera on the sphere: p(t) = t^2 - 2t, roots 0 and 2.
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 0.0, -1.0), UP)
    hit_at(truth, 2)
    # Looking away: roots 0 and -2; only -2 remains, argument pi.
    assert pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 0.0, 1.0), UP).decision == "miss"
    hit_at(pixel_truth(scene(sphere()), 0.0, 4.0, (0.0, 0.0, 1.0), UP), -2)


def test_clipping_ball_is_closed_and_exact():
    o = (0.0, 0.0, -3.0)  # roots 2 and 4, hit points (0, 0, -1) and (0, 0, 1)
    hit_at(pixel_truth(scene(sphere(clip_radius=1.0)), 0.0, 0.0, o, UP), 2)
    assert pixel_truth(scene(sphere(clip_radius=math.nextafter(1.0, 0.0))), 0.0, 0.0, o, UP).decision == "miss"
    # The clip applies at the real point at distance |t|, P = o' + |t| d':
    # roots -2 and -4 from (0, 0, 3) land at (0, 0, 5) and (0, 0, 7).
    assert pixel_truth(scene(sphere(clip_radius=4.9)), 0.0, 4.0, (0.0, 0.0, 3.0), UP).decision == "miss"
    hit_at(pixel_truth(scene(sphere(clip_radius=5.0)), 0.0, 4.0, (0.0, 0.0, 3.0), UP), -2)


def test_an_irrational_root_exactly_on_the_clipping_sphere_is_degenerate():
    # From the centre along (1, 1, 0) (not unit): 2 t^2 - 1, roots +-1/sqrt(2),
    # both at distance exactly 1 in object space, on the clip sphere of radius 1.
    truth = pixel_truth(scene(sphere(clip_radius=1.0)), 0.0, 0.0, (0.0, 0.0, 0.0), (1.0, 1.0, 0.0))
    assert truth.decision == "degenerate" and truth.hit is None
    assert "clipping sphere" in truth.reasons[0]


def test_a_modulus_tie_is_degenerate_but_still_a_hit():
    # From the centre along +z: roots +-1, both eligible when the band holds 0 and pi.
    truth = pixel_truth(scene(sphere()), 0.0, 4.0, (0.0, 0.0, 0.0), UP)
    assert truth.decision == "degenerate" and truth.hit is True
    assert "modulus tie" in truth.reasons[0]
    # Two objects meeting the ray at the same point: the sphere and z = -1 at t = 2.
    truth = pixel_truth(scene(sphere(), plane_z(-1.0)), 0.0, 0.0, (0.0, 0.0, -3.0), UP)
    assert truth.decision == "degenerate" and truth.hit is True


def test_the_nearest_object_wins():
    truth = pixel_truth(scene(sphere(), plane_z(-2.5)), 0.0, 0.0, (0.0, 0.0, -3.0), UP)
    hit_at(truth, 0.5, obj=1)
    truth = pixel_truth(scene(sphere(), plane_z(2.5)), 0.0, 0.0, (0.0, 0.0, -3.0), UP)
    hit_at(truth, 2, obj=0)


def test_a_ray_in_the_surface_is_degenerate_and_a_parallel_one_misses():
    assert pixel_truth(scene(plane_z(0.0)), 0.0, 0.0, (1.0, 0.0, 0.0), (1.0, 0.0, 0.0)).decision == "degenerate"
    assert pixel_truth(scene(plane_z(1.0)), 0.0, 0.0, (1.0, 0.0, 0.0), (1.0, 0.0, 0.0)).decision == "miss"


def test_a_tangent_ray_meets_a_double_root():
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 1.0, -3.0), UP)
    hit_at(truth, 3)
    assert truth.root.multiplicity == 2


def test_a_grazing_ray_is_decided_exactly():
    # y = 1 - 2^-53 from the axis: (t - 3)^2 = 1 - y^2 = 2^-52 - 2^-106, two
    # real roots 3 +- 2^-26 (to rounding).
    y = 1.0 - 2.0**-53
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, y, -3.0), UP)
    assert truth.decision == "hit" and truth.root.real
    assert truth.root.modulus < 3
    # y = 1 + 2^-52: (t - 3)^2 = -(2^-51 + 2^-104), a complex pair: a miss at delta = 0.
    assert pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 1.0 + 2.0**-52, -3.0), UP).decision == "miss"


# --- false claims are caught --------------------------------------------------


def real_hit():
    return pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 0.0, -3.0), UP)  # root 2


def complex_hit():
    return pixel_truth(scene(sphere()), 0.0, math.pi / 2, (0.0, 2.0, -3.0), UP)  # 3 + i sqrt 3


@pytest.mark.parametrize(
    "truth, pixel",
    [
        pytest.param(real_hit, (0, True, 2.0, 0.0, 2.0), id="right-root"),
        pytest.param(complex_hit, (0, True, 3.0, math.sqrt(3), math.sqrt(12)), id="complex-root"),
        pytest.param(complex_hit, (0, True, 3.0, -math.sqrt(3), math.sqrt(12)), id="its-conjugate"),
        # float32 AOVs: the float32 nearest the root.
        pytest.param(complex_hit, (0, True, 3.0, 1.7320508, 3.4641016), id="float32-rounding"),
        pytest.param(lambda: pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 2.0, -3.0), UP), (0, False, 0.0, 0.0, math.inf), id="right-miss"),
        # Any claim of a pixel that is not certified is honest.
        pytest.param(real_hit, (1, False, 0.0, 0.0, math.inf), id="cluster-miss"),
        pytest.param(real_hit, (3, True, 4.0, 0.0, 4.0), id="undecided-wrong-root"),
        pytest.param(real_hit, (2, False, 0.0, 0.0, math.inf), id="unverified"),
    ],
)
def test_true_claims_pass(truth, pixel):
    assert check_pixel(truth(), *pixel) == []


def test_certified_miss_on_a_hit_is_caught():
    only(check_pixel(real_hit(), 0, False, 0.0, 0.0, math.inf), "wrong: certified miss")


def test_certified_hit_on_a_miss_is_caught():
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 2.0, -3.0), UP)
    only(check_pixel(truth, 0, True, 3.0, 0.0, 3.0), "wrong: certified hit")


def test_the_farther_root_is_caught():
    problems = check_pixel(real_hit(), 0, True, 4.0, 0.0, 4.0)
    assert len(problems) == 2 and is_wrong(problems), problems
    assert problems[0].startswith("wrong: certified hit at t") and "Z = 4.0" in problems[1], problems
    # The nearer root of the wrong object is wrong too.
    truth = pixel_truth(scene(sphere(), plane_z(-2.5)), 0.0, 0.0, (0.0, 0.0, -3.0), UP)  # plane at 0.5
    only(check_pixel(truth, 0, True, 2.0, 0.0, 0.5), "wrong: certified hit at t")


def test_a_root_off_by_more_than_float32_is_imprecise():
    off = 2.0 * (1 + 2.0**-19)
    problems = check_pixel(real_hit(), 0, True, off, 0.0, off)
    assert len(problems) == 2 and all(p.startswith("imprecise: ") for p in problems), problems
    assert not is_wrong(problems)
    # The imaginary part is checked too (a complex root for a real one).
    only(check_pixel(real_hit(), 0, True, 2.0, 1e-3, 2.0), "imprecise: certified hit at t")
    only(check_pixel(complex_hit(), 0, True, 3.0, 1.74, math.sqrt(12)), "imprecise: certified hit at t")
    # Nearer to the other root: wrong, not imprecise.
    only(check_pixel(real_hit(), 0, True, 3.01, 0.0, 2.0), "wrong: certified hit at t")


def test_z_off_with_its_root_is_imprecise_and_off_its_root_is_wrong():
    """re and im within float32's tolerance of the root, and Z their
    modulus but beyond the tolerance (their errors add up in it): the same
    root, imprecise. Z that is not the modulus of the root written: wrong."""
    t = complex(3.0, math.sqrt(3.0))  # complex_hit's root, |t| = sqrt(12)
    step = 2.0**-21 * abs(t) * 0.9  # each part just within the tolerance
    re, im = t.real + step, t.imag + step
    problems = check_pixel(complex_hit(), 0, True, re, im, math.hypot(re, im))
    only(problems, "imprecise: certified Z")
    assert not is_wrong(problems)
    only(check_pixel(complex_hit(), 0, True, t.real, t.imag, abs(t) * (1 + 2.0**-18)), "wrong: certified Z")


def test_a_certified_single_root_on_a_double_root_is_caught():
    truth = pixel_truth(scene(sphere()), 0.0, 0.0, (0.0, 1.0, -3.0), UP)
    only(check_pixel(truth, 0, True, 3.0, 0.0, 3.0), "wrong: certified a single root")


def test_a_degenerate_truth_checks_what_it_knows():
    tie = pixel_truth(scene(sphere()), 0.0, 4.0, (0.0, 0.0, 0.0), UP)
    only(check_pixel(tie, 0, False, 0.0, 0.0, math.inf), "certified miss")
    assert check_pixel(tie, 0, True, 1.0, 0.0, 1.0) == []
    assert check_pixel(tie, 0, True, -1.0, 0.0, 1.0) == []
    on_clip = pixel_truth(scene(sphere(clip_radius=1.0)), 0.0, 0.0, (0.0, 0.0, 0.0), (1.0, 1.0, 0.0))
    assert check_pixel(on_clip, 0, False, 0.0, 0.0, math.inf) == []


def test_the_documented_command_runs_from_any_folder(tmp_path):
    """docs/rendering.md's command line: the script finds tests.helpers
    wherever it is started from, checks the pixels and exits 0 when no
    certified pixel is contradicted."""
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parent / "pixel_truth.py"
    run = subprocess.run([sys.executable, str(script), "whitney", "--size", "12x10", "-n", "20", "--delta", "pi/18"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "total: 20 pixels" in run.stdout and "0 wrong" in run.stdout, run.stdout
