"""Surface expressions: a safe parser (no eval) into an exact sparse polynomial.

Grammar (spaces are ignored)::

    equation := expr [ "=" expr ]              A = B means A - B = 0
    expr     := term { ("+" | "-") term }
    term     := signed { "*" signed }
    signed   := [ "+" | "-" ] power            one sign; "-x^2" is -(x^2)
    power    := atom [ ("^" | "**") integer ]  integer: digits only, at most 12
    atom     := number | "x" | "y" | "z" | "(" expr ")"
    number   := decimal such as 12, 1.5, .5, 1e-3

Numbers are taken at their exact rational value (``0.1`` is exactly 1/10)
and the polynomial is expanded once, so every coefficient is exact; it is
rounded to double precision only in :meth:`SurfacePolynomial.as_arrays`.

Guarantees: :func:`parse_surface` either returns a polynomial of total
degree 1..MAX_DEGREE whose coefficients are all finite, non-zero doubles,
or raises :class:`ExpressionError` (never another exception) with the
0-based position of the first mistake met reading left to right. Work is
bounded before it is done: an exponent above MAX_DEGREE, an over-long text,
deep nesting, or a number out of double range is refused before any
expansion, and the expansion as a whole stops once its coefficient
arithmetic exceeds MAX_WORK units (a unit is one product or sum of small
coefficients; long ones cost more, see :func:`_cost`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from argand.core import _core

#: Largest total degree of a surface: the renderer's limit (defined in C++,
#: where plan_frame enforces it); it also bounds the work of expansion.
MAX_DEGREE: int = _core.MAX_SURFACE_DEGREE
#: Longest expression text accepted (a fully expanded degree-12 polynomial
#: has at most 455 terms and fits easily).
MAX_LENGTH = 20_000
#: Deepest nesting of parentheses and signs accepted.
MAX_NESTING = 64
#: Longest number literal accepted, in characters.
MAX_NUMBER_LENGTH = 400
#: Largest decimal exponent written in a number: 1e999999 is refused before
#: 10**999999 is built (a number outside double range is refused anyway,
#: once its exact value is known).
MAX_DECIMAL_EXPONENT = 700
#: Most work units one expansion may take: a unit is one product or sum of
#: two coefficients of up to about 300 bits, and longer coefficients cost
#: more units (about bits_a * bits_b / 100,000). A unit takes 5-10 us, so
#: the budget is about 0.2 s of CPU whatever the text, and a scene of many
#: objects stays within seconds. (x+y+z+1)^12 takes 5,463 units, a product
#: of two full sextics 8,070, Barth's sextic 89, the presets at most 49.
MAX_WORK = 20_000
#: Most distinct terms a surface can have: every monomial x^i y^j z^k of
#: total degree <= MAX_DEGREE (455 for degree 12). Not a separate check: the
#: degree bound implies it.
MAX_TERMS = (MAX_DEGREE + 1) * (MAX_DEGREE + 2) * (MAX_DEGREE + 3) // 6
#: Largest magnitude of an intermediate coefficient, as a power of two: a
#: coefficient beyond 2^+-MAX_COEFFICIENT_BITS can never round to a finite
#: non-zero double, so the expansion is stopped there.
MAX_COEFFICIENT_BITS = 4000

Monomial = tuple[int, int, int]
Poly = dict[Monomial, Fraction]

_VARIABLES: dict[str, Monomial] = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
_DIGITS = "0123456789"
_LETTERS = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_"
# Characters people paste from papers, with what to write instead.
_HINTS = {
    "·": "write '*' for multiplication",
    "⋅": "write '*' for multiplication",
    "×": "write '*' for multiplication",
    "−": "write '-' (ASCII minus)",
    "–": "write '-' (ASCII minus)",
    "/": "division is not supported: write 0.5*x rather than x/2",
    "⁰": "write powers with '^', e.g. x^2",
    "¹": "write powers with '^', e.g. x^2",
    "²": "write powers with '^', e.g. x^2",
    "³": "write powers with '^', e.g. x^2",
    "⁴": "write powers with '^', e.g. x^2",
}


class ExpressionError(ValueError):
    """A mistake in a surface expression, at a 0-based character position.

    ``str()`` shows the message, the 1-based column, the text and a caret
    under the position::

        unexpected ')' at column 7
          x^2 + )
                ^
    """

    def __init__(self, message: str, position: int, text: str) -> None:
        self.message = message
        self.position = position
        self.text = text
        super().__init__(message, position, text)

    def __str__(self) -> str:
        # Tabs and newlines would move the caret: show them as spaces.
        shown = "".join(" " if ch in "\t\r\n\v\f" else ch for ch in self.text)
        if len(shown) > 120:  # keep a window around the position
            start = max(0, min(self.position - 60, len(shown) - 120))
            shown, caret = shown[start : start + 120], self.position - start
        else:
            caret = self.position
        return f"{self.message} at column {self.position + 1}\n  {shown}\n  {' ' * caret}^"


@dataclass(frozen=True)
class _Token:
    kind: str  # "num", "var", "op" (+ - * ^ =), "(", ")", "end"
    text: str
    position: int
    value: Fraction | None = None


class _Lexer:
    """Reads tokens on demand, so the first mistake reported is the leftmost."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.i = 0

    def error(self, message: str, position: int) -> ExpressionError:
        return ExpressionError(message, position, self.text)

    def next(self) -> _Token:
        text, n = self.text, len(self.text)
        while self.i < n and text[self.i].isspace():
            self.i += 1
        i = self.i
        if i >= n:
            return _Token("end", "", n)
        ch = text[i]
        if ch in _DIGITS or (ch == "." and i + 1 < n and text[i + 1] in _DIGITS):
            return self._number(i)
        if ch in _LETTERS:
            return self._name(i)
        if text.startswith("**", i):
            self.i = i + 2
            return _Token("op", "^", i)
        if ch in "+-*^=()":
            self.i = i + 1
            return _Token("op" if ch in "+-*^=" else ch, ch, i)
        hint = _HINTS.get(ch)
        raise self.error(f"unexpected character {ch!r}" + (f": {hint}" if hint else ""), i)

    def _number(self, i: int) -> _Token:
        literal = scan_number(self.text, i)
        self.i = i + len(literal)
        value = Fraction(literal)
        _check_double_range(value, lambda: self.error(f"the number {literal} is out of double-precision range", i))
        return _Token("num", literal, i, value)

    def _name(self, i: int) -> _Token:
        text, n = self.text, len(self.text)
        j = i
        while j < n and (text[j] in _LETTERS or text[j] in _DIGITS):
            j += 1
        name = text[i:j]
        self.i = j
        if name in _VARIABLES:
            return _Token("var", name, i)
        # "xy", "x2", "xyz": implicit multiplication, not an unknown name.
        if name[0] in _VARIABLES and all(ch in _VARIABLES or ch in _DIGITS for ch in name):
            a, b = name[0], name[1]
            suggestion = f"{a}*{b}" if b in _VARIABLES else f"{a}^{b} or {a}*{b}"
            raise self.error(f"missing operator between {a!r} and {b!r} (write {suggestion})", i + 1)
        if name.lower() in _VARIABLES:
            raise self.error(f"unknown name {name!r} (the variables are lowercase: x, y and z)", i)
        if len(name) == 1:
            raise self.error(f"unknown name {name!r} (the variables are x, y and z)", i)
        raise self.error(f"unknown name {name!r} (functions and constants are not supported; the variables are x, y and z)", i)


