"""Clusters held together by coefficient radii (the ray caster's case: its
coefficients carry radii of ~1e4 ulps, and a surface such as Endrass's octic,
64 A - B^2, has near-double roots along most rays).

find_roots skips its double-double rung when the discs that the coefficient
radii alone force still group as the double ones do (solve_smith's
family_limited: a heuristic about speed, no claim rests on it), and keeps the
first Smith discs when moving a near-real conjugate pair onto the axis would
make their radii explode (smith_members). These tests check every claim of
such rows against python-flint's exact roots of members of each family (the
midpoint, the corners and random points of the coefficient box), in blocks
that mix them with easy rows, for the batched and the scalar kernel.
"""

from __future__ import annotations

import random

import numpy as np
import pytest

from argand.core import find_roots_batch
from tests.core.test_roots_coefficient_radii import members
from tests.helpers.truth import check_members, reproducer

ULP = 2.0**-53


def _poly(roots: list[complex]) -> list[float]:
    c = np.polynomial.polynomial.polyfromroots(roots)
    return [float(v) for v in np.real(c)]


def _cluster_row(rng: random.Random, n: int) -> list[float]:
    """Degree n with a near-double real pair, a near-real conjugate pair, or
    a tight triple, the other roots spread (real and complex)."""
    base = rng.uniform(0.5, 2.0)
    gap = 10.0 ** rng.uniform(-7, -2)
    kind = rng.choice(["pair", "conjugate", "triple"])
    if kind == "pair":
        roots: list[complex] = [base, base + gap]
    elif kind == "conjugate":
        roots = [complex(base, gap), complex(base, -gap)]
    else:
        roots = [base, base + gap, base - 0.7 * gap]
    while len(roots) < n:
        if n - len(roots) >= 2 and rng.random() < 0.5:
            z = complex(rng.uniform(-2, 2), rng.uniform(0.05, 1.0))
            roots += [z, z.conjugate()]
        else:
            roots.append(rng.uniform(-3, 3))
    return _poly(roots)


def _check(rows: list[list[float]], radii: list[list[float]], rng: random.Random) -> list[str]:
    matrix, rad = np.array(rows), np.array(radii)
    problems: list[str] = []
    for kernel in ("auto", "scalar"):
        result = find_roots_batch(matrix, "auto", kernel, radius=rad)
        for r in range(len(rows)):
            roots = result.row(r)
            n = len(rows[r]) - 1
            if int(roots.count.sum()) + roots.n_infinite != n:
                problems.append(f"{kernel} row {r}: counts do not add up to {n}")
            problems += check_members([rows[r]] + members(rows[r], radii[r], rng, 1), roots,
                                      f"{kernel} row {r}: {reproducer(rows[r], 'auto')} radius {radii[r]}")
    return problems


@pytest.mark.parametrize("n", [5, 6, 8])
def test_family_clusters_in_mixed_lanes(n):
    """Clustered rows with ray-caster-sized radii (1 to 3e4 ulps), shuffled
    among easy rows: every verified disc holds exactly its count of roots of
    every member checked."""
    rng = random.Random(15_3000 + n)
    rows, radii = [], []
    for _ in range(24):
        c = _cluster_row(rng, n)
        f = rng.choice([1.0, 1e2, 1e3, 3e4])
        rows.append(c)
        radii.append([abs(v) * f * ULP for v in c])
    for _ in range(24):
        c = [rng.gauss(0, 1) for _ in range(n + 1)]
        rows.append(c)
        radii.append([abs(v) * ULP for v in c])
    order = list(range(len(rows)))
    rng.shuffle(order)
    rows, radii = [rows[i] for i in order], [radii[i] for i in order]
    problems = _check(rows, radii, rng)
    assert not problems, "\n".join(problems[:10])


def test_near_real_conjugate_pair_keeps_its_discs():
    """A conjugate pair 1e-3.5 off the axis among other roots (the shape that
    Endrass's rays give): moving both approximations onto the axis used to
    leave two nearly equal points whose Smith radii merged all eight roots
    into one disc; now the pair stays a cluster of at most four, and every
    claim holds."""
    roots = [0.910451588, 0.874672499 + 0.000372j, 0.874672499 - 0.000372j, 0.72826479,
             0.440883057 + 0.101j, 0.440883057 - 0.101j, 0.724923233, 0.904931714]
    c = _poly(roots)
    rng = random.Random(15_3001)
    for f in (1e3, 1e4):
        rad = [abs(v) * f * ULP for v in c]
        for kernel in ("auto", "scalar"):
            result = find_roots_batch(np.array([c]), "auto", kernel, radius=np.array([rad]))
            assert int(result.count[0].max()) <= 4, (f, kernel, result.count[0])
        assert not _check([c], [rad], rng)


def test_family_limited_cluster_skips_double_double():
    """A near-double pair that the coefficient radii alone keep together:
    the double-double rung could prove nothing more and is skipped
    (escalation 0), and the cluster disc is still proven."""
    c = _poly([1.0, 1.0 + 1e-6, -0.5, 2.0, complex(0.3, 0.9), complex(0.3, -0.9)])
    rad = [abs(v) * 3e4 * ULP for v in c]
    result = find_roots_batch(np.array([c]), "auto", "scalar", radius=np.array([rad]))
    assert int(result.count[0].max()) == 2
    assert bool(result.verified[0][result.count[0] > 0].all())
    assert int(result.escalation[0]) == 0
    assert not _check([c], [rad], random.Random(15_3002))


@pytest.mark.parametrize("n", [5, 6, 7, 8])
def test_lane_seeded_fallback_keeps_every_disc(n):
    """Rows whose lanes converged but whose Smith discs overlap (clusters
    held by ray-caster-sized radii) go to find_roots seeded with the lane's
    approximations (find_roots_lane_seeded; from scratch where those do not
    end in double). Every claim holds against python-flint for the batched
    kernel, and per row it proves as many discs as the unseeded scalar
    kernel (the reference) and reports the same counts of verified roots."""
    rng = random.Random(15_4000 + n)
    rows, radii = [], []
    for _ in range(40):
        c = _cluster_row(rng, n)
        f = rng.choice([1e3, 1e4, 3e4])
        rows.append(c)
        radii.append([abs(v) * f * ULP for v in c])
        easy = [rng.gauss(0, 1) for _ in range(n + 1)]
        rows.append(easy)
        radii.append([abs(v) * ULP for v in easy])
    matrix, rad = np.array(rows), np.array(radii)
    auto = find_roots_batch(matrix, "auto", "auto", radius=rad)
    scalar = find_roots_batch(matrix, "auto", "scalar", radius=rad)
    fewer = []
    for r in range(len(rows)):
        a, s = auto.row(r), scalar.row(r)
        if int(a.verified.sum()) < int(s.verified.sum()):
            fewer.append((r, a.count.tolist(), s.count.tolist()))
    assert not fewer, fewer[:5]
    assert not _check(rows[::2], radii[::2], rng)
