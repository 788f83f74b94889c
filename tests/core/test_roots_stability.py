"""The named stability suite: the polynomials where root finders fail.

Every method runs on every case. No method may ever claim a wrong verified
disc (checked against the exact truth in truth.py); which methods fail to
verify is recorded in build/stability.json and printed, and asserted only
where "auto" must verify (it has an exact fallback).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

# The named cases live with the report that tabulates them (one list for
# the tests and docs/benchmarks.md).
from argand.bench.stability import CASES
from argand.core import METHODS, find_roots, find_roots_batch
from argand.core.roots import MAX_DEGREE
from tests.helpers.truth import Truth, check_roots, reproducer


# "auto" has an exact fallback: on these it must verify every entry.
AUTO_MUST_VERIFY = {
    "double_root (t-1)^2",
    "triple_root (t-2)^3",
    "(t-1)^2(t+3)",
    "quadruple_root (t-1)^4",
    "cluster 1e-6",
    "cluster 1e-10",
    "cluster 1e-15",
    "wilkinson 10",
    "imaginary t^2+1",
    "imaginary t^4+5t^2+4",
    "roots at zero t^3(t-1)",
    "roots at zero t^2(t^2+1)",
    "denormal 5e-324 t^2 - 5e-324",
    "leading zeros [1,1,0,0]",
    "degree 1 [2,-4]",
    "degree 1 [1,3]",
}
assert AUTO_MUST_VERIFY <= set(CASES)

def describe(roots) -> str:
    """One table cell: how much of the answer is verified."""
    if len(roots) == 0:
        cell = "no finite roots"
    elif roots.all_verified:
        cell = "all verified"
    else:
        cell = f"{int(roots.verified.sum())}/{len(roots)} verified"
    return cell + (f" (esc {roots.escalation})" if roots.escalation else "")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", list(CASES), ids=list(CASES))
def test_no_false_claims(name, method):
    coeffs = CASES[name]
    truth = Truth(coeffs)
    roots = find_roots(coeffs, method=method)
    if method == "unverified":
        assert not roots.verified.any() and not roots.real.any(), roots
        assert int(roots.count.sum()) + roots.n_infinite == truth.degree, roots
        assert roots.n_infinite == truth.n_infinite, roots
    else:
        problems = check_roots(coeffs, roots, truth)
        assert not problems, f"{reproducer(coeffs, method)} claimed {roots!r}: {problems}"
    if method == "auto" and name in AUTO_MUST_VERIFY:
        assert len(roots) > 0 and roots.all_verified, f"auto must verify {name}: {roots!r}"


@pytest.mark.parametrize("method", METHODS)
def test_named_facts(method):
    """Exact facts that hold for every method."""
    r = find_roots(CASES["leading zeros [1,1,0,0]"], method=method)
    assert r.n_infinite == 2 and int(r.count.sum()) == 1 and r.degree == 3
    r = find_roots(CASES["degree 0 [3]"], method=method)
    assert len(r) == 0 and r.n_infinite == 0 and r.degree == 0
    for name in ("tiny leading 1e-300 t^3 + t + 1", "tiny leading 1e-320 t^2 + t - 1", "denormal [1e-310, 1, 1e-310]"):
        r = find_roots(CASES[name], method=method)
        assert r.n_infinite == 0, (name, r)  # tiny, not zero: finite (huge) roots


@pytest.mark.parametrize("method", ["auto", "smith", "paper"])
def test_zero_roots_are_exact(method):
    # Contract: exact zero constant terms give an exact verified disc D(0, 0).
    for coeffs, mult in (([0.0, 0.0, 0.0, -1.0, 1.0], 3), ([0.0, 0.0, 1.0, 0.0, 1.0], 2)):
        r = find_roots(coeffs, method=method)
        zero = [i for i in range(len(r)) if r.center[i] == 0 and r.radius[i] == 0 and r.verified[i]]
        assert len(zero) == 1 and int(r.count[zero[0]]) == mult, r


def test_auto_exact_multiplicities():
    r = find_roots(CASES["triple_root (t-2)^3"])
    assert list(r.count) == [3] and bool(r.verified[0]) and bool(r.real[0]), r
    r = find_roots(CASES["(t-1)^2(t+3)"])
    assert sorted(int(c) for c in r.count) == [1, 2] and r.all_verified and r.real.all(), r


def test_auto_finds_the_representable_root_beside_a_huge_one():
    # 1e-320 t^2 + t - 1: roots near 1 and near -1e320 (beyond float64).
    r = find_roots(CASES["tiny leading 1e-320 t^2 + t - 1"])
    assert int(r.count.sum()) == 2
    near_one = [i for i in range(len(r)) if r.verified[i] and abs(complex(r.center[i]) - 1) < 1e-12]
    assert near_one and bool(r.real[near_one[0]]), r


BAD_INPUTS = {
    "nan": ([1.0, math.nan, 1.0], "finite"),
    "+inf": ([1.0, math.inf], "finite"),
    "-inf leading": ([1.0, -math.inf], "finite"),
    "-inf constant": ([-math.inf, 1.0], "finite"),
    "zero polynomial": ([0.0, 0.0, 0.0], "zero polynomial"),
    "zero constant": ([0.0], "zero polynomial"),
    "negative zero": ([-0.0, 0.0], "zero polynomial"),
    "empty": ([], "empty"),
    "above MAX_DEGREE": ([1.0] * (MAX_DEGREE + 2), "maximum"),
    "not 1-D": ([[1.0, 2.0]], "1-D"),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", list(BAD_INPUTS), ids=list(BAD_INPUTS))
def test_bad_input_is_refused(case, method):
    coeffs, message = BAD_INPUTS[case]
    with pytest.raises(ValueError, match=message):
        find_roots(coeffs, method=method)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    "bad_row, message",
    [([1.0, math.nan], "finite"), ([math.inf, 1.0], "finite"), ([0.0, 0.0], "zero polynomial")],
    ids=["nan", "inf", "zero polynomial"],
)
def test_batch_names_the_bad_row(bad_row, message, method):
    matrix = np.array([[1.0, 2.0], [3.0, 4.0], bad_row, [1.0, math.nan]])
    with pytest.raises(ValueError, match=rf"{message}.*row 2"):
        find_roots_batch(matrix, method)


@pytest.mark.parametrize("method", METHODS)
def test_batch_refuses_bad_shapes(method):
    with pytest.raises(ValueError, match="2-D"):
        find_roots_batch(np.ones(3), method)
    with pytest.raises(ValueError, match="empty"):
        find_roots_batch(np.ones((2, 0)), method)


def test_max_degree_itself_is_accepted():
    coeffs = [1.0] * (MAX_DEGREE + 1)  # (t^(n+1) - 1)/(t - 1): roots of unity
    r = find_roots(coeffs, method="auto")
    assert int(r.count.sum()) == MAX_DEGREE
    assert check_roots(coeffs, r) == []


def test_bad_method_is_refused():
    with pytest.raises(ValueError, match="unknown method"):
        find_roots([1.0, 1.0], method="fast")


def test_stability_table(build_dir, capsys):
    """Which methods verify where: written to build/stability.json and
    printed (not asserted; the claims themselves are checked above)."""
    table = {name: {m: describe(find_roots(CASES[name], method=m)) for m in METHODS} for name in CASES}
    (build_dir / "stability.json").write_text(json.dumps(table, indent=2))
    with capsys.disabled():
        print("\nstability: which methods verify (build/stability.json)")
        print(f"{'case':36s}" + "".join(f"{m:>26s}" for m in METHODS))
        for name, row in table.items():
            print(f"{name:36s}" + "".join(f"{row[m]:>26s}" for m in METHODS))
    assert all(row["unverified"] in ("no finite roots",) or "verified" in row["unverified"] for row in table.values())
    assert json.loads((build_dir / "stability.json").read_text()) == table
