"""Surface expressions: a safe parser (no eval) into an exact sparse polynomial.

Grammar (whitespace ignored)::

    equation := sum [ "=" sum ]            (A = B means A - B = 0)
    sum      := ["+"|"-"] term { ("+"|"-") term }
    term     := power { "*" power }
    power    := atom [ ("^" | "**") integer ]
    atom     := number | "x" | "y" | "z" | "(" sum ")" | ("+"|"-") atom

Numbers are decimals (``12``, ``1.5``, ``.5``, ``2e-3``) taken at their exact
rational value, so ``0.1`` is exactly 1/10. The polynomial is expanded once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Iterator

import numpy as np

#: Largest total degree a surface may have (the root core handles more, but
#: a renderable scene never needs it and it bounds the work of expansion).
MAX_DEGREE = 12

Monomial = tuple[int, int, int]
Poly = dict[Monomial, Fraction]


class ExpressionError(ValueError):
    """A mistake in a surface expression, with the 0-based column where it is."""

    def __init__(self, message: str, position: int, text: str) -> None:
        self.message = message
        self.position = position
        self.text = text
        super().__init__(str(self))

    def __str__(self) -> str:
        return f"{self.message} at column {self.position + 1}\n  {self.text}\n  {' ' * self.position}^"


@dataclass(frozen=True)
class Token:
    kind: str  # "num", "var", "op", "(", ")", "end"
    text: str
    pos: int
    value: Fraction | None = None


def tokenize(text: str) -> Iterator[Token]:
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        if ch.isspace():
            i += 1
            continue
        if ch.isdigit() or (ch == "." and i + 1 < n and text[i + 1].isdigit()):
            j = i
            while j < n and text[j].isdigit():
                j += 1
            if j < n and text[j] == ".":
                j += 1
                while j < n and text[j].isdigit():
                    j += 1
            if j < n and text[j] in "eE":
                k = j + 1
                if k < n and text[k] in "+-":
                    k += 1
                if k < n and text[k].isdigit():
                    while k < n and text[k].isdigit():
                        k += 1
                    j = k
            literal = text[i:j]
            try:
                value = Fraction(literal)
            except (ValueError, ZeroDivisionError):
                raise ExpressionError(f"cannot read the number {literal!r}", i, text) from None
            if abs(value) > Fraction(10) ** 300:
                raise ExpressionError(f"the number {literal} is too large", i, text)
            yield Token("num", literal, i, value)
            i = j
            continue
        if ch.isalpha() or ch == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            name = text[i:j]
            if name in ("x", "y", "z"):
                yield Token("var", name, i)
            else:
                raise ExpressionError(f"unknown name {name!r} (the variables are x, y and z)", i, text)
            i = j
            continue
        if text.startswith("**", i):
            yield Token("op", "^", i)
            i += 2
            continue
        if ch in "+-*^=":
            yield Token("op", ch, i)
            i += 1
            continue
        if ch in "()":
            yield Token(ch, ch, i)
            i += 1
            continue
        raise ExpressionError(f"unexpected character {ch!r}", i, text)
    yield Token("end", "", n)


# ---------------------------------------------------------------------------
# Exact sparse polynomial arithmetic
# ---------------------------------------------------------------------------


def _add(a: Poly, b: Poly, sign: int = 1) -> Poly:
    out = dict(a)
    for m, c in b.items():
        v = out.get(m, Fraction(0)) + sign * c
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
            v = out.get(m, Fraction(0)) + c1 * c2
            if v:
                out[m] = v
            else:
                out.pop(m, None)
    return out


def _degree(p: Poly) -> int:
    return max((sum(m) for m in p), default=0)


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = list(tokenize(text))
        self.i = 0

    @property
    def tok(self) -> Token:
        return self.tokens[self.i]

    def error(self, message: str, pos: int | None = None) -> ExpressionError:
        return ExpressionError(message, self.tok.pos if pos is None else pos, self.text)

    def take(self) -> Token:
        t = self.tok
        self.i += 1
        return t

    def check_degree(self, p: Poly, pos: int) -> Poly:
        d = _degree(p)
        if d > MAX_DEGREE:
            raise self.error(f"degree {d} exceeds the maximum {MAX_DEGREE}", pos)
        return p

    def equation(self) -> Poly:
        if self.tok.kind == "end":
            raise self.error("the expression is empty")
        left = self.sum()
        if self.tok.kind == "op" and self.tok.text == "=":
            self.take()
            if self.tok.kind == "end":
                raise self.error("nothing after '='")
            left = _add(left, self.sum(), -1)
        if self.tok.kind != "end":
            t = self.tok
            if t.kind == ")":
                raise self.error("unmatched ')'")
            if t.kind in ("num", "var", "("):
                raise self.error(f"missing operator before {t.text!r}")
            raise self.error(f"unexpected {t.text!r}")
        return left

    def sum(self) -> Poly:
        start = self.tok.pos
        result = self.term()
        while self.tok.kind == "op" and self.tok.text in "+-":
            sign = 1 if self.take().text == "+" else -1
            result = _add(result, self.term(), sign)
        return self.check_degree(result, start)

    def term(self) -> Poly:
        start = self.tok.pos
        result = self.power()
        while self.tok.kind == "op" and self.tok.text == "*":
            self.take()
            result = self.check_degree(_mul(result, self.power()), start)
        return result

    def power(self) -> Poly:
        start = self.tok.pos
        base = self.atom()
        if self.tok.kind == "op" and self.tok.text == "^":
            self.take()
            t = self.tok
            negative = False
            if t.kind == "op" and t.text == "-":
                negative = True
            if negative or t.kind != "num":
                if negative or t.kind in ("var", "("):
                    raise self.error("the exponent must be a non-negative integer", t.pos)
                raise self.error("missing exponent after '^'", t.pos)
            self.take()
            if t.value is None or t.value.denominator != 1 or "." in t.text or "e" in t.text.lower():
                raise self.error(f"the exponent must be a non-negative integer, got {t.text}", t.pos)
            e = int(t.value)
            if e > MAX_DEGREE or e * _degree(base) > MAX_DEGREE:
                raise self.error(f"degree {e * max(1, _degree(base))} exceeds the maximum {MAX_DEGREE}", t.pos)
            result: Poly = {(0, 0, 0): Fraction(1)}
            for _ in range(e):
                result = _mul(result, base)
            if self.tok.kind == "op" and self.tok.text == "^":
                raise self.error("write (a^b)^c with parentheses", self.tok.pos)
            return self.check_degree(result, start)
        return base

    def atom(self) -> Poly:
        t = self.tok
        if t.kind == "num":
            self.take()
            return {(0, 0, 0): t.value} if t.value else {}
        if t.kind == "var":
            self.take()
            return {{"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[t.text]: Fraction(1)}
        if t.kind == "(":
            self.take()
            if self.tok.kind == ")":
                raise self.error("empty parentheses")
            inner = self.sum()
            if self.tok.kind != ")":
                if self.tok.kind == "end":
                    raise self.error("unmatched '('", t.pos)
                if self.tok.kind in ("num", "var", "("):
                    raise self.error(f"missing operator before {self.tok.text!r}")
                raise self.error(f"expected ')' but found {self.tok.text!r}")
            self.take()
            return inner
        if t.kind == "op" and t.text in "+-":
            self.take()
            inner = self.atom_after_sign(t)
            return inner if t.text == "+" else {m: -c for m, c in inner.items()}
        if t.kind == "end":
            raise self.error("the expression ends too early (an operand is missing)")
        if t.kind == ")":
            raise self.error("unexpected ')'")
        previous = self.tokens[self.i - 1] if self.i > 0 else None
        if t.kind == "op" and previous is not None and previous.kind == "op":
            raise self.error(f"two operators in a row ({previous.text!r} then {t.text!r})")
        raise self.error(f"unexpected {t.text!r} (an operand is missing)")

    def atom_after_sign(self, sign: Token) -> Poly:
        if self.tok.kind == "op" and self.tok.text in "+-*^=":
            raise self.error(f"two operators in a row ({sign.text!r} then {self.tok.text!r})")
        return self.power()


@dataclass(frozen=True)
class SurfacePolynomial:
    """F(x, y, z) as exact rational coefficients of monomials x^i y^j z^k."""

    text: str
    terms: dict[Monomial, Fraction] = field(hash=False)
    degree: int

    def as_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(exponents (m, 3) int32, coefficients (m,) float64)."""
        items = sorted(self.terms.items())
        exps = np.array([m for m, _ in items], dtype=np.int32).reshape(-1, 3)
        coeffs = np.array([float(c) for _, c in items], dtype=np.float64)
        return exps, coeffs

    def __call__(self, x, y, z):
        """Numeric value at a point (floats or complex numbers)."""
        return sum(float(c) * x**i * y**j * z**k for (i, j, k), c in self.terms.items())


def parse_surface(text: str) -> SurfacePolynomial:
    """Parse and expand a surface expression; raises ExpressionError."""
    if not isinstance(text, str):
        raise ExpressionError("the surface must be a string such as 'x^2 + y^2 + z^2 - 1'", 0, str(text))
    parser = _Parser(text)
    poly = parser.equation()
    if not poly:
        raise ExpressionError("the surface is the zero polynomial (every point satisfies it): nothing to render", 0, text)
    degree = _degree(poly)
    if degree == 0:
        raise ExpressionError("the surface has degree 0 (it is a constant): nothing to render", 0, text)
    for c in poly.values():
        if not math.isfinite(float(c)):
            raise ExpressionError("a coefficient is too large for double precision", 0, text)
    return SurfacePolynomial(text=text, terms=poly, degree=degree)
