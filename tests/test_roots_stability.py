"""Where root finders fail: multiple roots, clusters, Wilkinson, Mignotte,
extreme ranges, tiny leading coefficients, roots at zero and infinity,
denormals, bad input. Every method runs on every case; no method may ever
claim a wrong verified disc; which methods fail to verify is recorded in
build/test-results/stability.json (and printed)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from argand.core import METHODS, find_roots
from ground_truth import check_roots


def expand(roots) -> list[float]:
    """Coefficients (lowest first) of prod (t - r), expanded in float64."""
    c = np.array([1.0])
    for r in roots:
        c = np.convolve(c, [-r, 1.0])
    return [float(v) for v in c]


def mignotte(n: int, a: int) -> list[float]:
    # t^n - 2 (a t - 1)^2: two roots very close to 1/a.
    c = [0.0] * (n + 1)
    c[n] = 1.0
    c[0] -= 2.0
    c[1] += 4.0 * a
    c[2] -= 2.0 * a * a
    return c


CASES: dict[str, list[float]] = {
    "double_root": expand([1, 1]),
    "triple_root": expand([2, 2, 2]),
    "double_root_and_simple": expand([1, 1, -3]),
    "quadruple_root": expand([1, 1, 1, 1]),
    "cluster_1e-6": expand([1, 1 + 1e-6, -2]),
    "cluster_1e-10": expand([1, 1 + 1e-10, -2]),
    "cluster_1e-15": expand([1, 1 + 1e-15, -2]),
    "quartic_minus_1e-8": [v - (1e-8 if i == 0 else 0) for i, v in enumerate(expand([1, 1, 1, 1]))],
    "quartic_minus_1e-12": [v - (1e-12 if i == 0 else 0) for i, v in enumerate(expand([1, 1, 1, 1]))],
    "quartic_minus_1e-16": [v - (1e-16 if i == 0 else 0) for i, v in enumerate(expand([1, 1, 1, 1]))],
    "wilkinson_10": expand(range(1, 11)),
    "wilkinson_20": expand(range(1, 21)),
    "mignotte_7_10": mignotte(7, 10),
    "mignotte_10_100": mignotte(10, 100),
    "span_1e-150_1e150": [10.0 ** (150 - 25 * k) for k in range(13)],
    "span_1e-150_1e150_signs": [(-1) ** (k * (k + 1) // 2) * 10.0 ** (150 - 25 * k) for k in range(13)],
    "tiny_leading_1e-300": [1.0, 1.0, 0.0, 1e-300],
    "tiny_leading_1e-320": [-1.0, 1.0, 1e-320],
    "roots_at_zero": [0.0, 0.0, 0.0, -1.0, 1.0],
    "zero_double_and_imaginary": [0.0, 0.0, 1.0, 0.0, 1.0],
    "imaginary_pair": [1.0, 0.0, 1.0],
    "imaginary_pairs_1_2": [4.0, 0.0, 5.0, 0.0, 1.0],
    "imaginary_pair_1e-10": [1e-20, 0.0, 1.0],
    "denormal_quadratic": [-5e-324, 0.0, 5e-324],
    "denormal_outer": [1e-310, 1.0, 1e-310],  # roots ~ -1e-310 and ~ -1e310 (beyond float64)
    "leading_zeros": [1.0, 1.0, 0.0, 0.0],
    "degree_0": [3.0],
    "degree_1": [2.0, -4.0],
    "close_complex_pair": [1.0, -2.0, 1.0 + 1e-14],
}

# Cases where "auto" must verify every entry (it has an exact fallback).
AUTO_MUST_VERIFY = {
    "double_root", "triple_root", "double_root_and_simple", "quadruple_root",
    "cluster_1e-6", "cluster_1e-10", "cluster_1e-15", "wilkinson_10",
    "imaginary_pair", "imaginary_pairs_1_2", "roots_at_zero", "zero_double_and_imaginary",
    "denormal_quadratic", "degree_1", "leading_zeros", "mignotte_7_10",
}

RESULTS: dict[str, dict[str, str]] = {}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", sorted(CASES))
def test_no_false_claims(name, method):
    coeffs = CASES[name]
    roots = find_roots(coeffs, method=method)
    if method == "unverified":
        assert not roots.verified.any()
        assert int(roots.count.sum()) + roots.n_infinite == len(coeffs) - 1
    else:
        problems = check_roots(coeffs, roots)
        assert not problems, problems
    verified = int(roots.verified.sum())
    RESULTS.setdefault(name, {})[method] = (
        "all verified" if len(roots) and roots.all_verified else f"{verified}/{len(roots)} verified"
    )
    if method == "auto" and name in AUTO_MUST_VERIFY:
        assert roots.all_verified and len(roots) > 0, roots
    out = Path("build/test-results")
    out.mkdir(parents=True, exist_ok=True)
    (out / "stability.json").write_text(json.dumps(RESULTS, indent=2, sort_keys=True))


def test_named_expectations():
    # Exact facts that do not depend on the method.
    r = find_roots(CASES["leading_zeros"])
    assert r.n_infinite == 2 and int(r.count.sum()) == 1
    assert len(find_roots(CASES["degree_0"])) == 0
    r = find_roots(CASES["roots_at_zero"])
    zero = [i for i in range(len(r)) if r.center[i] == 0 and r.radius[i] == 0]
    assert zero and int(r.count[zero[0]]) == 3 and r.verified[zero[0]]
    r = find_roots(CASES["triple_root"])
    assert list(r.count) == [3] and r.verified[0] and r.real[0]
    r = find_roots(CASES["tiny_leading_1e-320"])  # roots 1 and about -1e320 (beyond float64)
    finite = [i for i in range(len(r)) if np.isfinite(r.center[i])]
    assert any(r.verified[i] and abs(r.center[i] - 1) < 1e-12 for i in finite)
    assert int(r.count.sum()) == 2


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    "coeffs, message",
    [
        ([1.0, math.nan, 1.0], "finite"),
        ([1.0, math.inf], "finite"),
        ([-math.inf, 1.0], "finite"),
        ([0.0, 0.0, 0.0], "zero polynomial"),
        ([], "empty"),
        ([1.0] * 70, "maximum"),
    ],
)
def test_bad_input_is_refused(coeffs, message, method):
    with pytest.raises(ValueError, match=message):
        find_roots(coeffs, method=method)


def test_bad_method_is_refused():
    with pytest.raises(ValueError, match="unknown method"):
        find_roots([1.0, 1.0], method="fast")


def test_report(capsys):
    # Printed so the CI log shows which methods fail where (not asserted).
    with capsys.disabled():
        for name in sorted(RESULTS):
            print(f"{name:28s} " + "  ".join(f"{m}: {RESULTS[name].get(m, '-')}" for m in METHODS))
    assert RESULTS, "the stability cases ran"