def scan_number(text: str, i: int) -> str:
    """The decimal literal starting at text[i] (digits, an optional fraction
    and an optional exponent: 12, 1.5, .5, 1e-3), checked before any value is
    built from it: at most MAX_NUMBER_LENGTH characters and a decimal exponent
    within double range (so no huge power of ten is ever made). Raises
    ExpressionError at i otherwise. Shared with the angle parser
    (:mod:`argand.frames.angles`)."""
    n = len(text)
    j = i
    while j < n and text[j] in _DIGITS:
        j += 1
    if j < n and text[j] == ".":
        j += 1
        while j < n and text[j] in _DIGITS:
            j += 1
    exponent_digits = ""
    if j < n and text[j] in "eE":
        k = j + 1
        if k < n and text[k] in "+-":
            k += 1
        if k < n and text[k] in _DIGITS:
            start = k
            while k < n and text[k] in _DIGITS:
                k += 1
            exponent_digits = text[start:k]
            j = k
    literal = text[i:j]
    if len(literal) > MAX_NUMBER_LENGTH:
        raise ExpressionError(f"the number has {len(literal)} characters; the most is {MAX_NUMBER_LENGTH}", i, text)
    # A decimal exponent beyond double range is refused before 10**e is built.
    if len(exponent_digits.lstrip("0")) > 3 or (exponent_digits and int(exponent_digits) > MAX_DECIMAL_EXPONENT):
        raise ExpressionError(f"the number {literal} is out of double-precision range", i, text)
    return literal


