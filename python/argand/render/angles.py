"""Angles as people write them: 0.35, pi/9, 2*pi/3, -pi/18 (no eval)."""

from __future__ import annotations

import ast
import math
import operator

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}


def parse_angle(text: str) -> float:
    """A number, ``pi``, + - * / and parentheses. Raises ValueError saying
    what is wrong."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ValueError(f"cannot read {text!r} as an angle (examples: 0.35, pi/9, 2*pi/3)") from None

    def value(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id in ("pi", "π"):
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            right = value(node.right)
            if isinstance(node.op, ast.Div) and right == 0:
                raise ValueError(f"division by zero in {text!r}")
            return _BINARY[type(node.op)](value(node.left), right)
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](value(node.operand))
        raise ValueError(f"{text!r}: only numbers, pi, + - * / and parentheses are allowed in an angle")

    result = value(tree)
    if not math.isfinite(result):
        raise ValueError(f"{text!r} is not a finite angle")
    return result


def parse_sweep(text: str) -> tuple[float, float, int]:
    """START:STOP:COUNT, e.g. ``0:pi/9:24``."""
    parts = text.split(":")
    if len(parts) != 3:
        raise ValueError(f"expected START:STOP:COUNT (e.g. 0:pi/9:24), got {text!r}")
    start, stop = parse_angle(parts[0]), parse_angle(parts[1])
    try:
        count = int(parts[2])
    except ValueError:
        raise ValueError(f"COUNT must be a whole number, got {parts[2]!r}") from None
    if count < 1:
        raise ValueError(f"COUNT must be >= 1, got {count}")
    return start, stop, count
