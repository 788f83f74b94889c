"""Independent ground truth for ``argand.core.find_roots``: nothing here calls
the root finder.

The truth is python-flint on the EXACT rational value of the float64
coefficients (``fmpq_poly``; exact-zero leading coefficients are roots at
infinity), whose ``complex_roots()`` gives isolating balls with exact
multiplicities. :func:`check_roots` compares every claim of a ``Roots``
object with that truth and returns the violations as readable strings
(an empty list means every claim holds):

* each verified disc ``D(center, radius)`` (closed) holds exactly ``count``
  roots with multiplicity; a root ball counts as inside when
  ``|ball - center|`` is certainly ``<= radius`` and as outside when it is
  certainly ``> radius``. Undecided pairs are retried with the truth computed
  at 256 and then 1024 bits; a pair still undecided after that is decided
  exactly when the root is rational or Gaussian-rational (a root lying exactly
  on a circle, e.g. the root 1 and D(1, 0)), otherwise it is a violation
  ("undecided");
* verified discs are pairwise disjoint: ``|c1 - c2| > r1 + r2`` in arb, and
  exactly in rationals when arb cannot tell (touching closed discs overlap);
* ``real`` only with ``verified``, and then a real root (a flint ball with an
  exactly zero imaginary part) lies in the disc;
* ``sum(count) + n_infinite == degree`` and ``n_infinite`` equals the number
  of exact-zero leading coefficients;
* when every entry is verified, every true root lies in some disc.

Centers and radii are used as the float64 values they are
(``flint.arb(float)`` is exact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import flint

PRECISIONS: tuple[int, ...] = (128, 256, 1024)


class Precision:
    """``with Precision(bits):`` sets ``flint.ctx.prec`` and restores it."""

    def __init__(self, bits: int) -> None:
        self.bits = bits

    def __enter__(self) -> None:
        self.old = flint.ctx.prec
        flint.ctx.prec = self.bits

    def __exit__(self, *exc: object) -> None:
        flint.ctx.prec = self.old


def exact_rational(x: float) -> flint.fmpq:
    """The exact value of a double as a rational."""
    return flint.fmpq(*float(x).as_integer_ratio())


@dataclass
class TrueRoot:
    ball: flint.acb  # an isolating ball around one distinct root
    multiplicity: int
    real: bool  # flint proved the root real: imaginary part exactly zero


@dataclass
class Truth:
    """The exact polynomial of float64 coefficients and its roots.

    Roots are computed lazily per precision and cached, so one Truth can check
    the answers of several methods on the same polynomial.
    """

    coeffs: list[float]
    poly: flint.fmpq_poly = field(init=False)
    n_infinite: int = field(init=False)
    degree: int = field(init=False)
    _roots: dict[int, list[TrueRoot]] = field(init=False, default_factory=dict)
    _exact: list[tuple[flint.fmpq, flint.fmpq]] | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        values = [float(c) for c in self.coeffs]
        if not values:
            raise ValueError("empty coefficient list")
        if not all(math.isfinite(v) for v in values):
            raise ValueError("non-finite coefficient")
        self.coeffs = values
        self.degree = len(values) - 1
        top = self.degree
        while top >= 0 and values[top] == 0.0:
            top -= 1
        if top < 0:
            raise ValueError("zero polynomial")
        self.n_infinite = self.degree - top
        self.poly = flint.fmpq_poly([exact_rational(v) for v in values[: top + 1]])

    @property
    def finite_degree(self) -> int:
        return self.degree - self.n_infinite

    def roots(self, prec: int = 128) -> list[TrueRoot]:
        """Isolating balls (relative accuracy >= prec bits) with multiplicities."""
        if prec not in self._roots:
            if self.poly.degree() < 1:
                self._roots[prec] = []
            else:
                with Precision(prec):
                    pairs = self.poly.complex_roots()
                self._roots[prec] = [
                    TrueRoot(ball, int(mult), bool(ball.imag.is_exact() and ball.imag.is_zero()))
                    for ball, mult in pairs
                ]
            total = sum(t.multiplicity for t in self._roots[prec])
            assert total == self.finite_degree, (total, self.finite_degree)
        return self._roots[prec]

    def exact_roots(self) -> list[tuple[flint.fmpq, flint.fmpq]]:
        """The roots known in closed form: rational roots (linear factors over
        Q) and Gaussian-rational roots (quadratic factors with a rational
        square root of the discriminant), as exact (re, im) pairs."""
        if self._exact is None:
            out: list[tuple[flint.fmpq, flint.fmpq]] = []
            zero = flint.fmpq(0)
            if self.poly.degree() >= 1:
                _, factors = self.poly.factor()
                for f, _mult in factors:
                    if f.degree() == 1:
                        out.append((-f[0] / f[1], zero))
                    elif f.degree() == 2:
                        a, b, c = f[2], f[1], f[0]
                        disc = b * b - 4 * a * c  # < 0 for a complex pair
                        if disc < 0:
                            root = _rational_sqrt(-disc)
                            if root is not None:
                                re, im = -b / (2 * a), root / (2 * a)
                                out += [(re, im), (re, -im)]
            self._exact = out
        return self._exact


def _rational_sqrt(q: flint.fmpq) -> flint.fmpq | None:
    p, d = int(q.p), int(q.q)
    sp, sd = math.isqrt(p), math.isqrt(d)
    if sp * sp == p and sd * sd == d:
        return flint.fmpq(sp, sd)
    return None


def _membership(root: TrueRoot, center: complex, radius: float, prec: int) -> bool | None:
    """True / False when the root is certainly inside / outside the closed
    disc, None when undecided at this precision."""
    with Precision(prec):
        dist = abs(root.ball - flint.acb(center.real, center.imag))
        r = flint.arb(radius)
        if dist <= r:
            return True
        if dist > r:
            return False
        return None


def _exact_membership(
    truth: Truth, roots: list[TrueRoot], k: int, center: complex, radius: float
) -> bool | None:
    """Decide root k exactly if it is one of the closed-form roots."""
    for re, im in truth.exact_roots():
        with Precision(2048):
            enclosure = flint.acb(flint.arb(re), flint.arb(im))
        hits = [j for j, t in enumerate(roots) if t.ball.overlaps(enclosure)]
        if hits == [k]:
            dx = re - exact_rational(center.real)
            dy = im - exact_rational(center.imag)
            r = exact_rational(radius)
            return dx * dx + dy * dy <= r * r
    return None


def _disjoint(c1: complex, r1: float, c2: complex, r2: float) -> bool:
    """Closed discs certainly disjoint: |c1 - c2| > r1 + r2 (exact)."""
    with Precision(128):
        dist = abs(flint.acb(c1.real, c1.imag) - flint.acb(c2.real, c2.imag))
        rsum = flint.arb(r1) + flint.arb(r2)
        if dist > rsum:
            return True
        if dist <= rsum:
            return False
    # arb cannot tell (touching discs, or exponents far apart): exact rationals.
    dx = exact_rational(c1.real) - exact_rational(c2.real)
    dy = exact_rational(c1.imag) - exact_rational(c2.imag)
    s = exact_rational(r1) + exact_rational(r2)
    return dx * dx + dy * dy > s * s


def _disc(center: complex, radius: float) -> str:
    return f"D({center!r}, {radius!r})"


def check_roots(coeffs: Sequence[float], roots, truth: Truth | None = None) -> list[str]:
    """Every violation of the contract by ``roots`` (an ``argand.core.Roots``)
    for the polynomial ``coeffs`` (lowest degree first), as readable strings;
    empty when every claim holds. ``truth`` may be passed to reuse the exact
    roots across several answers for the same coefficients."""
    if truth is None:
        truth = Truth(list(coeffs))
    problems: list[str] = []
    degree = truth.degree

    center = [complex(c) for c in roots.center]
    radius = [float(r) for r in roots.radius]
    count = [int(c) for c in roots.count]
    verified = [bool(v) for v in roots.verified]
    real = [bool(v) for v in roots.real]
    n = len(center)
    if not (len(radius) == len(count) == len(verified) == len(real) == n):
        return [f"arrays of unequal length: {len(center)}, {len(radius)}, {len(count)}, {len(verified)}, {len(real)}"]

    # Bookkeeping claims that hold for every entry.
    if int(roots.n_infinite) != truth.n_infinite:
        problems.append(f"n_infinite {int(roots.n_infinite)} != {truth.n_infinite} exact-zero leading coefficients")
    if sum(count) + int(roots.n_infinite) != degree:
        problems.append(f"sum(count) + n_infinite = {sum(count)} + {int(roots.n_infinite)} != degree {degree}")
    if int(roots.degree) != degree:
        problems.append(f"Roots.degree {int(roots.degree)} != declared degree {degree}")
    for i in range(n):
        if real[i] and not verified[i]:
            problems.append(f"entry {i}: real claimed without verified")

    checked: list[int] = []
    for i in range(n):
        if not verified[i]:
            continue
        if not (math.isfinite(center[i].real) and math.isfinite(center[i].imag)):
            problems.append(f"verified disc {i} has a non-finite center {center[i]!r}")
        elif not (math.isfinite(radius[i]) and radius[i] >= 0.0):
            problems.append(f"verified disc {i} has an invalid radius {radius[i]!r}")
        elif count[i] < 0:
            problems.append(f"verified disc {i} has a negative count {count[i]}")
        else:
            checked.append(i)

    # Membership of every true root in every verified disc, with certainty.
    inside: dict[int, list[bool | None]] = {}
    true_roots: list[TrueRoot] = []
    for prec in PRECISIONS:
        true_roots = truth.roots(prec)
        inside = {
            i: [_membership(t, center[i], radius[i], prec + 64) for t in true_roots] for i in checked
        }
        if all(v is not None for row in inside.values() for v in row):
            break
    for i in checked:
        for k, v in enumerate(inside[i]):
            if v is None:
                inside[i][k] = _exact_membership(truth, true_roots, k, center[i], radius[i])
            if inside[i][k] is None:
                problems.append(
                    f"undecided: true root {true_roots[k].ball} vs verified disc {i} "
                    f"{_disc(center[i], radius[i])} even at {PRECISIONS[-1]} bits"
                )

    for i in checked:
        held = sum(t.multiplicity for t, v in zip(true_roots, inside[i]) if v)
        if any(v is None for v in inside[i]):
            continue  # already reported as undecided
        if held != count[i]:
            problems.append(
                f"verified disc {i} {_disc(center[i], radius[i])} claims {count[i]} roots, holds {held}"
            )
        if real[i] and not any(v and t.real for t, v in zip(true_roots, inside[i])):
            problems.append(f"disc {i} {_disc(center[i], radius[i])} claims a real root and holds none")

    for x in range(len(checked)):
        for y in range(x):
            a, b = checked[x], checked[y]
            if not _disjoint(center[a], radius[a], center[b], radius[b]):
                problems.append(
                    f"verified discs {b} {_disc(center[b], radius[b])} and {a} "
                    f"{_disc(center[a], radius[a])} are not disjoint"
                )

    if n and all(verified) and len(checked) == n:
        for k, t in enumerate(true_roots):
            if any(inside[i][k] is None for i in checked):
                continue  # already reported as undecided
            if not any(inside[i][k] for i in checked):
                problems.append(f"true root {t.ball} (x{t.multiplicity}) lies in no disc although all are verified")
    return problems


def check_members(members: Sequence[Sequence[float]], roots, label: str) -> list[str]:
    """check_roots for each member of a row's family (polynomials whose
    coefficients lie within the row's radii): the row's discs hold the roots
    of every member. A member of another degree (a leading coefficient
    inside its radius, zero) has roots the discs cannot count: then nothing
    may be verified."""
    problems: list[str] = []
    for q in members:
        truth = Truth(q)
        if truth.n_infinite != roots.n_infinite:
            if roots.verified.any():
                problems.append(f"{label}: member {q} of another degree, yet verified")
            continue
        problems += [f"{label} member {q}: {p}" for p in check_roots(q, roots, truth)]
    return problems


def reproducer(coeffs: Sequence[float], method: str) -> str:
    """A one-line reproducer: exact coefficients as float.hex()."""
    hexes = ", ".join(f"float.fromhex({float(c).hex()!r})" for c in coeffs)
    return f"find_roots([{hexes}], method={method!r})"