# ---------------------------------------------------------------------------
# Exact sparse polynomial arithmetic
# ---------------------------------------------------------------------------

_ONE: Poly = {(0, 0, 0): Fraction(1)}


def _add(a: Poly, b: Poly, sign: int) -> Poly:
    out = dict(a)
    for m, c in b.items():
        v = out.get(m, 0) + sign * c
        if v:
            out[m] = v
        else:
            out.pop(m, None)
    return out


def _mul(a: Poly, b: Poly) -> Poly:
    out: Poly = {}
    for (i1, j1, k1), c1 in a.items():
        for (i2, j2, k2), c2 in b.items():
            m = (i1 + i2, j1 + j2, k1 + k2)
            v = out.get(m, 0) + c1 * c2
            if v:
                out[m] = v
            else:
                out.pop(m, None)
    return out


def _degree(p: Poly) -> int:
    return max((sum(m) for m in p), default=0)


def _too_wide(p: Poly) -> bool:
    return any(abs(c.numerator.bit_length() - c.denominator.bit_length()) > MAX_COEFFICIENT_BITS for c in p.values())


def _bits(p: Poly) -> int:
    """The longest numerator or denominator of p's coefficients, in bits."""
    return max((max(c.numerator.bit_length(), c.denominator.bit_length()) for c in p.values()), default=0)


