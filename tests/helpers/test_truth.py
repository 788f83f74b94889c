"""The checker in truth.py must catch false claims, or a green suite proves
nothing. Every test builds a fake ``Roots`` and asserts the exact violation
(or its absence)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from argand.core import Roots, find_roots
from tests.helpers.truth import Truth, check_roots

SQRT2 = math.sqrt(2.0)  # 1.4142135623730951 > sqrt(2) by about 9.7e-17
P = [-2.0, 0.0, 1.0]  # t^2 - 2: roots +-sqrt(2)


def fake(center, radius, count, verified, real, n_infinite=0, degree=None) -> Roots:
    count = np.array(count, dtype=np.int64)
    return Roots(
        center=np.array(center, dtype=np.complex128),
        radius=np.array(radius, dtype=np.float64),
        count=count,
        verified=np.array(verified, dtype=bool),
        real=np.array(real, dtype=bool),
        n_infinite=n_infinite,
        method="fake",
        escalation=0,
        degree=int(count.sum()) + n_infinite if degree is None else degree,
    )


def only(problems: list[str], needle: str) -> None:
    """Exactly one violation, and it is the expected kind."""
    assert len(problems) == 1 and needle in problems[0], problems


# --- true claims pass ------------------------------------------------------


@pytest.mark.parametrize(
    "coeffs, roots",
    [
        pytest.param(P, fake([SQRT2, -SQRT2], [1e-15, 1e-15], [1, 1], [True, True], [True, True]), id="sqrt2"),
        pytest.param(P, fake([0.0], [1.5], [2], [True], [True]), id="one-disc-two-roots"),
        pytest.param(P, fake([SQRT2, -SQRT2], [1e-3, 5.0], [1, 1], [True, False], [True, False]), id="unverified-claims-nothing"),
        # Exact multiple root on an exact point disc (root == center, radius 0).
        pytest.param([1.0, -2.0, 1.0], fake([1.0], [0.0], [2], [True], [True]), id="double-root-radius-0"),
        # Roots exactly on the circle: i and -i on |z| = 1 (closed disc, decided exactly).
        pytest.param([1.0, 0.0, 1.0], fake([0.0], [1.0], [2], [True], [False]), id="roots-on-boundary"),
        # t (t - 1): both roots on the boundary of D(0.5, 0.5).
        pytest.param([0.0, -1.0, 1.0], fake([0.5], [0.5], [2], [True], [True]), id="rational-roots-on-boundary"),
        pytest.param([0.0, 0.0, 0.0, -1.0, 1.0], fake([0.0, 1.0], [0.0, 0.0], [3, 1], [True, True], [True, True]), id="zero-root-x3"),
        pytest.param([1.0, 1.0, 0.0, 0.0], fake([-1.0], [0.0], [1], [True], [True], n_infinite=2), id="roots-at-infinity"),
        pytest.param([3.0], fake([], [], [], [], []), id="degree-0"),
        # A root far beyond float64 (about -1e310) reported unverified with an infinite center.
        pytest.param([1e-310, 1.0, 1e-310], fake([-1e-310, -math.inf], [1e-320, math.inf], [1, 1], [True, False], [True, False]), id="root-beyond-float64"),
    ],
)
def test_true_claims_pass(coeffs, roots):
    assert check_roots(coeffs, roots) == []


# --- false claims are caught ------------------------------------------------


def test_wrong_count_is_caught():
    # One disc holding both roots but claiming one (sum of counts kept right by an unverified entry).
    roots = fake([0.0, 7.0], [2.0, 1.0], [1, 1], [True, False], [False, False])
    only(check_roots(P, roots), "claims 1 roots, holds 2")


def test_count_too_high_is_caught():
    roots = fake([SQRT2, -SQRT2], [1e-15, 1e-15], [2, 1], [True, True], [False, False], degree=2)
    problems = check_roots(P, roots)
    assert any("claims 2 roots, holds 1" in p for p in problems), problems
    assert any("sum(count)" in p for p in problems), problems


def test_disc_missing_the_root_by_a_hair_is_caught():
    # float(sqrt 2) - sqrt 2 ~ 9.67e-17: radius 9e-17 misses it, 1e-16 holds it.
    assert check_roots(P, fake([SQRT2, -SQRT2], [1e-16, 1e-16], [1, 1], [True, True], [False, False])) == []
    problems = check_roots(P, fake([SQRT2, -SQRT2], [9e-17, 1e-16], [1, 1], [True, True], [False, False]))
    assert any("disc 0" in p and "holds 0" in p for p in problems), problems
    assert any("lies in no disc" in p for p in problems), problems


def test_undecided_at_128_bits_is_retried_at_higher_precision(monkeypatch):
    # A truth whose 128-bit balls are too coarse (radius 1e-3) to decide
    # D(float(sqrt 2), 1e-16) must be recomputed at a higher precision, not
    # reported and not guessed.
    import flint

    real_roots = Truth.roots
    asked = []

    def coarse(self, prec=128):
        asked.append(prec)
        roots = real_roots(self, prec)
        if prec > 128:
            return roots
        out = []
        for t in roots:
            ball = flint.acb(flint.arb(t.ball.real.mid(), 1e-3), 0 if t.real else flint.arb(t.ball.imag.mid(), 1e-3))
            out.append(type(t)(ball, t.multiplicity, t.real))
        return out

    monkeypatch.setattr(Truth, "roots", coarse)
    assert check_roots(P, fake([SQRT2, -SQRT2], [1e-16, 1e-16], [1, 1], [True, True], [True, True])) == []
    assert asked[:2] == [128, 256]
    problems = check_roots(P, fake([SQRT2, -SQRT2], [9e-17, 1e-16], [1, 1], [True, True], [True, True]))
    assert any("holds 0" in p for p in problems), problems


def test_overlapping_discs_are_caught():
    # Each disc holds its own root and claims the right count; they overlap.
    roots = fake([-1.5, 1.5], [2.0, 2.0], [1, 1], [True, True], [True, True])
    only(check_roots(P, roots), "not disjoint")


def test_touching_closed_discs_are_caught():
    # D(-s, s) and D(s, s) with s = float(sqrt 2) share exactly the point 0.
    roots = fake([-SQRT2, SQRT2], [SQRT2, SQRT2], [1, 1], [True, True], [True, True])
    only(check_roots(P, roots), "not disjoint")
    # One ulp less radius and they are disjoint.
    r = math.nextafter(SQRT2, 0.0)
    assert check_roots(P, fake([-SQRT2, SQRT2], [r, r], [1, 1], [True, True], [True, True])) == []


def test_duplicate_point_discs_are_caught():
    roots = fake([1.0, 1.0], [0.0, 0.0], [1, 1], [True, True], [True, True])
    problems = check_roots([1.0, -2.0, 1.0], roots)
    assert any("not disjoint" in p for p in problems), problems


def test_wrong_real_flag_is_caught():
    # t^2 + 1: the disc holds i, which is not real.
    roots = fake([1j, -1j], [1e-15, 1e-15], [1, 1], [True, True], [True, False])
    only(check_roots([1.0, 0.0, 1.0], roots), "claims a real root and holds none")


def test_real_flag_on_a_disc_reaching_the_axis_is_caught():
    # (t^2 + 1): D(0.5i, 0.6) crosses the real axis but holds only i.
    roots = fake([0.5j, -1j], [0.6, 1e-15], [1, 1], [True, True], [True, False])
    only(check_roots([1.0, 0.0, 1.0], roots), "claims a real root")


def test_real_without_verified_is_caught():
    roots = fake([SQRT2, -SQRT2], [1e-15, 1e-15], [1, 1], [False, True], [True, True])
    only(check_roots(P, roots), "real claimed without verified")


def test_wrong_n_infinite_is_caught():
    # [1, 1, 0, 0]: one finite root -1 and two at infinity.
    roots = fake([-1.0, 1e300], [0.0, 1.0], [1, 2], [True, False], [True, False], n_infinite=0)
    only(check_roots([1.0, 1.0, 0.0, 0.0], roots), "n_infinite 0 != 2")


def test_missing_root_is_caught_when_all_verified():
    roots = fake([SQRT2], [1e-15], [1], [True], [True], degree=2)
    problems = check_roots(P, roots)
    assert any("lies in no disc" in p for p in problems), problems
    assert any("sum(count)" in p for p in problems), problems


def test_non_finite_verified_disc_is_caught():
    roots = fake([SQRT2, complex(math.inf, 0)], [1e-15, 1.0], [1, 1], [True, True], [True, False])
    assert any("non-finite center" in p for p in check_roots(P, roots))
    roots = fake([SQRT2, -SQRT2], [1e-15, math.nan], [1, 1], [True, True], [True, True])
    assert any("invalid radius" in p for p in check_roots(P, roots))
    roots = fake([SQRT2, -SQRT2], [1e-15, -1.0], [1, 1], [True, True], [True, True])
    assert any("invalid radius" in p for p in check_roots(P, roots))


def test_undecidable_boundary_is_reported_not_passed():
    # t^2 - t + 1 has roots (1 +- i sqrt 3)/2 exactly on |z| = 1, irrational:
    # no precision decides it; the checker must say so instead of passing.
    roots = fake([0.0], [1.0], [2], [True], [False])
    problems = check_roots([1.0, -1.0, 1.0], roots)
    assert problems and all("undecided" in p for p in problems), problems


def test_conjugate_pair_claimed_as_one_root_is_caught():
    roots = fake([1j, -1j], [1e-15, 1e-15], [2, 0], [True, False], [False, False])
    only(check_roots([1.0, 0.0, 1.0], roots), "claims 2 roots, holds 1")


# --- the truth itself ---------------------------------------------------------


def test_truth_has_exact_multiplicities_and_infinity():
    t = Truth([3.0, -5.0, 1.0, 1.0, 0.0])  # (t - 1)^2 (t + 3), one root at infinity
    assert t.n_infinite == 1 and t.degree == 4
    mults = sorted((r.multiplicity, r.real) for r in t.roots())
    assert mults == [(1, True), (2, True)]
    assert sorted(t.exact_roots()) == sorted([(-3, 0), (1, 0)])


def test_truth_takes_the_exact_double_value():
    # 0.1 is not 1/10: the root of t - 0.1 is the double 0.1 exactly.
    assert check_roots([-0.1, 1.0], fake([0.1], [0.0], [1], [True], [True])) == []
    problems = check_roots([-0.1, 1.0], fake([0.1], [1e-18], [1], [True], [True]))
    assert problems == []
    # 1/10 itself is not the root: D(0.1 + 1ulp, tiny) misses.
    nxt = math.nextafter(0.1, 1.0)
    assert check_roots([-0.1, 1.0], fake([nxt], [1e-18], [1], [True], [True]))


@pytest.mark.parametrize("bad", [[], [0.0, 0.0], [1.0, math.nan]])
def test_truth_refuses_what_the_contract_refuses(bad):
    with pytest.raises(ValueError):
        Truth(bad)


def test_flint_precision_is_restored():
    import flint

    before = flint.ctx.prec
    check_roots(P, fake([SQRT2, -SQRT2], [1e-15, 1e-15], [1, 1], [True, True], [True, True]))
    assert flint.ctx.prec == before


@pytest.mark.parametrize("method", ["auto", "smith", "paper"])
def test_real_core_output_passes(method):
    coeffs = [1.0, 0.0, 0.0, 0.0, 1.0]
    assert check_roots(coeffs, find_roots(coeffs, method=method)) == []
