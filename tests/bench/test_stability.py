"""The stability report's classes (docs/benchmarks.md): each class is checked
on cases whose answer is known from the mathematics, not from the code."""

from __future__ import annotations

from argand.bench.stability import (CASES, CLASSES, FAMILIES, accurate, classify_argand, classify_flint,
                                    classify_mpmath, classify_mpsolve, classify_numpy, markdown, true_roots)


def test_every_case_is_in_one_family():
    names = [n for family in FAMILIES.values() for n in family]
    assert len(names) == len(set(names)) == len(CASES)


def test_accurate_matches_roots_with_multiplicity():
    truth = true_roots([2.0, -3.0, 1.0])  # (t - 1)(t - 2)
    assert accurate([1.0, 2.0], truth)
    assert accurate([2.0 + 1e-9, 1.0 - 1e-9], truth)
    assert not accurate([1.0, 1.0], truth)  # one root twice, the other missed
    assert not accurate([1.0, 2.0 + 1e-3], truth)
    assert not accurate([1.0], truth)
    assert not accurate([1.0, float("nan")], truth)
    double = true_roots([1.0, -2.0, 1.0])  # (t - 1)^2
    assert accurate([1.0, 1.0], double) and not accurate([1.0], double)


def test_argand_auto_proves_what_it_must_and_never_claims_wrong():
    from tests.helpers import truth  # the project's independent checker, which the classifier uses

    for name in ("double_root (t-1)^2", "wilkinson 10", "cluster 1e-15", "degree 0 [3]"):
        assert classify_argand(CASES[name], "auto", truth) == "proven", name
    for name, coeffs in CASES.items():
        assert classify_argand(coeffs, "auto", truth) != "wrong", name
    # The unverified method proves nothing; where its answer is accurate it is "correct, unproven".
    assert classify_argand(CASES["degree 1 [2,-4]"], "unverified", truth) == "correct, unproven"


def test_numpy_is_wrong_on_wilkinson_20_and_right_on_a_simple_quadratic():
    # Wilkinson's polynomial of degree 20: eigenvalues of the companion matrix
    # lose about 1e-3 relative accuracy (far above the 1e-6 tolerance).
    assert classify_numpy(CASES["wilkinson 20"]) == "wrong"
    assert classify_numpy(CASES["imaginary t^2+1"]) == "correct, unproven"


def test_python_flint_flags_a_double_root_and_proves_simple_ones():
    assert classify_flint(CASES["double_root (t-1)^2"]) == "flagged"  # it cannot isolate a multiple root
    assert classify_flint(CASES["imaginary t^2+1"]) == "proven"


def test_mpmath_answers_without_proof():
    assert classify_mpmath(CASES["degree 1 [2,-4]"]) == "correct, unproven"


def test_mpsolve_discs_are_judged_by_what_they_hold():
    t2 = CASES["imaginary t^2+1"]  # roots +-i
    assert classify_mpsolve(([1j, -1j], [1e-10, 1e-10]), t2) == "proven"
    assert classify_mpsolve(([1j, -1j + 0.5], [1e-10, 1e-10]), t2) == "wrong"  # a disc holding no root
    assert classify_mpsolve(([0.0, 0.0], [2.0, 2.0]), t2) == "flagged"  # overlapping discs, both roots inside
    assert classify_mpsolve(([1j], [1e-10]), t2) == "wrong"  # a root missing
    assert classify_mpsolve(None, t2) == "flagged"  # it failed


def test_markdown_counts_each_class():
    report = {"table": {"f": {"a": {"auto": "proven", "numpy": "wrong"}, "b": {"auto": "proven", "numpy": "flagged"}}},
              "tolerance": 1e-6, "mpsolve": "unavailable"}
    text = markdown(report)
    assert "| auto | 2 | 0 | 0 | 0 |" in text
    assert "| numpy | 0 | 0 | 1 | 1 |" in text
    assert set(CLASSES) == {"proven", "correct, unproven", "flagged", "wrong"}


def test_picture_marks_differences(tmp_path):
    from argand.bench.stability import picture

    shares = picture(tmp_path / "p.png", size=32)
    assert set(shares) == {"steiner", "sextic x^6+y^6+z^6"}
    assert all(0.0 <= s["differing_share"] <= 1.0 for s in shares.values())
    assert (tmp_path / "p.png").read_bytes().startswith(b"\x89PNG")
