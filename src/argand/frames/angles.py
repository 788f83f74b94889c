"""Angles as people write them: 0.35, pi/9, 2*pi/3, -pi/18 (no eval).

Grammar (spaces are ignored)::

    angle   := sum
    sum     := product { ("+" | "-") product }
    product := signed { ("*" | "/") signed }
    signed  := { "+" | "-" } atom             -pi/9 is (-pi)/9, as in Python
    atom    := number | "pi" | "π" | "(" sum ")"
    number  := decimal such as 12, 1.5, .5, 1e-3

Guarantees: :func:`parse_angle` returns a finite float or raises
``ValueError`` (an :class:`~argand.scene.ExpressionError` for text, with the
0-based position of the first mistake and what is allowed), never another
exception, and its work is bounded before it starts: the text is at most
MAX_ANGLE_LENGTH characters, parsed without recursion (an explicit operator
stack, shunting-yard), numbers are read by the surface parser's bounded
:func:`~argand.scene.expression.scan_number` and evaluated in floating
point, so no huge integer is ever built, and every intermediate value must
stay finite.
"""

from __future__ import annotations

import math
import numbers

from argand.scene.expression import ExpressionError, scan_number

#: Longest angle text accepted ("-2*pi/3 + 0.125" is 15 characters).
MAX_ANGLE_LENGTH = 200
#: What an angle may contain, quoted in every error.
ANGLE_SYNTAX = "numbers, pi, + - * / and parentheses (e.g. 0.35, pi/9, -2*pi/3)"

_DIGITS = "0123456789"
_NAME_CHARS = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789π"
# Binary operators and their precedence; unary signs bind tighter than both.
_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2}
_UNARY_PRECEDENCE = 3


def parse_angle(value: object) -> float:
    """An angle in radians from a number or from text (see the module grammar).

    Numbers (int or float, not bool) must be finite and within double range;
    text is parsed as above. Raises ValueError saying what is wrong, where
    (for text) and what is allowed."""
    if isinstance(value, str):
        return _parse_text(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"an angle must be a number or text made of {ANGLE_SYNTAX}; got {_describe(value)}")
    try:
        result = float(value)
    except (OverflowError, ValueError):
        result = math.inf
    if not math.isfinite(result):
        raise ValueError(f"an angle must be a finite number within double range; got {_short(repr(value))}")
    return result


def _describe(value: object) -> str:
    if value is None:
        return "null (None)"
    return f"{type(value).__name__} {_short(repr(value))}"


def _short(text: str, most: int = 40) -> str:
    return text if len(text) <= most else text[: most - 3] + "..."


