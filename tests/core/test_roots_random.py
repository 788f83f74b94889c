"""Random polynomials of degree 1 to 12 against the exact truth (truth.py).

28,560 polynomials per run (fixed seed; seven coefficient families x twelve
degrees x 340), every one through all four methods with find_roots_batch.
The three verified methods must make zero false claims; "unverified" must
claim nothing and still account for every root. The fraction verified per
method (and per family) is written to build/random_verification.json and
printed.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from argand.core import METHODS, find_roots, find_roots_batch
from tests.helpers.truth import Truth, check_roots, reproducer

SEED = 20_261_124
PER_BATCH = 340  # polynomials per (family, degree)
DEGREES = range(1, 13)
KINDS = ("normal", "uniform", "integer", "loguniform", "from_roots", "clustered", "sparse")
VERIFIED_METHODS = ("auto", "smith", "paper")
assert set(METHODS) == {*VERIFIED_METHODS, "unverified"}


def _from_roots(rng: np.random.Generator, n: int) -> np.ndarray:
    """prod (t - r) expanded in float64, with real roots, conjugate pairs and
    repeats of both. Half the polynomials take roots on the dyadic grid k/8
    (expansion exact: true multiple roots), half decimal-rounded roots
    (expansion rounded: tight clusters)."""
    dyadic = rng.random() < 0.5

    def value() -> float:
        return float(rng.integers(-16, 17)) / 8.0 if dyadic else round(float(rng.normal()), 2)

    factors: list[list[float]] = []  # lowest degree first
    degree = 0
    while degree < n:
        u = rng.random()
        if factors and u < 0.3:  # repeat an earlier factor (multiple root / pair)
            f = factors[rng.integers(len(factors))]
            if degree + len(f) - 1 > n:
                continue
        elif degree + 2 <= n and u < 0.6:  # conjugate pair a +- bi
            a, b = value(), abs(value()) or 0.5
            f = [a * a + b * b, -2.0 * a, 1.0]
        else:
            f = [-value(), 1.0]
        factors.append(f)
        degree += len(f) - 1
    c = np.array([1.0])
    for f in factors:
        c = np.convolve(c, f)
    scale = 2.0 ** int(rng.integers(-4, 5))  # exact rescaling
    return c * scale


def family(kind: str, rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    if kind == "normal":  # well separated roots, as a rule
        return rng.standard_normal((count, n + 1))
    if kind == "uniform":
        return rng.uniform(-1.0, 1.0, (count, n + 1))
    if kind == "integer":
        # Integers in [-5, 5]: exact multiple roots, zero roots (zero constant
        # terms) and roots at infinity (zero leading terms) all occur.
        m = rng.integers(-5, 6, (count, n + 1)).astype(np.float64)
        m[np.all(m == 0.0, axis=1), 0] = 1.0  # never the zero polynomial
        return m
    if kind == "loguniform":
        signs = rng.choice([-1.0, 1.0], (count, n + 1))
        return signs * 10.0 ** rng.uniform(-15.0, 15.0, (count, n + 1))
    if kind == "from_roots":
        return np.array([_from_roots(rng, n) for _ in range(count)])
    if kind == "clustered":
        # Roots in tight clusters (offsets 1e-4 .. 1e-14 around a few centers),
        # expanded in float64: the hard case for isolation and counting.
        rows = []
        for _ in range(count):
            centers = rng.standard_normal(max(1, n // 3))
            roots = [float(rng.choice(centers)) + float(rng.choice([-1.0, 1.0])) * 10.0 ** rng.uniform(-14, -4) for _ in range(n)]
            c = np.array([1.0])
            for r in roots:
                c = np.convolve(c, [-r, 1.0])
            rows.append(c)
        return np.array(rows)
    if kind == "sparse":
        # Normal coefficients with most of them exactly zero (roots at zero,
        # at infinity, and on symmetric stars).
        m = rng.standard_normal((count, n + 1))
        m[rng.random((count, n + 1)) < 0.6] = 0.0
        m[np.all(m == 0.0, axis=1), 0] = 1.0
        return m
    raise ValueError(kind)


def batches():
    """(kind, degree, matrix), deterministic."""
    rng = np.random.default_rng(SEED)
    for kind in KINDS:
        for n in DEGREES:
            yield kind, n, family(kind, rng, n, PER_BATCH)


@dataclass
class Results:
    polynomials: int = 0
    with_finite_roots: int = 0  # by the exact truth
    # method -> kind -> [polynomials with a finite root, fully verified, entries, verified entries]
    table: dict[str, dict[str, list[int]]] = field(default_factory=dict)
    violations: dict[str, list[str]] = field(default_factory=dict)  # kind -> reproducers
    per_degree_auto_normal: dict[int, float] = field(default_factory=dict)
    auto_escalation: dict[int, int] = field(default_factory=dict)  # level -> polynomials
    seconds: float = 0.0

    def add(self, method: str, kind: str, polys: int, full: int, entries: int, ver: int) -> None:
        row = self.table.setdefault(method, {}).setdefault(kind, [0, 0, 0, 0])
        for j, v in enumerate((polys, full, entries, ver)):
            row[j] += v


@pytest.fixture(scope="module")
def results(build_dir) -> Results:
    start = time.perf_counter()
    res = Results()
    for kind, n, matrix in batches():
        res.violations.setdefault(kind, [])
        res.polynomials += len(matrix)
        answers = {m: find_roots_batch(matrix, m) for m in METHODS}
        for m, batch in answers.items():
            used = batch.count > 0
            has_roots = used.any(axis=1)  # rows without finite roots verify vacuously: left out
            res.add(
                m, kind, int(has_roots.sum()), int((batch.all_verified & has_roots).sum()),
                int(used.sum()), int((batch.verified & used).sum()),
            )
        for level in answers["auto"].escalation:
            res.auto_escalation[int(level)] = res.auto_escalation.get(int(level), 0) + 1
        if kind == "normal":
            res.per_degree_auto_normal[n] = float(answers["auto"].all_verified.mean())
        for r in range(len(matrix)):
            row = matrix[r]
            truth = Truth(list(row))
            res.with_finite_roots += truth.finite_degree > 0
            for m in VERIFIED_METHODS:
                roots = answers[m].row(r)
                problems = check_roots(row, roots, truth)
                if problems:
                    res.violations[kind].append(f"{reproducer(row, m)}: claimed {roots!r}; {problems}")
            roots = answers["unverified"].row(r)
            if roots.verified.any() or roots.real.any():
                res.violations[kind].append(f"{reproducer(row, 'unverified')}: claims verified/real: {roots!r}")
            if int(roots.count.sum()) + roots.n_infinite != n or roots.n_infinite != truth.n_infinite:
                res.violations[kind].append(
                    f"{reproducer(row, 'unverified')}: sum(count) {int(roots.count.sum())} + n_infinite "
                    f"{roots.n_infinite} != {n} (true n_infinite {truth.n_infinite})"
                )
    res.seconds = time.perf_counter() - start
    summary = {
        "seed": SEED,
        "polynomials": res.polynomials,
        "seconds": round(res.seconds, 1),
        "methods": {
            m: {
                "fully_verified": sum(v[1] for v in per.values()) / sum(v[0] for v in per.values()),
                "entries_verified": sum(v[3] for v in per.values()) / max(1, sum(v[2] for v in per.values())),
                "by_family": {k: {"polynomials": v[0], "fully_verified": v[1] / v[0]} for k, v in per.items()},
            }
            for m, per in res.table.items()
        },
        "auto_normal_fully_verified_by_degree": res.per_degree_auto_normal,
        "auto_escalation": {str(k): v for k, v in sorted(res.auto_escalation.items())},
        "violations": {k: len(v) for k, v in res.violations.items()},
    }
    (build_dir / "random_verification.json").write_text(json.dumps(summary, indent=2))
    return res


def test_enough_polynomials(results):
    assert results.polynomials >= 20_000
    assert sum(results.auto_escalation.values()) == results.polynomials
    # Every method reports entries exactly for the polynomials that have a
    # finite root (the exact degree after removing roots at infinity > 0).
    for m in METHODS:
        assert sum(v[0] for v in results.table[m].values()) == results.with_finite_roots, m
    assert results.with_finite_roots >= 0.95 * results.polynomials


@pytest.mark.parametrize("kind", KINDS)
def test_no_false_claims(results, kind):
    found = results.violations[kind]
    assert not found, f"{len(found)} violations in family {kind!r}; first ones:\n" + "\n".join(found[:10])


def test_auto_verifies_well_separated(results):
    # Standard normal coefficients: roots are well separated almost always.
    polys, full = results.table["auto"]["normal"][:2]
    assert full / polys >= 0.99, (full, polys, results.per_degree_auto_normal)


def test_auto_verifies_at_least_as_much_as_smith(results):
    # auto is smith plus escalations: on every family it verifies no less.
    for kind in KINDS:
        assert results.table["auto"][kind][1] >= results.table["smith"][kind][1], kind


def test_verification_table(results, capsys):
    with capsys.disabled():
        print(
            f"\nrandom polynomials: {results.polynomials} in {results.seconds:.1f} s; "
            "fraction fully verified per method (of those with a finite root)"
        )
        print(f"{'method':12s}" + "".join(f"{k:>11s}" for k in KINDS) + f"{'all':>10s}")
        for m in METHODS:
            per = results.table[m]
            cells = "".join(f"{per[k][1] / per[k][0]:11.4f}" for k in KINDS)
            total = sum(v[1] for v in per.values()) / sum(v[0] for v in per.values())
            print(f"{m:12s}{cells}{total:10.4f}")
        print(f"auto escalation (0 double, 1 double-double, 2 exact): {dict(sorted(results.auto_escalation.items()))}")
    for kind in KINDS:
        assert results.table["unverified"][kind][1] == 0 and results.table["unverified"][kind][3] == 0


@pytest.mark.parametrize("method", METHODS)
def test_single_calls_agree_with_truth(method):
    """find_roots (not the batch path, with its auto exact fallback in Python)
    on a smaller sample of every family."""
    rng = np.random.default_rng(SEED + 1)
    problems = []
    for kind in KINDS:
        for n in (1, 2, 3, 5, 8, 12):
            for row in family(kind, rng, n, 8):
                roots = find_roots(row, method=method)
                if method == "unverified":
                    bad = roots.verified.any() or int(roots.count.sum()) + roots.n_infinite != n
                    if bad:
                        problems.append(f"{reproducer(row, method)}: {roots!r}")
                    continue
                found = check_roots(row, roots)
                if found:
                    problems.append(f"{reproducer(row, method)}: {found}")
    assert not problems, "\n".join(problems[:10])
