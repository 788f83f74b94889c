"""The surface expression parser: exact expansion checked against an
independent evaluation, positioned errors, and no crash on garbage."""

from __future__ import annotations

import ast
import operator
import pickle
import random
from fractions import Fraction

import numpy as np
import pytest

from argand.scene import MAX_DEGREE, ExpressionError, SurfacePolynomial, parse_surface

# ---------------------------------------------------------------------------
# An independent reference: Python's own parser (ast, never eval) walked with
# exact Fractions. It shares nothing with argand.scene.expression.
# ---------------------------------------------------------------------------

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Pow: operator.pow}


def reference_value(text: str, x: Fraction, y: Fraction, z: Fraction) -> Fraction:
    """The exact value of the expression at (x, y, z), read by Python's parser
    ("^" written "**", "A = B" as "(A) - (B)")."""
    source = text.replace("^", "**")
    if "=" in source:
        left, right = source.split("=")
        source = f"({left}) - ({right})"
    variables = {"x": x, "y": y, "z": z}

    def walk(node: ast.AST) -> Fraction:
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value = walk(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            segment = ast.get_source_segment(source, node)
            return Fraction(segment)  # exact decimal, as written
        if isinstance(node, ast.Name):
            return variables[node.id]
        raise AssertionError(f"the reference cannot read {ast.dump(node)}")

    return walk(ast.parse(source, mode="eval"))


def exact_value(p: SurfacePolynomial, x: Fraction, y: Fraction, z: Fraction) -> Fraction:
    return sum((c * x**i * y**j * z**k for (i, j, k), c in p.terms.items()), Fraction(0))


EXPRESSIONS = [
    # the paper's Table 1
    "x^2*z + y^2",
    "x^2*z - x*y + y^2*z",
    "x^4 + y^4 + z^4 - 1000",
    "4*(x^4 + (y^2 + z^2)^2) + 17*x^2*(y^2 + z^2) - 20*(x^2 + y^2 + z^2) + 17",
    "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2",
    # more
    "(x + y + z - 1)^4 - 0.25",
    "(x - 1)*(x + 1)*(y - 2.5)*(z + .5) + 1e-3*x",
    "-x^2 - -y^2 + -(z - 3)^3",
    "(2*x - 3*y)^3*(x + z)^2 - 7",
    "x**2 + y**2 = z**2 + 1.5",
    "((x))^2 * ((y + (z)))^3 - x^0*y",
    "0.1*x + 0.2*y + 0.3*z - 0.6",
    "(x^2 + y^2 + z^2 + 3.24 - 0.64)^2 - 4*3.24*(x^2 + y^2)",
    "x*y*z*(x + y + z)^9 - 1",
    "(1.5*x - 2.25)^12 + y",
    "3*x^3 - 3*x^3 + y*z",
    "+x - y",
    "x^2*1e2 - 2.5e-1*y + 1E1*z",
]


@pytest.mark.parametrize("text", EXPRESSIONS)
def test_expansion_matches_the_reference_exactly(text):
    p = parse_surface(text)
    rng = random.Random(text)
    for _ in range(25):
        point = [Fraction(rng.randint(-60, 60), rng.randint(1, 12)) for _ in range(3)]
        assert exact_value(p, *point) == reference_value(text, *point)


@pytest.mark.parametrize("text", EXPRESSIONS)
def test_numeric_evaluation_at_random_points(text):
    p = parse_surface(text)
    exponents, coefficients = p.as_arrays()
    rng = np.random.default_rng(7)
    for _ in range(10):
        # Real points: against the exact reference, rounded once.
        real = [float(v) for v in rng.uniform(-2, 2, 3)]
        want = float(reference_value(text, *map(Fraction, real)))
        scale = float(np.sum(np.abs(coefficients) * np.prod(np.abs(real) ** exponents, axis=1)))
        assert abs(p(*real) - want) <= 1e-12 * scale
        # Complex points: against numpy on the arrays.
        point = rng.uniform(-2, 2, 3) + 1j * rng.uniform(-2, 2, 3)
        direct = np.sum(coefficients * np.prod(point[None, :] ** exponents, axis=1))
        scale = float(np.sum(np.abs(coefficients) * np.prod(np.abs(point) ** exponents, axis=1)))
        assert abs(p(*point) - direct) <= 1e-12 * scale


def test_evaluation_broadcasts_over_arrays():
    p = parse_surface("x^2 + y^2 + z^2 - 1")
    x = np.linspace(-1, 1, 5)
    assert np.allclose(p(x, 0.0, 0.0), x**2 - 1)


@pytest.mark.parametrize(
    "text, terms, degree",
    [
        ("x^2*z + y^2", {(2, 0, 1): 1, (0, 2, 0): 1}, 3),
        ("x^4 + y^4 + z^4 - 1000", {(4, 0, 0): 1, (0, 4, 0): 1, (0, 0, 4): 1, (0, 0, 0): -1000}, 4),
        ("(x + y)^2", {(2, 0, 0): 1, (1, 1, 0): 2, (0, 2, 0): 1}, 2),
        ("0.1*x", {(1, 0, 0): Fraction(1, 10)}, 1),
        (".5*x - 2e-3*y + 1.*z", {(1, 0, 0): Fraction(1, 2), (0, 1, 0): Fraction(-2, 1000), (0, 0, 1): 1}, 1),
        ("0.1*x + 0.2*x - 0.3*x + y", {(0, 1, 0): 1}, 1),  # exact: 0.1 + 0.2 - 0.3 is 0
        ("-x^2", {(2, 0, 0): -1}, 2),
        ("x**3 = y", {(3, 0, 0): 1, (0, 1, 0): -1}, 3),
        ("x^2 + y^2 = 0", {(2, 0, 0): 1, (0, 2, 0): 1}, 2),
        ("(x - 1)*(x + 1) - y*z", {(2, 0, 0): 1, (0, 0, 0): -1, (0, 1, 1): -1}, 2),
        ("x^0 + z", {(0, 0, 0): 1, (0, 0, 1): 1}, 1),
        ("2^3*x", {(1, 0, 0): 8}, 1),
        ("x^12", {(12, 0, 0): 1}, 12),
        ("(x*y*z)^4", {(4, 4, 4): 1}, 12),
        ("x^7*y^5 - 1", {(7, 5, 0): 1, (0, 0, 0): -1}, 12),
        ("x^13 - x^13 + y", None, None),  # refused: x^13 is refused before it cancels
    ],
)
def test_exact_terms_and_degree(text, terms, degree):
    if terms is None:
        with pytest.raises(ExpressionError, match="degree 13 exceeds"):
            parse_surface(text)
        return
    p = parse_surface(text)
    assert p.terms == {m: Fraction(c) for m, c in terms.items()}
    assert all(isinstance(c, Fraction) and c != 0 for c in p.terms.values())
    assert p.degree == degree
    assert p.text == text


def test_decimals_are_exact():
    assert parse_surface("0.1*x").terms == {(1, 0, 0): Fraction(1, 10)}
    assert parse_surface("x*1.000000000000000000001").terms[(1, 0, 0)] == Fraction(10**21 + 1, 10**21)
    assert parse_surface("x - 1e-300").terms[(0, 0, 0)] == -Fraction(1, 10**300)


def test_as_arrays():
    exponents, coefficients = parse_surface("x^2*z + 3*y^2 - 0.5").as_arrays()
    assert exponents.dtype == np.int32 and exponents.shape == (3, 3)
    assert coefficients.dtype == np.float64 and coefficients.shape == (3,)
    assert dict(zip(map(tuple, exponents.tolist()), coefficients.tolist())) == {(2, 0, 1): 1.0, (0, 2, 0): 3.0, (0, 0, 0): -0.5}


@pytest.mark.parametrize("text", EXPRESSIONS)
def test_to_text_parses_back_to_the_same_terms(text):
    p = parse_surface(text)
    assert parse_surface(p.to_text()).terms == p.terms


def test_to_text_reads_well():
    assert parse_surface("(x + y)^2 - 0.25").to_text() == "x^2 + 2*x*y + y^2 - 0.25"
    assert parse_surface("-z + 1.5*x^3").to_text() == "1.5*x^3 - z"


@pytest.mark.parametrize(
    "text, message, position",
    [
        # unknown names
        ("x^2 + w", "unknown name 'w'", 6),
        ("sin(x)", "unknown name 'sin'", 0),
        ("X + y", "lowercase", 0),
        ("pi*x", "unknown name 'pi'", 0),
        # parentheses
        ("(x + y", "unmatched '('", 0),
        ("x*(y + (z - 1)", "unmatched '('", 2),
        ("x + y)", "unmatched ')'", 5),
        ("x^2 + )", "unexpected ')'", 6),
        ("()", "empty parentheses", 1),
        ("(", "unmatched '('", 0),
        # empty, trailing and doubled operators
        ("", "the expression is empty", 0),
        ("   ", "the expression is empty", 3),
        ("x +", "ends with '+'", 2),
        ("x*y -", "ends with '-'", 4),
        ("x + * y", "two operators in a row: '+' then '*'", 4),
        ("x - - - y", "two operators in a row: '-' then '-'", 6),
        ("x ^ ^ 2", "non-negative integer", 4),
        ("*x", "'*' needs an operand before it", 0),
        ("= 0", "'=' needs an operand before it", 0),
        ("x =", "'=' has nothing after it", 2),
        ("x = y = z", "only one '='", 6),
        ("(x = y)", "not allowed inside parentheses", 3),
        # implicit multiplication
        ("2x", "missing operator", 1),
        ("x y", "missing operator", 2),
        ("(x + 1)(x - 1)", "missing operator", 7),
        ("3(x)", "missing operator", 1),
        ("xy", "missing operator between 'x' and 'y'", 1),
        ("x2", "missing operator between 'x' and '2'", 1),
        ("x^2 y", "missing operator", 4),
        ("1.5.5*x", "missing operator", 3),
        # exponents
        ("x^1.5", "non-negative integer", 2),
        ("x^-1", "non-negative integer", 2),
        ("x**-1", "non-negative integer", 3),
        ("x^y", "non-negative integer", 2),
        ("x^(2)", "non-negative integer", 2),
        ("x^1e1", "non-negative integer", 2),
        ("x^", "missing exponent", 1),
        ("x^2^3", "power of a power needs parentheses", 3),
        # degree
        ("x^40", "degree 40 exceeds the maximum 12", 2),
        ("x^13", "degree 13 exceeds the maximum 12", 2),
        ("(x+y)^1000000", "degree 1000000 exceeds the maximum 12", 6),
        ("(x*y)^99999999999999999999999999999999999", "exceeds the maximum 12", 6),
        ("2^13*x", "the exponent 13 exceeds the maximum 12", 2),
        ("x^7*y^7", "degree 14 exceeds the maximum 12", 3),
        ("(x^6 + 1)*(y^6 + 1)*z", "degree 13 exceeds the maximum 12", 19),
        # numbers out of double range
        ("1e400*x", "out of double-precision range", 0),
        ("x + 1e-400", "out of double-precision range", 4),
        ("x + 9e99999999999", "out of double-precision range", 4),
        ("x + 1e-99999999999", "out of double-precision range", 4),
        ("(1e300*x)^2", "coefficient of x^2 is outside double-precision range", 0),
        ("x + " + "9" * 500, "the number has 500 characters", 4),
        # nothing to render
        ("3", "the surface has degree 0 (it is a constant): nothing to render", 0),
        ("x - x + 1", "the surface has degree 0 (it is a constant): nothing to render", 0),
        ("x - x", "zero polynomial", 0),
        ("0", "zero polynomial", 0),
        ("x = x", "zero polynomial", 0),
        # characters
        ("x $ y", "unexpected character '$'", 2),
        ("x·y", "write '*'", 1),
        ("x²", "write powers with '^'", 1),
        ("x/2", "division is not supported", 1),
        ("x − y", "ASCII minus", 2),
        # nesting
        ("(" * 70 + "x" + ")" * 70, "nesting deeper than 64", 64),
        ("-(" * 40 + "x" + ")" * 40, "nesting deeper than 64", 64),
    ],
)
def test_errors_say_what_and_where(text, message, position):
    with pytest.raises(ExpressionError) as info:
        parse_surface(text)
    error = info.value
    assert message in error.message
    assert error.position == position
    assert error.text == text
    # str(): message, "at column N" (1-based), the text, a caret under it.
    first, shown, caret = str(error).split("\n")
    assert first == f"{error.message} at column {position + 1}"
    assert caret.index("^") - 2 == position or len(text) > 120


def test_caret_example_from_the_docs():
    with pytest.raises(ExpressionError) as info:
        parse_surface("x^2 + )")
    assert str(info.value) == "unexpected ')' at column 7\n  x^2 + )\n        ^"


def test_caret_stays_under_the_mistake_in_long_text():
    text = "x + " * 100 + "w"
    with pytest.raises(ExpressionError) as info:
        parse_surface(text)
    _, shown, caret = str(info.value).split("\n")
    assert shown[caret.index("^")] == "w" and len(shown) <= 122


def test_error_is_a_value_error_and_pickles():
    with pytest.raises(ValueError):
        parse_surface("x +")
    error = ExpressionError("unexpected ')'", 6, "x^2 + )")
    copy = pickle.loads(pickle.dumps(error))
    assert (copy.message, copy.position, copy.text, str(copy)) == (error.message, 6, error.text, str(error))


def test_not_text():
    with pytest.raises(ExpressionError, match="must be text"):
        parse_surface(3)  # type: ignore[arg-type]


def test_over_long_text_is_refused():
    with pytest.raises(ExpressionError, match="characters; the most is"):
        parse_surface("x" + " + x" * 10_000)


def test_huge_exponents_are_refused_before_expanding():
    # Expanding (x + y + z + 1)^1000000 would never finish: it must be refused
    # from the exponent alone.
    for text in ["(x + y + z + 1)^1000000", "(x+y)^" + "9" * 100, "x*(y + 1)^20"]:
        with pytest.raises(ExpressionError, match="exceeds the maximum 12"):
            parse_surface(text)


def test_huge_numbers_are_refused_before_they_are_built():
    # 10**(10**11) would exhaust memory: the exponent alone refuses it.
    for text in ["1e99999999999*x", "x*1e-99999999999", "1" + "0" * 380 + "*x"]:
        with pytest.raises(ExpressionError, match="range|characters"):
            parse_surface(text)


def test_expansion_work_is_bounded():
    # Each term is a legal degree-12 product; forty of them would take
    # seconds to expand, so the parser stops once MAX_WORK is spent.
    assert parse_surface("(x + y + z + 1)^6*(x - y + z - 1)^6").degree == 12
    with pytest.raises(ExpressionError, match="units of coefficient arithmetic: simplify"):
        parse_surface(" + ".join(["(x + y + z + 1)^6*(x - y + z - 1)^6"] * 40))


def test_long_coefficients_cost_more_work():
    # A 3 KB text: two sextics of 380-digit coefficients. Counting each
    # coefficient product as one unit let it through, and it took 11 s of
    # CPU (the gcds of 16,000-bit fractions); weighted by length it is refused
    # after a few hundred products.
    d = "1." + "3" * 380
    sextic = f"({d}*x + {d}*y + {d}*z + {d})^6"
    with pytest.raises(ExpressionError, match="units of coefficient arithmetic") as caught:
        parse_surface(f"{sextic}*{sextic}")
    assert caught.value.position > 0
    # Short decimals still expand to the full degree.
    assert parse_surface("(1.5*x + 2.25*y - 0.125*z + 3)^12").degree == 12


def test_the_limits_are_named_and_consistent():
    from argand.scene import MAX_LENGTH, MAX_NUMBER_LENGTH, MAX_TERMS, MAX_WORK

    assert MAX_TERMS == 455 == len(parse_surface("(x+y+z+1)^12").terms)
    assert MAX_NUMBER_LENGTH < MAX_LENGTH and MAX_WORK > 0


def test_long_product_of_big_numbers_is_refused():
    with pytest.raises(ExpressionError, match="grows beyond double-precision range"):
        parse_surface("*".join(["1e300"] * 20) + "*x")


def test_fuzz_raises_only_expression_errors():
    rng = random.Random(11)
    alphabet = "xyzw0123456789.+-*^() =e"
    valid = 0
    for _ in range(5000):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 24)))
        try:
            p = parse_surface(text)
        except ExpressionError as error:
            assert 0 <= error.position <= len(text)
            str(error)
            continue
        assert 1 <= p.degree <= MAX_DEGREE
        assert all(c != 0 for c in p.terms.values())
        valid += 1
    assert valid > 20  # random strings do include valid surfaces


def test_fuzz_of_token_sequences():
    """Random sequences of whole tokens reach deeper into the grammar than
    random characters do."""
    rng = random.Random(5)
    tokens = ["x", "y", "z", "2", "0.5", "1e3", "1e400", "+", "-", "*", "^", "**", "(", ")", "=", "12", "99", " "]
    valid = 0
    for _ in range(3000):
        text = "".join(rng.choice(tokens) for _ in range(rng.randint(1, 16)))
        try:
            p = parse_surface(text)
        except ExpressionError as error:
            assert 0 <= error.position <= len(text)
            continue
        assert 1 <= p.degree <= MAX_DEGREE
        valid += 1
    assert valid > 50