class _Angle:
    """One parse: tokens are read on demand and reduced on two explicit
    stacks, so the first mistake reported is the leftmost and no Python
    recursion happens whatever the text."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.values: list[float] = []
        # Pending operators: (symbol, position); "u+"/"u-" are unary signs and
        # "(" an open parenthesis.
        self.ops: list[tuple[str, int]] = []

    def error(self, message: str, position: int) -> ExpressionError:
        return _error(message, position, self.text)

    def tokens(self):
        """(kind, text, position) with kind "num", "pi", "op", "(", ")" and a
        final "end"."""
        text, n, i = self.text, len(self.text), 0
        while True:
            while i < n and text[i].isspace():
                i += 1
            if i >= n:
                yield "end", "", n
                return
            ch = text[i]
            if ch in _DIGITS or (ch == "." and i + 1 < n and text[i + 1] in _DIGITS):
                try:
                    literal = scan_number(text, i)
                except ExpressionError as exc:
                    raise self.error(exc.message, exc.position) from None
                yield "num", literal, i
                i += len(literal)
            elif ch in _NAME_CHARS:
                j = i
                while j < n and text[j] in _NAME_CHARS:
                    j += 1
                name = text[i:j]
                if name not in ("pi", "π"):
                    raise self.error(f"unknown name {_short(name)!r}: an angle allows {ANGLE_SYNTAX}", i)
                yield "pi", name, i
                i = j
            elif ch in "+-*/()":
                yield ("op" if ch in "+-*/" else ch), ch, i
                i += 1
            else:
                hint = " (write '*' to multiply)" if ch in "·⋅×" else " (write '-', ASCII minus)" if ch in "−–" else ""
                raise self.error(f"unexpected character {ch!r}{hint}: an angle allows {ANGLE_SYNTAX}", i)

    def reduce(self) -> None:
        """Applies the operator on top of the stack to its operands."""
        op, position = self.ops.pop()
        if op in ("u+", "u-"):
            operand = self.values.pop()
            self.values.append(operand if op == "u+" else -operand)
            return
        right = self.values.pop()
        left = self.values.pop()
        if op == "/" and right == 0.0:
            raise self.error("division by zero", position)
        result = {"+": left + right, "-": left - right, "*": left * right}[op] if op != "/" else left / right
        if not math.isfinite(result):
            raise self.error(f"the value overflows double range at this {op!r}", position)
        self.values.append(result)

    def reduce_while(self, precedence: int) -> None:
        while self.ops and self.ops[-1][0] != "(" and _precedence(self.ops[-1][0]) >= precedence:
            self.reduce()

    def parse(self) -> float:
        expect_operand = True
        previous: tuple[str, str, int] | None = None
        for kind, token, position in self.tokens():
            if expect_operand:
                if kind in ("num", "pi"):
                    value = math.pi if kind == "pi" else float(token)
                    if not math.isfinite(value):
                        raise self.error(f"the number {_short(token)} is out of double-precision range", position)
                    self.values.append(value)
                    expect_operand = False
                elif kind == "(" or (kind == "op" and token in "+-"):
                    self.ops.append(("(" if kind == "(" else "u" + token, position))
                elif kind == "end":
                    if previous is None:
                        raise self.error(f"it is empty (write {ANGLE_SYNTAX})", 0)
                    if previous[0] == "(":
                        raise self.error("unmatched '('", previous[2])
                    raise self.error(
                        f"it ends with {previous[1]!r}: a number, pi or '(' must follow it", previous[2]
                    )
                elif kind == ")":
                    if previous is not None and previous[0] == "(":
                        raise self.error("empty parentheses", previous[2])
                    raise self.error("unexpected ')': a number, pi or '(' is missing before it", position)
                elif previous is not None and previous[0] in ("op", "("):
                    raise self.error(f"{token!r} after {previous[1]!r}: a number, pi or '(' is missing between", position)
                else:
                    raise self.error(f"{token!r} needs a number or pi before it", position)
            else:
                if kind == "op":
                    self.reduce_while(_PRECEDENCE[token])
                    self.ops.append((token, position))
                    expect_operand = True
                elif kind == ")":
                    self.reduce_while(0)
                    if not self.ops:
                        raise self.error("unmatched ')'", position)
                    self.ops.pop()  # the matching "("
                elif kind == "end":
                    self.reduce_while(0)
                    if self.ops:
                        raise self.error("unmatched '('", self.ops[-1][1])
                    return self.values[-1]
                else:
                    raise self.error(f"missing operator before {_short(token)!r} (write '*' to multiply)", position)
            previous = (kind, token, position)
        raise AssertionError("unreachable: tokens() ends with 'end'")  # pragma: no cover


def _error(message: str, position: int, text: str) -> ExpressionError:
    return ExpressionError(f"cannot read the angle: {message}", position, text)


def _precedence(op: str) -> int:
    return _UNARY_PRECEDENCE if op in ("u+", "u-") else _PRECEDENCE[op]


def _parse_text(text: str) -> float:
    if len(text) > MAX_ANGLE_LENGTH:
        raise _error(f"it has {len(text)} characters; the most is {MAX_ANGLE_LENGTH} ({ANGLE_SYNTAX})", MAX_ANGLE_LENGTH, text)
    return _Angle(text).parse()


def parse_sweep(text: str) -> tuple[float, float, int]:
    """START:STOP:COUNT, e.g. ``0:pi/9:24``."""
    parts = text.split(":")
    if len(parts) != 3:
        raise ValueError(f"expected START:STOP:COUNT (e.g. 0:pi/9:24), got {_short(text)!r}")
    start, stop = parse_angle(parts[0]), parse_angle(parts[1])
    count_text = parts[2].strip()
    if not count_text.isascii() or not count_text.isdigit() or len(count_text) > 9:
        raise ValueError(f"COUNT must be a whole number of at most 9 digits, got {_short(parts[2])!r}")
    count = int(count_text)
    if count < 1:
        raise ValueError(f"COUNT must be >= 1, got {count}")
    return start, stop, count
