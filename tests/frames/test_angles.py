"""Angles as people write them (argand.frames.angles): values, and a clear,
positioned ValueError for everything else, including inputs long or deep
enough to exhaust a parser (which the API would answer with a 500)."""

from __future__ import annotations

import math

import pytest

from argand.frames.angles import ANGLE_SYNTAX, MAX_ANGLE_LENGTH, parse_angle, parse_sweep
from argand.scene import ExpressionError


@pytest.mark.parametrize(
    "text, value",
    [
        ("pi/9", math.pi / 9),
        ("2*pi/3", 2 * math.pi / 3),
        ("-pi/18", -math.pi / 18),
        ("π/2", math.pi / 2),
        ("0.35", 0.35),
        (" 1e-3 ", 1e-3),
        ("--1", 1.0),
        ("-(pi - 1) * 2", -(math.pi - 1) * 2),
        ("8/2/2", 2.0),
        ("1 - 2 - 3", -4.0),
        ("2*-3", -6.0),
        ("1e-400", 0.0),
    ],
)
def test_values_are_pythons_float_arithmetic(text, value):
    assert parse_angle(text) == value


@pytest.mark.parametrize("value", [0, 3, -2.5, 0.35, 2**1023])
def test_numbers_pass_through(value):
    assert parse_angle(value) == float(value)


@pytest.mark.parametrize(
    "text, message, position",
    [
        # Inputs that would exhaust the parser: refused before any work.
        ("-" * 5000 + "1", f"it has 5001 characters; the most is {MAX_ANGLE_LENGTH}", MAX_ANGLE_LENGTH),
        ("0x" + "f" * 300, "it has 302 characters", MAX_ANGLE_LENGTH),
        ("0x1f", "unknown name 'x1f': an angle allows numbers, pi", 1),
        ("pi/", "it ends with '/'", 2),
        ("", "it is empty", 0),
        ("  ", "it is empty", 0),
        ("()", "empty parentheses", 0),
        ("(pi", "unmatched '('", 0),
        ("pi)", "unmatched ')'", 2),
        ("2pi", "missing operator before 'pi'", 1),
        ("2 3", "missing operator before '3'", 2),
        ("1/0", "division by zero", 1),
        ("pi/(1-1)", "division by zero", 2),
        ("1e200*1e200", "overflows double range", 5),
        ("1e999", "out of double-precision range", 0),
        ("1e99999", "out of double-precision range", 0),
        ("2**3", "'*' after '*'", 2),
        ("*3", "'*' needs a number or pi before it", 0),
        ("x", "unknown name 'x'", 0),
        ("__import__('os')", "unknown name '__import__'", 0),
        ("1,5", "unexpected character ','", 1),
        ("1 − 2", "write '-', ASCII minus", 2),
    ],
)
def test_text_errors_say_what_where_and_what_is_allowed(text, message, position):
    with pytest.raises(ExpressionError) as caught:
        parse_angle(text)
    assert caught.value.message.startswith("cannot read the angle: ")
    assert message in caught.value.message
    assert caught.value.position == position
    assert isinstance(caught.value, ValueError)


def test_errors_quote_the_syntax():
    with pytest.raises(ValueError) as caught:
        parse_angle("sin(1)")
    assert ANGLE_SYNTAX in str(caught.value)


@pytest.mark.parametrize(
    "value, message",
    [
        (None, "got null (None)"),
        ({}, "got dict {}"),
        ([], "got list []"),
        (["pi/9"], "got list"),
        (True, "got bool True"),
        (10**400, "finite number within double range"),
        (-(2**1024), "finite number within double range"),
        (float("nan"), "finite number"),
        (float("inf"), "finite number"),
    ],
)
def test_other_values_are_value_errors(value, message):
    with pytest.raises(ValueError, match="an angle must be") as caught:
        parse_angle(value)
    assert message in str(caught.value)


def test_no_recursion_at_the_length_limit():
    # The old ast-based parser recursed once per sign: 5,000 signs raised
    # RecursionError. Within the limit, any mix of signs and parentheses is
    # parsed with explicit stacks.
    signs = MAX_ANGLE_LENGTH - 1  # 199 minus signs and a 1
    assert parse_angle("-" * signs + "1") == (-1.0) ** signs
    depth = (MAX_ANGLE_LENGTH - 2) // 2  # 99 parentheses around pi
    assert parse_angle("(" * depth + "pi" + ")" * depth) == math.pi


@pytest.mark.parametrize(
    "text, expected",
    [("0:pi/9:24", (0.0, math.pi / 9, 24)), ("-pi/18 : pi/18 : 3", (-math.pi / 18, math.pi / 18, 3))],
)
def test_sweeps(text, expected):
    assert parse_sweep(text) == expected


@pytest.mark.parametrize(
    "text, message",
    [
        ("0:pi/9", "START:STOP:COUNT"),
        ("0:pi/9:0", "COUNT must be >= 1"),
        ("0:pi/9:x", "whole number"),
        ("0:pi/9:" + "9" * 5000, "at most 9 digits"),
        ("0:pi/:3", "cannot read the angle: it ends with '/'"),
    ],
)
def test_bad_sweeps(text, message):
    with pytest.raises(ValueError) as caught:
        parse_sweep(text)
    assert message in str(caught.value)
