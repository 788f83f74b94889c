"""The surface expression parser: exact expansion, positioned errors, no crash on garbage."""

from __future__ import annotations

import random
from fractions import Fraction

import pytest

from argand.scene import MAX_DEGREE, ExpressionError, parse_surface


@pytest.mark.parametrize(
    "text, terms, degree",
    [
        ("x^2*z + y^2", {(2, 0, 1): 1, (0, 2, 0): 1}, 3),
        ("x^4 + y^4 + z^4 - 1000", {(4, 0, 0): 1, (0, 4, 0): 1, (0, 0, 4): 1, (0, 0, 0): -1000}, 4),
        ("(x + y)^2", {(2, 0, 0): 1, (1, 1, 0): 2, (0, 2, 0): 1}, 2),
        ("0.1*x", {(1, 0, 0): Fraction(1, 10)}, 1),
        (".5*x - 2e-3*y", {(1, 0, 0): Fraction(1, 2), (0, 1, 0): Fraction(-2, 1000)}, 1),
        ("-x^2", {(2, 0, 0): -1}, 2),
        ("x**3 = y", {(3, 0, 0): 1, (0, 1, 0): -1}, 3),
        ("(x - 1)*(x + 1) - y*z", {(2, 0, 0): 1, (0, 0, 0): -1, (0, 1, 1): -1}, 2),
        ("x^0 + z", {(0, 0, 0): 1, (0, 0, 1): 1}, 1),
    ],
)
def test_exact_expansion(text, terms, degree):
    p = parse_surface(text)
    assert p.terms == {m: Fraction(c) for m, c in terms.items()}
    assert p.degree == degree


def test_mitchell_matches_direct_evaluation():
    text = "4*(x^4 + (y^2 + z^2)^2) + 17*x^2*(y^2 + z^2) - 20*(x^2 + y^2 + z^2) + 17"
    p = parse_surface(text)

    def direct(x, y, z):  # the same formula written by hand
        return 4 * (x**4 + (y**2 + z**2) ** 2) + 17 * x**2 * (y**2 + z**2) - 20 * (x**2 + y**2 + z**2) + 17

    rng = random.Random(3)
    for _ in range(50):
        x, y, z = (Fraction(rng.randint(-40, 40), rng.randint(1, 9)) for _ in range(3))
        exact = sum(c * x**i * y**j * z**k for (i, j, k), c in p.terms.items())
        assert exact == direct(x, y, z)
    assert p.degree == 4


def test_as_arrays():
    exps, coeffs = parse_surface("x^2*z + 3*y^2").as_arrays()
    assert exps.shape == (2, 3) and sorted(coeffs.tolist()) == [1.0, 3.0]


@pytest.mark.parametrize(
    "text, message, position",
    [
        ("x^2 + w", "unknown name 'w'", 6),
        ("sin(x)", "unknown name 'sin'", 0),
        ("(x + y", "unmatched '('", 0),
        ("x + y)", "unmatched ')'", 5),
        ("", "empty", 0),
        ("x +", "ends too early", 3),
        ("x + * y", "two operators", 4),
        ("2x", "missing operator", 1),
        ("x y", "missing operator", 2),
        ("x^1.5", "non-negative integer", 2),
        ("x^-1", "non-negative integer", 2),
        ("x^40", "degree 40 exceeds the maximum 12", 2),
        ("(x+y)^1000000", "exceeds the maximum", 6),
        ("x^7*y^7", "degree 14 exceeds", 0),
        ("3", "degree 0", 0),
        ("x - x + 1", "degree 0", 0),
        ("x - x", "zero polynomial", 0),
        ("x $ y", "unexpected character '$'", 2),
        ("()", "empty parentheses", 1),
    ],
)
def test_errors_point_at_the_mistake(text, message, position):
    with pytest.raises(ExpressionError) as info:
        parse_surface(text)
    assert message in info.value.message
    assert info.value.position == position
    # The caret line sits under the reported column.
    lines = str(info.value).splitlines()
    assert lines[-1].index("^") - 2 == position


def test_fuzz_only_expression_errors():
    rng = random.Random(11)
    alphabet = "xyzw0123456789.+-*^() =e"
    ok = 0
    for _ in range(3000):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 14)))
        try:
            p = parse_surface(text)
        except ExpressionError:
            continue
        assert 1 <= p.degree <= MAX_DEGREE
        ok += 1
    assert ok > 0  # some random strings are valid surfaces
