"""find_roots with coefficient radii: the discs are proven for a FAMILY.

``find_roots(c, radius=r)`` promises that every verified disc holds exactly
``count`` roots of EVERY real polynomial q with ``|q_k - c_k| <= r_k``, that
verified discs are disjoint and that ``real`` discs hold a real root of each
such q. The ray caster relies on it to certify the surface itself rather
than a rounding of its ray polynomial.

The truth is independent (tests/helpers/truth.py: python-flint on exact rationals):
each test picks members q of the family (corners of the coefficient box and
random interior points, every q_k a double proven inside [c_k - r_k,
c_k + r_k] in rationals) and checks every claim against q's exact roots.
"""

from __future__ import annotations

import math
import random
from fractions import Fraction

import numpy as np
import pytest

from argand.core import find_roots
from tests.helpers.truth import Truth, check_roots

METHODS = ("auto", "smith", "paper")


def member_inside(c: float, r: float, s: float) -> float:
    """A double q with |q - c| <= r exactly, near c + s r (s in [-1, 1])."""
    target = Fraction(c) + Fraction(s) * Fraction(r)
    q = float(target)
    lo, hi = Fraction(c) - Fraction(r), Fraction(c) + Fraction(r)
    while Fraction(q) > hi:
        q = math.nextafter(q, -math.inf)
    while Fraction(q) < lo:
        q = math.nextafter(q, math.inf)
    assert lo <= Fraction(q) <= hi
    return q


def members(coeffs: list[float], radius: list[float], rng: random.Random, k: int) -> list[list[float]]:
    """Corners (all +r, all -r, alternating signs) and random points of the box."""
    n = len(coeffs)
    signs = [[1.0] * n, [-1.0] * n, [(-1.0) ** i for i in range(n)], [-((-1.0) ** i) for i in range(n)]]
    signs += [[rng.uniform(-1, 1) for _ in range(n)] for _ in range(k)]
    return [[member_inside(c, r, s) for c, r, s in zip(coeffs, radius, sv)] for sv in signs]


def check_family(coeffs: list[float], radius: list[float], method: str, rng: random.Random) -> list[str]:
    roots = find_roots(coeffs, method=method, radius=radius)
    problems: list[str] = []
    for q in members(coeffs, radius, rng, 3):
        truth = Truth(q)
        if truth.n_infinite != roots.n_infinite:
            # A member of lower degree: then nothing may be verified.
            if np.any(roots.verified):
                problems.append(f"member {q} has another degree, yet discs are verified")
            continue
        problems += [f"member {q}: {p}" for p in check_roots(q, roots, truth)]
    return problems


def random_family(rng: random.Random) -> tuple[list[float], list[float]]:
    n = rng.randint(1, 8)
    kind = rng.random()
    if kind < 0.4:
        coeffs = [rng.uniform(-1, 1) for _ in range(n + 1)]
    elif kind < 0.7:
        # Roots close together (near-multiple roots), expanded in doubles.
        base = rng.uniform(-2, 2)
        roots = [base + rng.choice([1e-3, 1e-6, 1e-9]) * rng.uniform(-1, 1) for _ in range(n)]
        coeffs = [float(c) for c in np.polynomial.polynomial.polyfromroots(roots)]
    else:
        # Spread scales: roots from 1e-3 to 1e3.
        roots = [10.0 ** rng.uniform(-3, 3) * rng.choice([-1, 1]) for _ in range(n)]
        coeffs = [float(c) for c in np.polynomial.polynomial.polyfromroots(roots)]
    if coeffs[-1] == 0.0:
        coeffs[-1] = 1.0
    rel = 10.0 ** rng.uniform(-17, -4)
    radius = [abs(c) * rel * rng.uniform(0.5, 2.0) for c in coeffs]
    if rng.random() < 0.3:
        radius[rng.randrange(len(radius))] = 0.0  # an exact coefficient among them
    return coeffs, radius


@pytest.mark.parametrize("method", METHODS)
def test_discs_hold_for_every_member_of_random_families(method):
    rng = random.Random(20261201 + METHODS.index(method))
    problems: list[str] = []
    verified_any = 0
    for case in range(150):
        coeffs, radius = random_family(rng)
        found = check_family(coeffs, radius, method, rng)
        problems += [f"case {case} {coeffs} r={radius}: {p}" for p in found]
        verified_any += bool(np.any(find_roots(coeffs, method=method, radius=radius).verified))
    assert not problems, "\n".join(problems[:20])
    # The families are mostly narrow: most must still be proven (a method
    # that proves nothing would pass the check above).
    assert verified_any >= 100


def test_a_radius_that_merges_two_roots_gives_a_cluster_or_nothing():
    # (t - 1)(t - 1 - 1e-6) = t^2 - (2 + 1e-6) t + (1 + 1e-6); a radius of 1e-9
    # on the constant term lets members have a double root or a complex pair.
    c = [1.0 + 1e-6, -(2.0 + 1e-6), 1.0]
    for method in METHODS:
        r = find_roots(c, method=method, radius=[1e-9, 0.0, 0.0])
        for i in np.flatnonzero(r.verified):
            assert r.count[i] != 1 or abs(r.center[i] - 1.0) > 2e-6 + r.radius[i] or r.radius[i] < 5e-7
        assert not check_family(c, [1e-9, 0.0, 0.0], method, random.Random(1))
        # Without the radius the two roots are isolated: the radius is what merged them.
        assert np.all(find_roots(c, method=method).count == 1)


def test_exact_zero_needs_a_zero_radius():
    # p = t (t - 2): with a radius on the constant term the family holds
    # polynomials without the root 0, so nothing may be verified.
    r = find_roots([0.0, -2.0, 1.0], radius=[1e-12, 0.0, 0.0])
    assert not np.any(r.verified)
    r = find_roots([0.0, -2.0, 1.0], radius=[0.0, 1e-12, 1e-12])
    assert np.all(r.verified) and 0.0 in r.center


def test_leading_interval_containing_zero_verifies_nothing():
    for method in METHODS:
        r = find_roots([-1.0, 0.0, 1e-10], method=method, radius=[0.0, 0.0, 2e-10])
        assert not np.any(r.verified)
        r = find_roots([-1.0, 0.0, 0.0], method=method, radius=[0.0, 0.0, 1e-3])
        assert not np.any(r.verified)


def test_zero_radii_change_nothing():
    rng = random.Random(7)
    for _ in range(50):
        coeffs = [rng.uniform(-1, 1) for _ in range(rng.randint(2, 8))]
        a = find_roots(coeffs, method="smith")
        b = find_roots(coeffs, method="smith", radius=[0.0] * len(coeffs))
        assert np.array_equal(a.center, b.center) and np.array_equal(a.radius, b.radius)


def test_bad_radii_are_refused_with_the_reason():
    with pytest.raises(ValueError, match="one entry per coefficient"):
        find_roots([1.0, 2.0, 3.0], radius=[0.0, 0.0])
    with pytest.raises(ValueError, match="radius"):
        find_roots([1.0, 2.0, 3.0], radius=[0.0, -1.0, 0.0])
    with pytest.raises(ValueError):
        find_roots([1.0, 2.0, 3.0], radius=[0.0, math.nan, 0.0])