def _cost(pairs: int, bits_a: int, bits_b: int) -> int:
    """Work units of `pairs` coefficient operations (Fraction products or
    sums, with their gcds) on operands of up to bits_a and bits_b bits: one
    unit each for short operands, and about bits_a * bits_b / 100,000 for
    long ones (measured: 1,330-bit operands take ~20 times as long as small
    ones, 16,000-bit ones ~500 times)."""
    return pairs * (1 + bits_a * bits_b // 100_000)


def _check_double_range(value: Fraction, error) -> None:
    """Raises error() unless value is 0 or rounds to a finite non-zero double."""
    if not value:
        return
    try:
        rounded = float(value)
    except OverflowError:
        raise error() from None
    if rounded == 0.0 or rounded in (float("inf"), float("-inf")):
        raise error()


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.lexer = _Lexer(text)
        self.previous: _Token | None = None
        self.tok = self.lexer.next()
        self.depth = 0
        self.work = 0

    def error(self, message: str, position: int | None = None) -> ExpressionError:
        return ExpressionError(message, self.tok.position if position is None else position, self.text)

    def take(self) -> _Token:
        t = self.tok
        self.previous = t
        self.tok = self.lexer.next()
        return t

    def at_op(self, ops: str) -> bool:
        return self.tok.kind == "op" and self.tok.text in ops

    def spend(self, units: int, position: int) -> None:
        self.work += units
        if self.work > MAX_WORK:
            raise self.error(
                f"expanding this takes more than {MAX_WORK} units of coefficient arithmetic: "
                "simplify the expression (fewer or shorter numbers, lower powers)",
                position,
            )

    def add(self, a: Poly, b: Poly, sign: int, position: int) -> Poly:
        """a + sign * b, counted in the work like multiply."""
        self.spend(_cost(len(b), _bits(a), _bits(b)), position)
        return _add(a, b, sign)

    def multiply(self, a: Poly, b: Poly, position: int) -> Poly:
        """a * b, refused (at position) before it is computed once the
        expansion's work would exceed MAX_WORK, or after it when a coefficient
        leaves any hope of double range."""
        self.spend(_cost(len(a) * len(b), _bits(a), _bits(b)), position)
        product = _mul(a, b)
        if _too_wide(product):
            raise self.error("a coefficient grows beyond double-precision range", position)
        return product

    def nest(self, position: int) -> None:
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise self.error(f"nesting deeper than {MAX_NESTING} levels", position)

    # -- grammar -------------------------------------------------------------

    def equation(self) -> Poly:
        if self.tok.kind == "end":
            raise self.error("the expression is empty")
        left = self.expr()
        if self.at_op("="):
            equals = self.take()
            if self.tok.kind == "end":
                raise self.error("'=' has nothing after it", equals.position)
            left = self.add(left, self.expr(), -1, equals.position)
        self.leftover(inside=None)
        return left

    def leftover(self, inside: _Token | None) -> None:
        """What may not follow a complete expression (at the top, or inside
        the parenthesis `inside`)."""
        t = self.tok
        if t.kind == "end":
            if inside is not None:
                raise self.error("unmatched '('", inside.position)
            return
        if t.kind == ")":
            if inside is not None:
                return
            raise self.error("unmatched ')'")
        if t.kind in ("num", "var", "("):
            raise self.error(f"missing operator before {t.text!r} (write '*' to multiply)")
        if t.text == "^":
            raise self.error("a power of a power needs parentheses: write (x^2)^3")
        if t.text == "=":
            if inside is not None:
                raise self.error("'=' is not allowed inside parentheses")
            raise self.error("only one '=' is allowed")
        raise self.error(f"unexpected {t.text!r}")  # pragma: no cover (every token kind is handled above)

    def expr(self) -> Poly:
        result = self.term()
        while self.at_op("+-"):
            operator = self.take()
            result = self.add(result, self.term(), 1 if operator.text == "+" else -1, operator.position)
        return result

    def term(self) -> Poly:
        result = self.signed()
        while self.at_op("*"):
            star = self.take()
            factor = self.signed()
            degree = _degree(result) + _degree(factor) if result and factor else 0
            if degree > MAX_DEGREE:
                raise self.error(f"degree {degree} exceeds the maximum {MAX_DEGREE}", star.position)
            result = self.multiply(result, factor, star.position)
        return result

    def signed(self) -> Poly:
        if self.at_op("+-"):
            sign = self.take()
            if self.at_op("+-*^="):
                raise self.error(f"two operators in a row: {sign.text!r} then {self.tok.text!r}")
            self.nest(sign.position)
            inner = self.power()
            self.depth -= 1
            return inner if sign.text == "+" else {m: -c for m, c in inner.items()}
        return self.power()

    def power(self) -> Poly:
        base = self.atom()
        if not self.at_op("^"):
            return base
        caret = self.take()
        t = self.tok
        if t.kind == "end":
            raise self.error("missing exponent after '^'", caret.position)
        if t.kind != "num" or any(ch not in _DIGITS for ch in t.text):
            shown = "-" if t.text == "-" else t.text
            raise self.error(f"the exponent must be a non-negative integer such as 2, not {shown!r}")
        self.take()
        # Refuse before expanding: the exponent alone bounds the work.
        base_degree = _degree(base) if base else 0
        if len(t.text.lstrip("0")) > 30:
            shown = t.text if len(t.text) <= 20 else t.text[:17] + "..."
            raise self.error(f"the exponent {shown} exceeds the maximum {MAX_DEGREE}", t.position)
        exponent = int(t.text)
        if base_degree == 0 and exponent > MAX_DEGREE:
            raise self.error(f"the exponent {exponent} exceeds the maximum {MAX_DEGREE}", t.position)
        if exponent * base_degree > MAX_DEGREE:
            raise self.error(f"degree {exponent * base_degree} exceeds the maximum {MAX_DEGREE}", t.position)
        result = _ONE
        for _ in range(exponent):
            result = self.multiply(result, base, t.position)
        return result

    def atom(self) -> Poly:
        t = self.tok
        if t.kind == "num":
            self.take()
            return {(0, 0, 0): t.value} if t.value else {}
        if t.kind == "var":
            self.take()
            return {_VARIABLES[t.text]: Fraction(1)}
        if t.kind == "(":
            self.take()
            self.nest(t.position)
            if self.tok.kind == ")":
                raise self.error("empty parentheses")
            inner = self.expr()
            self.leftover(inside=t)
            self.take()  # the ')'
            self.depth -= 1
            return inner
        previous = self.previous
        if t.kind == "end":
            # Only reached after an operator: the expression ends with it.
            assert previous is not None
            if previous.kind == "(":
                raise self.error("unmatched '('", previous.position)
            raise self.error(f"the expression ends with {previous.text!r}: an operand is missing after it", previous.position)
        if t.kind == ")":
            raise self.error("unexpected ')'")
        if previous is not None and previous.kind == "op":
            raise self.error(f"two operators in a row: {previous.text!r} then {t.text!r}")
        raise self.error(f"{t.text!r} needs an operand before it")


@dataclass(frozen=True)
class SurfacePolynomial:
    """F(x, y, z) = sum of c * x^i * y^j * z^k over ``terms[(i, j, k)] = c``.

    Coefficients are exact (``Fraction``) and non-zero; ``degree`` is the
    total degree, 1..MAX_DEGREE; ``text`` is the expression it came from.
    """

    text: str
    terms: dict[Monomial, Fraction] = field(hash=False)
    degree: int

    def as_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(exponents, coefficients): int32 of shape (m, 3) and float64 of
        shape (m,), in lexicographic order of the exponents; each coefficient
        is the exact one rounded to the nearest double."""
        items = sorted(self.terms.items())
        exponents = np.array([m for m, _ in items], dtype=np.int32).reshape(-1, 3)
        coefficients = np.array([float(c) for _, c in items], dtype=np.float64)
        return exponents, coefficients

    def __call__(self, x, y, z):
        """F at a point, in floating point: x, y, z may be floats, complex
        numbers or numpy arrays (broadcast together)."""
        total = 0.0
        for (i, j, k), c in self.terms.items():
            total = total + float(c) * x**i * y**j * z**k
        return total

    def to_text(self) -> str:
        """The expanded polynomial as an expression that parses back to the
        same terms (every coefficient is a terminating decimal, since the
        decimals are closed under + - *)."""
        parts = []
        for (i, j, k), c in sorted(self.terms.items(), key=lambda item: (-sum(item[0]), tuple(-e for e in item[0]))):
            factors = [f"{v}^{e}" if e > 1 else v for v, e in zip("xyz", (i, j, k)) if e]
            magnitude = _decimal(abs(c))
            if factors and magnitude == "1":
                body = "*".join(factors)
            else:
                body = "*".join([magnitude, *factors])
            sign = "-" if c < 0 else "+"
            parts.append((sign, body))
        first_sign, first_body = parts[0]
        out = ("-" if first_sign == "-" else "") + first_body
        for sign, body in parts[1:]:
            out += f" {sign} {body}"
        return out


def _decimal(value: Fraction) -> str:
    """Exact decimal text of a non-negative fraction whose denominator is 2^a 5^b."""
    denominator, twos, fives = value.denominator, 0, 0
    while denominator % 2 == 0:
        denominator //= 2
        twos += 1
    while denominator % 5 == 0:
        denominator //= 5
        fives += 1
    if denominator != 1:  # pragma: no cover (parse_surface never makes one)
        raise ValueError(f"{value} is not a terminating decimal")
    places = max(twos, fives)
    digits = str(value.numerator * 10**places // value.denominator)
    if places == 0:
        return digits
    digits = digits.rjust(places + 1, "0")
    return f"{digits[:-places]}.{digits[-places:]}".rstrip("0").rstrip(".")


def parse_surface(text: str) -> SurfacePolynomial:
    """Parses and expands a surface expression (see the module grammar).

    Returns a polynomial of total degree 1..MAX_DEGREE with exact non-zero
    coefficients, each representable as a finite non-zero double. Raises
    ExpressionError, with the position of the first mistake, for anything
    else: a syntax error, an unknown name, an exponent that is not a
    non-negative integer, a degree above MAX_DEGREE, a number or
    coefficient outside double range, the zero polynomial, or a constant.
    """
    if not isinstance(text, str):
        raise ExpressionError(
            f"the surface must be text such as 'x^2 + y^2 + z^2 - 1', not {type(text).__name__}", 0, repr(text)
        )
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the expression has {len(text)} characters; the most is {MAX_LENGTH}", MAX_LENGTH, text)
    poly = _Parser(text).equation()
    if not poly:
        raise ExpressionError("the surface is the zero polynomial (every point satisfies it): nothing to render", 0, text)
    degree = _degree(poly)
    if degree == 0:
        raise ExpressionError("the surface has degree 0 (it is a constant): nothing to render", 0, text)
    for monomial, c in poly.items():
        _check_double_range(
            c,
            lambda: ExpressionError(
                f"the coefficient of {_monomial_text(monomial)} is outside double-precision range", 0, text
            ),
        )
    return SurfacePolynomial(text=text, terms=poly, degree=degree)


def _monomial_text(monomial: Monomial) -> str:
    factors = [f"{v}^{e}" if e > 1 else v for v, e in zip("xyz", monomial) if e]
    return "*".join(factors) or "the constant term"
