"""Property tests (hypothesis) of everything that reads untrusted input or
proves something: the surface expression parser, the angle parser, and
find_roots on arbitrary doubles.

Reproducible in CI: ``derandomize=True`` (examples derived from the test
itself, no random seed) and no example database. Example counts are fixed
per test (see docs/reliability.md) so the file runs in well under a minute.
A hang cannot pass: every call into the C++ core runs under a
faulthandler watchdog that ends the process with a traceback.
"""

from __future__ import annotations

import ast
import faulthandler
import math
from contextlib import contextmanager
from datetime import timedelta

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from argand.core import find_roots
from argand.frames.angles import MAX_ANGLE_LENGTH, parse_angle
from argand.scene import MAX_DEGREE, MAX_LENGTH, MAX_TERMS, ExpressionError, parse_surface
from tests.helpers.truth import check_roots, reproducer

def reproducible(max_examples: int, deadline: timedelta | None) -> settings:
    """Settings for CI: derandomized (the examples follow from the test),
    no example database, a fixed number of examples."""
    return settings(
        max_examples=max_examples,
        deadline=deadline,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow],
    )

# ---------------------------------------------------------------------------
# Strings: arbitrary text, and text made of the grammar's own pieces (which
# reaches far more of the parser than random characters do).
# ---------------------------------------------------------------------------

_SURFACE_PIECES = st.sampled_from(
    ["x", "y", "z", "+", "-", "*", "^", "**", "=", "(", ")", " ", "0", "1", "2", "3", "12", "13", "0.5", ".5",
     "1e3", "1e-3", "1e308", "1e-320", "9" * 40, "x^2", "(x+y+z+1)", "^12", "^99", "xy", "X", "pi", "/", "·", "\t"]
)
_ANGLE_PIECES = st.sampled_from(
    ["pi", "π", "+", "-", "*", "/", "(", ")", " ", "0", "1", "2", "9", "18", "0.35", ".5", "1e308", "1e-400",
     "1e999", "0x", "f", "x", "--", "**", ",", "−"]
)


def _joined(pieces: st.SearchStrategy[str], most: int) -> st.SearchStrategy[str]:
    return st.lists(pieces, max_size=most).map("".join)


def _check_expression_error(error: ExpressionError, text: str) -> None:
    assert isinstance(error.message, str) and error.message
    assert 0 <= error.position <= len(text), (error.position, len(text))
    assert f"at column {error.position + 1}" in str(error)


@reproducible(max_examples=400, deadline=timedelta(seconds=5))
@given(st.one_of(st.text(max_size=200), _joined(_SURFACE_PIECES, 60), st.text(alphabet="xyz+-*^()=0123456789. ", max_size=80)))
@example("(x+y+z+1)^" + "9" * 400)
@example("(" * 100 + "x" + ")" * 100)
@example("1" + "0" * 500 + "*x")
@example("x" * (MAX_LENGTH + 1))
def test_surface_parser_returns_a_polynomial_or_a_positioned_error(text):
    try:
        poly = parse_surface(text)
    except ExpressionError as error:
        _check_expression_error(error, text)
        return
    assert 1 <= poly.degree <= MAX_DEGREE
    assert 0 < len(poly.terms) <= MAX_TERMS
    assert all(sum(m) <= poly.degree and min(m) >= 0 for m in poly.terms)
    _, coefficients = poly.as_arrays()
    assert np.all(np.isfinite(coefficients)) and np.all(coefficients != 0)
    # The expansion written out parses back to the same exact terms.
    assert parse_surface(poly.to_text()).terms == poly.terms


def _polynomial_texts() -> st.SearchStrategy[str]:
    """Well-formed expressions: sums of products of powers, nested."""
    atom = st.one_of(st.sampled_from(["x", "y", "z"]), st.integers(0, 99).map(str),
                     st.sampled_from(["0.5", "1.25", "3e2", "2e-3"]))
    return st.recursive(
        atom,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*"]), inner).map(lambda t: f"{t[0]} {t[1]} {t[2]}"),
            inner.map(lambda s: f"({s})"),
            st.tuples(inner, st.integers(0, 13)).map(lambda t: f"({t[0]})^{t[1]}"),
            inner.map(lambda s: f"-({s})"),
        ),
        max_leaves=12,
    )


@reproducible(max_examples=300, deadline=timedelta(seconds=5))
@given(_polynomial_texts())
def test_well_formed_expressions_parse_or_say_which_limit(text):
    try:
        poly = parse_surface(text)
    except ExpressionError as error:
        _check_expression_error(error, text)
        # A well-formed expression is refused only for a documented reason.
        assert any(
            reason in error.message
            for reason in ("exceeds the maximum", "zero polynomial", "degree 0", "units of coefficient arithmetic")
        ), error.message
        return
    assert 1 <= poly.degree <= MAX_DEGREE


# ---------------------------------------------------------------------------
# Angles
# ---------------------------------------------------------------------------


@reproducible(max_examples=400, deadline=timedelta(seconds=2))
@given(st.one_of(st.text(max_size=300), _joined(_ANGLE_PIECES, 80)))
@example("-" * 5000 + "1")
@example("0x" + "f" * 300)
@example("(" * 150 + "1" + ")" * 150)
@example("1e308*1e308")
def test_angle_text_is_a_finite_float_or_a_positioned_error(text):
    try:
        value = parse_angle(text)
    except ExpressionError as error:
        _check_expression_error(error, text)
        if len(text) > MAX_ANGLE_LENGTH:
            assert "the most is" in error.message
        return
    assert isinstance(value, float) and math.isfinite(value)


_ANY_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
    max_leaves=8,
)


