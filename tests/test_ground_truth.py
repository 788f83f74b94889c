"""The checker must catch false claims, or it proves nothing."""

import numpy as np
import pytest

from argand.core import Roots, find_roots
from ground_truth import check_roots


def roots_of(center, radius, count, verified, real, n_infinite=0):
    return Roots(
        center=np.array(center, dtype=complex),
        radius=np.array(radius, dtype=float),
        count=np.array(count, dtype=np.int64),
        verified=np.array(verified, dtype=bool),
        real=np.array(real, dtype=bool),
        n_infinite=n_infinite,
    )


P = [-2.0, 0.0, 1.0]  # t^2 - 2: roots +-sqrt(2)


def test_true_claims_pass():
    good = roots_of([1.4142135623730951, -1.4142135623730951], [1e-15, 1e-15], [1, 1], [True, True], [True, True])
    assert check_roots(P, good) == []


@pytest.mark.parametrize(
    "bad, expected",
    [
        # the disc misses sqrt(2) by a hair: 1.41421356237309505 - 1.4142135623730951 ~ 9.7e-17
        (roots_of([1.4142135623730951, -1.4142135623730951], [1e-17, 1e-15], [1, 1], [True, True], [False, False]), "holds 0"),
        (roots_of([0.0], [2.0], [1], [True], [False]), "claims 1 roots, holds 2"),
        (roots_of([1.0, 1.4142135623730951], [0.5, 1e-15], [1, 1], [True, True], [False, False]), "not proven disjoint"),
        (roots_of([1.4142135623730951, -1.4142135623730951], [1e-15, 1e-15], [1, 2], [True, True], [False, False]), "sum(count)"),
        (roots_of([1.0 + 1.0j, -1.4142135623730951], [1e-3, 1e-15], [1, 1], [False, True], [True, False]), "real claimed without verified"),
    ],
)
def test_false_claims_are_caught(bad, expected):
    problems = check_roots(P, bad)
    assert any(expected in p for p in problems), problems


def test_false_real_claim_is_caught():
    # t^2 + 1: the disc holds i, which is not real.
    bad = roots_of([1j, -1j], [1e-15, 1e-15], [1, 1], [True, True], [True, False])
    assert any("real root" in p for p in check_roots([1.0, 0.0, 1.0], bad))


def test_missing_root_is_caught_when_all_verified():
    # Only one disc, verified, for a quadratic: count sum is wrong and a root is uncovered.
    bad = roots_of([1.4142135623730951], [1e-15], [1], [True], [True])
    problems = check_roots(P, bad)
    assert any("lies in no disc" in p for p in problems)


def test_real_core_output_passes():
    assert check_roots([1.0, 0.0, 0.0, 0.0, 1.0], find_roots([1.0, 0.0, 0.0, 0.0, 1.0])) == []
