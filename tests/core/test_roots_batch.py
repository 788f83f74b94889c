"""The batched root kernels behind find_roots_batch, lane by lane
against the exact truth (truth.py).

Each batch mixes easy rows (standard normal coefficients: the lanes keep
them) with hard ones (clusters, exact multiple roots, subnormal and zero
coefficients, roots that map back to subnormals, coefficients spanning the
double range, leading coefficients near overflow, Mignotte shapes), shuffled
so that hard rows share blocks with easy ones. Every claim of every row is
checked against python-flint's exact roots; the batched answers are
compared with the scalar path (kernel="scalar": find_roots row by row) for
the same counts and overlapping discs, and every instruction set this CPU
runs must give the same bits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from argand.core import BATCH_MAX_DEGREE, KERNELS, batch_kernel, find_roots_batch
from tests.helpers.stability_families import generate, mignotte
from tests.core.test_roots_random import family
from tests.helpers.truth import Truth, check_members, check_roots, reproducer

SEED = 15_2026
DENORM_MIN = 5e-324
ISAS = {"avx512": ("avx512", "avx2", "sse2"), "avx2": ("avx2", "sse2"), "sse2": ("sse2",)}[batch_kernel()]


def _hard_rows(rng: np.random.Generator, n: int) -> list[list[float]]:
    rows: list[list[float]] = []
    for kind in ("from_roots", "clustered", "integer", "sparse", "loguniform"):
        rows += family(kind, rng, n, 12).tolist()
    for _ in range(8):  # a subnormal coefficient among normal ones
        c = rng.standard_normal(n + 1)
        c[int(rng.integers(0, n + 1))] = DENORM_MIN * float(rng.integers(1, 1 << 20))
        rows.append(c.tolist())
    for _ in range(6):  # roots ~1e-310: the scaled lanes would map back to subnormals
        roots = rng.standard_normal(n) * 1e-310
        c = [1.0]
        for r in roots:
            c = np.convolve(c, [-float(r), 1.0]).tolist()
        rows.append([float(v) for v in c])
    for _ in range(6):  # exact powers of two far out: scaling at the ends of the range
        c = rng.standard_normal(n + 1) * 2.0 ** float(rng.choice([-1000, -600, 600, 1000]))
        rows.append(c.tolist())
    for _ in range(4):  # a leading coefficient near overflow
        c = rng.standard_normal(n + 1)
        c[n] = math.copysign(1.7976931348623157e308, c[n])
        rows.append(c.tolist())
    for _ in range(4):  # exact zero constant term / zero leading coefficient
        c = rng.standard_normal(n + 1)
        c[0 if rng.random() < 0.5 else n] = 0.0
        rows.append(c.tolist())
    if n >= 4:  # Mignotte t^n - 2(a t - 1)^k: k roots near 1/a
        for a, k in ((2.0, 2), (10.0, 3), (16.0, n - 2)):
            rows.append(mignotte(n, a, min(k, n - 2)))
    for fam in ("multiple+subnormal", "subnormal roots", "subnormal pairs", "near overflow", "full range"):
        rows += [c for c in generate(fam, 120, SEED + n) if len(c) == n + 1][:4]
    return rows


def mixed_batch(n: int) -> np.ndarray:
    rng = np.random.default_rng([SEED, n])
    easy = rng.standard_normal((160, n + 1)).tolist()
    with np.errstate(all="ignore"):  # the families over/underflow on purpose
        hard = _hard_rows(rng, n)
    rows = easy + [c for c in hard if all(math.isfinite(v) for v in c) and any(v != 0.0 for v in c)]
    order = rng.permutation(len(rows))
    return np.array([rows[i] for i in order], dtype=np.float64)


DEGREES = range(1, BATCH_MAX_DEGREE + 2)  # the last one is above the kernels: all scalar


@pytest.fixture(scope="module")
def batches() -> dict[int, np.ndarray]:
    return {n: mixed_batch(n) for n in DEGREES}


def _same(a, b) -> bool:
    return all(
        np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True)
        for f in ("center", "radius", "count", "verified", "real", "n_infinite", "escalation")
    )


@pytest.mark.parametrize("method", ["auto", "smith"])
def test_every_lane_against_the_exact_truth(batches, method):
    problems: list[str] = []
    kept = 0
    for n, matrix in batches.items():
        result = find_roots_batch(matrix, method)
        assert result.kernel == (batch_kernel() if n <= BATCH_MAX_DEGREE else "scalar")
        kept += result.lanes_kept
        if n > BATCH_MAX_DEGREE:
            assert result.lanes_kept == 0, n
        else:
            # Most easy rows are answered in the lanes (the batch is not all scalar).
            assert result.lanes_kept >= 100, (n, result.lanes_kept)
        for r in range(len(matrix)):
            found = check_roots(matrix[r], result.row(r), Truth(list(matrix[r])))
            if found:
                problems.append(f"{reproducer(matrix[r], method)} (batch row {r}): {found}")
    assert not problems, f"{len(problems)} rows with false claims:\n" + "\n".join(problems[:10])
    assert kept > 0


@pytest.mark.parametrize("method", ["auto", "smith", "unverified"])
def test_instruction_sets_agree_bit_for_bit(batches, method):
    for n, matrix in batches.items():
        answers = [find_roots_batch(matrix, method, isa) for isa in ISAS]
        for isa, other in zip(ISAS[1:], answers[1:]):
            assert _same(answers[0], other), (n, ISAS[0], isa)


def _overlap(c1: complex, r1: float, c2: complex, r2: float) -> bool:
    return abs(c1 - c2) <= (r1 + r2) * (1 + 1e-12)


@pytest.mark.parametrize("method", ["auto", "smith", "unverified"])
def test_batch_consistent_with_scalar(batches, method):
    for n, matrix in batches.items():
        batched = find_roots_batch(matrix, method)
        scalar = find_roots_batch(matrix, method, "scalar")
        assert scalar.kernel == "scalar" and scalar.lanes_kept == 0
        for r in range(len(matrix)):
            b, s = batched.row(r), scalar.row(r)
            assert int(b.count.sum()) + b.n_infinite == n == int(s.count.sum()) + s.n_infinite, r
            assert b.n_infinite == s.n_infinite
            if method == "unverified":
                assert not b.verified.any() and not b.real.any()
                continue
            if not (b.all_verified and s.all_verified):
                continue
            # Both proven: every batch disc's roots lie in scalar discs, which
            # must therefore meet it with at least as many roots.
            for cb, rb, kb in zip(b.center, b.radius, b.count):
                met = sum(int(ks) for cs, rs, ks in zip(s.center, s.radius, s.count) if _overlap(cb, rb, cs, rs))
                assert met >= kb, (reproducer(matrix[r], method), b, s)
        # Where the lanes answer, they verify as much as the scalar path.
        assert batched.all_verified.sum() >= scalar.all_verified.sum() - 2, n


def test_denormal_inputs_in_the_batched_path():
    """Rows with subnormal coefficients, or whose roots are subnormal, share
    blocks with easy rows: they leave the lanes and are answered right."""
    rng = np.random.default_rng(SEED + 99)
    rows = rng.standard_normal((64, 5))
    rows[5, 2] = DENORM_MIN
    rows[17, 0] = 3 * DENORM_MIN
    rows[33] = [1e-323, -5.960464477539065e-08, 8.98846567431158e307, 0.0, 0.0][::1]
    rows[33, 3:] = 0.0  # degree 2 in a degree-4 row: roots at infinity
    with np.errstate(all="ignore"):
        rows[40] = np.convolve(np.convolve([-1e-310, 1.0], [-2e-310, 1.0]), [1.0, 0.0, 1.0])
    result = find_roots_batch(rows, "auto")
    assert result.lanes_kept >= 56
    for r in (5, 17, 33, 40):
        assert not check_roots(rows[r], result.row(r)), r
    assert result.row(33).n_infinite == 2


def test_bad_kernel_names_are_refused():
    m = np.ones((2, 3))
    with pytest.raises(ValueError, match="unknown kernel 'avx9'"):
        find_roots_batch(m, "auto", "avx9")
    assert set(ISAS) <= set(KERNELS)


def test_bad_rows_are_still_named():
    m = np.random.default_rng(0).standard_normal((40, 5))
    m[23, 1] = math.nan
    with pytest.raises(ValueError, match=r"row 23"):
        find_roots_batch(m, "auto")


@pytest.mark.parametrize("method", ["auto", "smith"])
def test_family_radii_in_the_lanes(method):
    """find_roots_batch(radius=...): each row's discs hold for every member
    of its family (corners and random points of the coefficient box, exact
    truth per member), in the lanes as in the scalar path."""
    import random

    from tests.core.test_roots_coefficient_radii import members, random_family

    rng = random.Random(15_16)
    problems: list[str] = []
    kept = 0
    for n in (2, 4, 6):
        rows, radii = [], []
        while len(rows) < 48:
            coeffs, radius = random_family(rng)
            if len(coeffs) == n + 1:
                rows.append(coeffs)
                radii.append(radius)
        matrix, rad = np.array(rows), np.array(radii)
        result = find_roots_batch(matrix, method, radius=rad)
        scalar = find_roots_batch(matrix, method, "scalar", radius=rad)
        kept += result.lanes_kept
        for r in range(len(rows)):
            roots = result.row(r)
            assert int(roots.count.sum()) + roots.n_infinite == n
            assert int(scalar.row(r).count.sum()) + scalar.row(r).n_infinite == n
            problems += check_members(members(rows[r], radii[r], rng, 2), roots,
                                      f"row {r}: {reproducer(rows[r], method)} radius {radii[r]}")
    assert not problems, "\n".join(problems[:10])
    assert kept > 0
    with pytest.raises(ValueError, match="radius"):
        find_roots_batch(np.ones((2, 3)), "auto", radius=-np.ones((2, 3)))


def _lane_kinds(rng: np.random.Generator, n: int) -> list[list[float]]:
    """One block's worth (16 rows) of lanes of degree n, easy and hard side
    by side: well-separated roots, an exact double root, a near-multiple
    pair (gap 1e-9), a tight cluster of three, a complex pair next to a real
    root of nearly its modulus, and standard normal coefficients."""

    def expand(roots: list[complex]) -> list[float]:
        c = np.poly(np.array(roots))[::-1].real
        return [float(v) for v in c]

    def separated(k: int) -> list[complex]:
        out: list[complex] = []
        while len(out) < k:
            z = complex(rng.uniform(-2, 2), rng.uniform(0.2, 1.5))
            if len(out) + 2 <= k and rng.random() < 0.5:
                out += [z, z.conjugate()]
            else:
                out.append(complex(z.real, 0.0))
        return out

    rows = []
    for lane in range(16):
        kind = lane % 6
        if kind == 0:
            rows.append(rng.standard_normal(n + 1).tolist())
        elif kind == 1:
            rows.append(expand(separated(n)))
        elif kind == 2:  # exact double root beside separated ones
            rows.append(expand([0.625, 0.625] + separated(n - 2)))
        elif kind == 3:  # near-multiple pair
            rows.append(expand([1.0, 1.0 + 1e-9] + separated(n - 2)))
        elif kind == 4:  # cluster of three
            rows.append(expand([0.75, 0.75 + 1e-6, 0.75 - 1e-6] + separated(n - 3)))
        else:  # complex pair beside a real root of nearly its modulus
            rows.append(expand([0.5 + 1j, 0.5 - 1j, -1.118] + separated(n - 3)))
    return rows


@pytest.mark.parametrize("n", range(4, BATCH_MAX_DEGREE + 1))
def test_blocks_mixing_easy_and_hard_lanes(n):
    """Every block of 16 lanes holds easy rows next to exact double roots,
    near-multiple pairs, clusters and near-equal moduli (so the lanes of one
    block stop after different numbers of Aberth sweeps): every claim holds
    against the exact truth, the easy rows are answered in the lanes, and
    every instruction set gives the same bits (their vectors differ in
    width: 2, 4 or 8 lanes)."""
    rng = np.random.default_rng([SEED, 77, n])
    matrix = np.array([row for _ in range(4) for row in _lane_kinds(rng, n)], dtype=np.float64)
    problems: list[str] = []
    for method in ("auto", "smith"):
        answers = [find_roots_batch(matrix, method, isa) for isa in ISAS]
        for isa, other in zip(ISAS[1:], answers[1:]):
            assert _same(answers[0], other), (n, method, ISAS[0], isa)
        result = answers[0]
        assert result.lanes_kept >= 16, (n, method, result.lanes_kept)  # at least the easy kinds
        for r in range(len(matrix)):
            found = check_roots(matrix[r], result.row(r), Truth(list(matrix[r])))
            if found:
                problems.append(f"{reproducer(matrix[r], method)} (lane {r % 16}): {found}")
    assert not problems, f"{len(problems)} rows with false claims:\n" + "\n".join(problems[:10])


def test_results_survive_later_calls():
    """The result arrays share one recycled buffer (bind_roots.cpp): it goes
    back to the pool only when every array of the result has died, so a
    kept result, or a single kept array of one, is never overwritten."""
    rng = np.random.default_rng([SEED, 99])
    a_mat, b_mat = rng.standard_normal((100, 5)), rng.standard_normal((100, 5))
    a = find_roots_batch(a_mat, "auto")
    kept = {f: getattr(a, f).copy() for f in ("center", "radius", "count", "verified", "real", "n_infinite")}
    count_only = find_roots_batch(a_mat, "smith").count
    count_kept = count_only.copy()
    for _ in range(8):
        b = find_roots_batch(b_mat, "auto")
        b.center[:] = 0.0
        del b
    for f, v in kept.items():
        assert np.array_equal(getattr(a, f), v, equal_nan=True), f
    assert np.array_equal(count_only, count_kept)


@pytest.mark.parametrize("n", [9, 12])
def test_family_radii_in_the_lanes_high_degree(n):
    """Coefficient radii (the ray caster's families) at the kernel's top
    degrees: random coefficients, radii from 1e-17 to 1e-6 relative, some
    exact coefficients; every member checked (corners and random points of
    the box) against the exact truth, and the lanes keep most rows."""
    import random

    from tests.core.test_roots_coefficient_radii import members

    rng = random.Random(15_17 + n)
    nrng = np.random.default_rng([SEED, 17, n])
    matrix = nrng.standard_normal((32, n + 1))
    rel = 10.0 ** nrng.uniform(-17, -6, size=(32, 1))
    rad = np.abs(matrix) * rel * nrng.uniform(0.5, 2.0, size=matrix.shape)
    rad[nrng.random(matrix.shape) < 0.1] = 0.0
    result = find_roots_batch(matrix, "auto", radius=rad)
    assert result.lanes_kept >= 24, result.lanes_kept
    problems: list[str] = []
    for r in range(len(matrix)):
        roots = result.row(r)
        problems += check_members(members(matrix[r].tolist(), rad[r].tolist(), rng, 1), roots,
                                  f"{reproducer(matrix[r], 'auto')} radius {rad[r].tolist()}")
    assert not problems, "\n".join(problems[:10])