@reproducible(max_examples=300, deadline=timedelta(seconds=2))
@given(_ANY_JSON)
@example(10**400)
@example(-(2**1024))
@example(None)
@example({})
@example([0.1])
@example(True)
def test_angle_of_any_json_value_is_a_finite_float_or_a_value_error(value):
    try:
        result = parse_angle(value)
    except ValueError as error:
        assert str(error)
        return
    assert isinstance(result, float) and math.isfinite(result)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        assert result == float(value)


def _angle_texts() -> st.SearchStrategy[str]:
    atom = st.one_of(st.just("pi"), st.integers(0, 360).map(str), st.sampled_from(["0.35", "1.5", "2e-3", ".25"]))
    return st.recursive(
        atom,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/"]), inner).map(lambda t: f"{t[0]}{t[1]}{t[2]}"),
            inner.map(lambda s: f"({s})"),
            inner.map(lambda s: f"-{s}"),
        ),
        max_leaves=10,
    )


class _IntegersAsFloats(ast.NodeTransformer):
    def visit_Constant(self, node: ast.Constant) -> ast.Constant:
        return ast.Constant(float(node.value)) if isinstance(node.value, int) else node


def _python_value(text: str) -> float | None:
    """Python's own evaluation of the same text in float arithmetic (the
    generated texts hold only numbers, pi, + - * / and parentheses; integer
    literals become floats, as the angle parser reads them); None where
    Python divides by zero or the value is not finite."""
    tree = ast.fix_missing_locations(_IntegersAsFloats().visit(ast.parse(text, mode="eval")))
    try:
        value = eval(compile(tree, "<angle>", "eval"), {"__builtins__": {}}, {"pi": math.pi})  # noqa: S307
    except ZeroDivisionError:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


@reproducible(max_examples=300, deadline=timedelta(seconds=2))
@given(_angle_texts())
def test_angles_equal_pythons_own_arithmetic(text):
    expected = _python_value(text)
    try:
        value = parse_angle(text)
    except ExpressionError as error:
        _check_expression_error(error, text)
        assert expected is None or len(text) > MAX_ANGLE_LENGTH or "overflows" in error.message, (text, error)
        return
    assert expected is not None and value == expected, (text, value, expected)


# ---------------------------------------------------------------------------
# find_roots on arbitrary doubles
# ---------------------------------------------------------------------------

#: Seconds one find_roots call may take before the watchdog ends the run
#: (a call takes milliseconds; this only turns a hang into a failure).
HANG_SECONDS = 60


@contextmanager
def watchdog(seconds: int = HANG_SECONDS):
    faulthandler.dump_traceback_later(seconds, exit=True)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


_ANY_FINITE = st.floats(allow_nan=False, allow_infinity=False)  # subnormals, +-0 and +-max included
_SCALED_INTEGER = st.builds(lambda m, e: math.ldexp(float(m), e), st.integers(-8, 8), st.integers(-1074, 1000))
_COEFFICIENTS = st.lists(st.one_of(_ANY_FINITE, _SCALED_INTEGER), min_size=2, max_size=13).filter(
    lambda c: any(v != 0.0 for v in c)
)


@reproducible(max_examples=150, deadline=None)
@given(_COEFFICIENTS, st.sampled_from(["auto", "smith", "paper"]))
@example([0.0, -1.5452486057561193e271, 1.0], "auto")  # fuzz finding: a verified disc of infinite radius
@example([5e-324, 0.0, 1.0], "smith")
@example([1.0, 0.0, 5e-324], "paper")
@example([1.7976931348623157e308, -1.7976931348623157e308, 1.7976931348623157e308], "auto")
def test_find_roots_makes_no_false_claim_on_any_doubles(coeffs, method):
    with watchdog():
        roots = find_roots(coeffs, method=method)
    problems = check_roots(coeffs, roots)
    assert not problems, f"{reproducer(coeffs, method)}: {problems}"


_SEED = st.one_of(st.just(0j), st.builds(complex, _ANY_FINITE, _ANY_FINITE), st.builds(complex, _SCALED_INTEGER, _SCALED_INTEGER))


@st.composite
def _seeded(draw):
    """Coefficients and one seed per root: arbitrary, all equal or all zero
    (the fuzzer's hangs were all-zero seeds)."""
    coeffs = draw(_COEFFICIENTS)
    n = len(coeffs) - 1
    kind = draw(st.sampled_from(["any", "equal", "zero"]))
    if kind == "any":
        seeds = draw(st.lists(_SEED, min_size=n, max_size=n))
    else:
        seeds = [draw(_SEED) if kind == "equal" else 0j] * n
    return coeffs, seeds


@reproducible(max_examples=100, deadline=None)
@given(_seeded(), st.sampled_from(["auto", "smith", "paper"]))
def test_seeds_change_nothing_that_is_proven(case, method):
    coeffs, seeds = case
    with watchdog():
        roots = find_roots(coeffs, method=method, initial=np.array(seeds, dtype=np.complex128))
    problems = check_roots(coeffs, roots)
    assert not problems, f"{reproducer(coeffs, method)} seeded with {seeds}: {problems}"


@reproducible(max_examples=60, deadline=None)
@given(_COEFFICIENTS)
def test_unverified_method_claims_nothing_and_accounts_for_every_root(coeffs):
    with watchdog():
        roots = find_roots(coeffs, method="unverified")
    assert not roots.verified.any() and not roots.real.any()
    assert int(roots.count.sum()) + roots.n_infinite == len(coeffs) - 1


@pytest.mark.parametrize("bad", [[float("nan"), 1.0], [1.0, float("inf")], [0.0, 0.0, 0.0], []])
def test_find_roots_refuses_what_has_no_roots_to_find(bad):
    with pytest.raises(ValueError):
        find_roots(bad)
