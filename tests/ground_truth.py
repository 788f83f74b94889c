"""An independent truth for the root finder: python-flint on the EXACT
rational value of the double coefficients, and a checker that compares every
claim the core makes against it. Nothing here calls argand.core."""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Sequence

import flint


@dataclass
class TrueRoot:
    ball: flint.acb  # encloses the root (at the precision it was computed)
    multiplicity: int
    real: bool  # the ball is exactly on the real axis (flint isolated a real root)


def exact_polynomial(coeffs: Sequence[float]) -> tuple[flint.fmpq_poly, int]:
    """The exact polynomial and its number of roots at infinity."""
    values = [float(c) for c in coeffs]
    top = len(values) - 1
    while top >= 0 and values[top] == 0.0:
        top -= 1
    poly = flint.fmpq_poly([flint.fmpq(*Fraction(v).as_integer_ratio()) for v in values[: top + 1]])
    return poly, len(values) - 1 - top


def true_roots(coeffs: Sequence[float], prec: int = 128) -> tuple[list[TrueRoot], int]:
    poly, n_infinite = exact_polynomial(coeffs)
    old = flint.ctx.prec
    flint.ctx.prec = prec
    try:
        roots = [] if poly.degree() < 1 else poly.complex_roots()
    finally:
        flint.ctx.prec = old
    out = []
    for ball, mult in roots:
        out.append(TrueRoot(ball, int(mult), ball.imag.is_exact() and ball.imag.is_zero()))
    return out, n_infinite


def _inside(root: TrueRoot, center: complex, radius: float, prec: int) -> bool | None:
    """True/False if certain that the root lies in / outside the closed disc,
    None if undecided at this precision."""
    old = flint.ctx.prec
    flint.ctx.prec = prec
    try:
        dist = abs(root.ball - flint.acb(center.real, center.imag))
        r = flint.arb(radius)
        if dist <= r:
            return True
        if dist > r:
            return False
        return None
    finally:
        flint.ctx.prec = old


def _disjoint(c1: complex, r1: float, c2: complex, r2: float) -> bool:
    old = flint.ctx.prec
    flint.ctx.prec = 256
    try:
        dist = abs(flint.acb(c1.real, c1.imag) - flint.acb(c2.real, c2.imag))
        return bool(dist > flint.arb(r1) + flint.arb(r2))
    finally:
        flint.ctx.prec = old


def check_roots(coeffs: Sequence[float], roots) -> list[str]:
    """Every violation of the contract by `roots` (an argand.core.Roots),
    as readable strings; empty when all claims hold."""
    problems: list[str] = []
    degree = len(coeffs) - 1
    n = len(roots.center)
    verified = [i for i in range(n) if bool(roots.verified[i])]
    for i in range(n):
        if bool(roots.real[i]) and not bool(roots.verified[i]):
            problems.append(f"entry {i}: real claimed without verified")
    # Membership of every true root in every verified disc, decided with
    # certainty (raising the precision of the truth when a root sits too
    # close to a disc's boundary to tell).
    for prec in (128, 256, 1024):
        truth, n_infinite = true_roots(coeffs, prec)
        inside = {
            i: [_inside(t, complex(roots.center[i]), float(roots.radius[i]), prec + 64) for t in truth]
            for i in verified
        }
        if all(v is not None for row in inside.values() for v in row):
            break
    else:
        return problems + [f"membership undecided even at 1024 bits for {list(coeffs)!r}"]
    if int(roots.n_infinite) != n_infinite:
        problems.append(f"n_infinite {roots.n_infinite} != {n_infinite}")
    if sum(int(c) for c in roots.count) + int(roots.n_infinite) != degree:
        problems.append(f"sum(count) + n_infinite = {sum(int(c) for c in roots.count)} + {roots.n_infinite} != degree {degree}")
    for i in verified:
        held = sum(t.multiplicity for t, v in zip(truth, inside[i]) if v)
        if held != int(roots.count[i]):
            problems.append(
                f"disc {i} D({complex(roots.center[i])!r}, {float(roots.radius[i])!r}) claims {int(roots.count[i])} roots, holds {held}"
            )
        if bool(roots.real[i]) and not any(v and t.real for t, v in zip(truth, inside[i])):
            problems.append(f"disc {i} claims a real root and holds none")
    for a in verified:
        for b in verified:
            if a < b and not _disjoint(
                complex(roots.center[a]), float(roots.radius[a]), complex(roots.center[b]), float(roots.radius[b])
            ):
                problems.append(f"verified discs {a} and {b} are not proven disjoint")
    if n and len(verified) == n:
        for k, t in enumerate(truth):
            if not any(inside[i][k] for i in verified):
                problems.append(f"true root {t.ball} (x{t.multiplicity}) lies in no disc although all are verified")
    return problems
