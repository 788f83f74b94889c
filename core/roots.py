"""Verified complex roots: the Python face of the C++ core.

Contract (FLINT/Arb style; every promise below is tested against python-flint
at high precision on the exact rational value of the double coefficients):

* Input: real coefficients ``p_0 .. p_n`` (lowest degree first) as float64.
  Each double is taken at its exact value; nothing is rounded on the way in.
* ``verified[i]`` true: the closed disc ``D(center[i], radius[i])`` contains
  exactly ``count[i]`` roots of p, counted with multiplicity. ``count > 1``
  is a cluster or a multiple root reported as one disc. Verified discs are
  pairwise disjoint.
* ``real[i]`` true (only with ``verified``): the disc is proven to contain a
  real root.
* ``verified[i]`` false: ``center[i]`` is the best approximation available and
  ``radius[i]`` an error *estimate*; neither is proven.
* ``sum(count) + n_infinite == n`` always. When every entry is verified, the
  discs contain all the finite roots.
* Leading coefficients that are exactly zero are roots at infinity
  (``n_infinite``); a tiny nonzero one gives huge roots, and a root beyond the
  range of float64 comes back unverified with an infinite center.
* Exact zero constant terms give an exact verified disc ``D(0, 0)``.
* Degree 0 (a nonzero constant) has no roots: empty arrays.
* ``radius`` (optional, one finite radius >= 0 per coefficient) turns the
  input into a family of polynomials: every promise above then holds for
  EVERY real polynomial q with ``|q_k - coeffs[k]| <= radius[k]``. A
  coefficient is exactly zero only when its radius is 0 too; if the leading
  coefficient's interval contains 0, or a stripped zero has a radius,
  nothing is verified. The exact fallback (below) is for one exact
  polynomial, so it does not run when a radius is nonzero.
* NaN or infinite coefficients, the zero polynomial, an empty input or a
  degree above ``MAX_DEGREE`` raise ``ValueError`` with the reason.

Methods (``method=``):

``"auto"`` (default)
    Aberth-Ehrlich in double + Smith's discs; double-double only where double
    cannot isolate the roots; for the rare polynomials that still have a
    cluster or an unverified entry, the exact fallback: python-flint's
    ``fmpq_poly.complex_roots()`` on the exact rational coefficients, which
    gives isolated roots with exact multiplicities.
``"smith"``
    Aberth-Ehrlich + Smith's (1970) inclusion discs in double with rigorous
    rounding bounds; clusters get a count (components of k discs hold k roots);
    approximations of a cluster are re-spread as the paper's step 2(b) says.
``"paper"``
    The paper's AllCPolyZero: approximate a zero of the deflated polynomial,
    verify it on the original polynomial with Hammer et al.'s interval
    Newton/Krawczyk test on the companion eigenproblem, deflate, repeat;
    failures are retried in double-double (the paper's section 2.6).
``"unverified"``
    The approximations alone, nothing proven (the speed reference).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Sequence

import numpy as np

from argand.core import _core

METHODS: tuple[str, ...] = ("auto", "smith", "paper", "unverified")
MAX_DEGREE: int = _core.MAX_DEGREE


@dataclass(frozen=True)
class Roots:
    """Roots of one polynomial: arrays of equal length, one entry per disc."""

    center: np.ndarray  # complex128
    radius: np.ndarray  # float64
    count: np.ndarray  # int64
    verified: np.ndarray  # bool
    real: np.ndarray  # bool
    n_infinite: int = 0
    method: str = "auto"
    #: 0 = double, 1 = double-double, 2 = exact fallback (python-flint)
    escalation: int = 0
    degree: int = field(default=0)

    def __len__(self) -> int:
        return len(self.center)

    @property
    def all_verified(self) -> bool:
        """True iff every entry is verified (then the discs hold all roots)."""
        return bool(np.all(self.verified))


@dataclass(frozen=True)
class BatchRoots:
    """Roots of N polynomials of declared degree n: arrays of shape (N, n).

    Row r holds the discs of polynomial r first; the remaining entries of the
    row are padding with ``count == 0``, ``verified == False`` and NaN center
    and radius.
    """

    center: np.ndarray
    radius: np.ndarray
    count: np.ndarray
    verified: np.ndarray
    real: np.ndarray
    n_infinite: np.ndarray  # (N,)
    escalation: np.ndarray  # (N,)
    method: str = "auto"

    def row(self, r: int) -> Roots:
        """The roots of polynomial r, padding removed."""
        used = self.count[r] > 0
        return Roots(
            center=self.center[r][used],
            radius=self.radius[r][used],
            count=self.count[r][used],
            verified=self.verified[r][used],
            real=self.real[r][used],
            n_infinite=int(self.n_infinite[r]),
            method=self.method,
            escalation=int(self.escalation[r]),
            degree=self.center.shape[1],
        )

    @property
    def all_verified(self) -> np.ndarray:
        """(N,) bool: every entry of the row is verified."""
        return np.all(self.verified | (self.count == 0), axis=1)


def _check_method(method: str) -> None:
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")


def _as_coefficients(coeffs: Sequence[float] | np.ndarray) -> np.ndarray:
    try:
        arr = np.asarray(coeffs, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"coefficients must be real numbers, lowest degree first: {exc}") from None
    if arr.ndim != 1:
        raise ValueError(f"coefficients must be a 1-D sequence, got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError("coefficients must not be empty")
    return arr


def find_roots(
    coeffs: Sequence[float] | np.ndarray,
    method: str = "auto",
    initial: Sequence[complex] | np.ndarray | None = None,
    radius: Sequence[float] | np.ndarray | None = None,
) -> Roots:
    """All complex roots of ``p(t) = sum coeffs[k] t^k`` with proven discs.

    ``initial`` (optional, one complex value per root) seeds the approximation,
    for example with the roots of a neighbouring ray's polynomial; it changes
    speed only, never what is proven. See the module docstring for the full
    contract (``radius``: coefficient radii, a family of polynomials).
    """
    _check_method(method)
    arr = _as_coefficients(coeffs)
    rad = None
    if radius is not None:
        rad = _as_coefficients(radius)
        if rad.shape != arr.shape:
            raise ValueError(f"radius must have one entry per coefficient ({arr.size}), got {rad.size}")
    center, disc_radius, count, verified, real, n_inf, wants_exact, escalation = _core.find_roots(
        arr, method, None if initial is None else np.asarray(initial, dtype=np.complex128), rad
    )
    result = Roots(center, disc_radius, count, verified, real, int(n_inf), method, int(escalation), arr.size - 1)
    exact_polynomial = rad is None or not np.any(rad > 0)
    if method == "auto" and wants_exact and exact_polynomial:
        exact = exact_roots(arr)
        if exact is not None:
            return exact
    return result


def find_roots_batch(matrix: np.ndarray, method: str = "auto") -> BatchRoots:
    """:func:`find_roots` for every row of an (N, n+1) array, in C++ with the
    GIL released. Returns :class:`BatchRoots` of shape (N, n). Raises
    ``ValueError`` naming the first bad row."""
    _check_method(method)
    mat = np.ascontiguousarray(np.asarray(matrix, dtype=np.float64))
    if mat.ndim != 2:
        raise ValueError(f"matrix must be 2-D (one polynomial per row), got shape {mat.shape}")
    out = _core.find_roots_batch(mat, method)
    batch = BatchRoots(
        out["center"], out["radius"], out["count"], out["verified"], out["real"],
        out["n_infinite"], out["escalation"], method,
    )
    if method == "auto":
        for r in np.flatnonzero(out["wants_exact"]):
            exact = exact_roots(mat[r])
            if exact is None:
                continue
            k = len(exact)
            n = mat.shape[1] - 1
            batch.center[r, :k] = exact.center
            batch.radius[r, :k] = exact.radius
            batch.count[r, :k] = exact.count
            batch.verified[r, :k] = exact.verified
            batch.real[r, :k] = exact.real
            batch.center[r, k:n] = complex(math.nan, math.nan)
            batch.radius[r, k:n] = math.nan
            batch.count[r, k:n] = 0
            batch.verified[r, k:n] = False
            batch.real[r, k:n] = False
            batch.escalation[r] = 2
    return batch


def exact_roots(coeffs: np.ndarray) -> Roots | None:
    """The exact fallback: roots of the exact rational polynomial with
    python-flint (``fmpq_poly.complex_roots``: isolated balls with exact
    multiplicities), turned into float64 discs rounded outward. Returns None
    if the polynomial is constant after removing roots at infinity."""
    import flint

    top = len(coeffs) - 1
    while top >= 0 and coeffs[top] == 0.0:
        top -= 1
    if top <= 0:
        return None
    n_infinite = len(coeffs) - 1 - top
    poly = flint.fmpq_poly([flint.fmpq(*Fraction(float(c)).as_integer_ratio()) for c in coeffs[: top + 1]])
    old_prec = flint.ctx.prec
    try:
        flint.ctx.prec = 128
        pairs = poly.complex_roots()
        discs = []
        for ball, mult in pairs:
            re = float(ball.real.mid())
            im = float(ball.imag.mid())
            finite = math.isfinite(re) and math.isfinite(im)
            if finite:
                gap = abs(ball - flint.acb(re, im))  # arb enclosing |ball - center|
                rad = math.nextafter(float(gap.upper()), math.inf)
                ok = math.isfinite(rad)
            else:
                rad, ok = math.inf, False
            is_real = ok and ball.imag.is_exact() and ball.imag.is_zero()
            discs.append([complex(re, 0.0 if is_real else im), rad, int(mult), ok, is_real])
        # The float64 discs were inflated: re-prove pairwise disjointness.
        for i in range(len(discs)):
            for j in range(i):
                a, b = discs[i], discs[j]
                if not (a[3] and b[3]):
                    continue
                dist = abs(flint.acb(a[0].real, a[0].imag) - flint.acb(b[0].real, b[0].imag))
                if not (dist > flint.arb(a[1]) + flint.arb(b[1])):
                    a[3] = a[4] = False
                    b[3] = b[4] = False
    finally:
        flint.ctx.prec = old_prec
    discs.sort(key=lambda d: (d[0].real, d[0].imag))
    return Roots(
        center=np.array([d[0] for d in discs], dtype=np.complex128),
        radius=np.array([d[1] for d in discs], dtype=np.float64),
        count=np.array([d[2] for d in discs], dtype=np.int64),
        verified=np.array([d[3] for d in discs], dtype=bool),
        real=np.array([d[4] for d in discs], dtype=bool),
        n_infinite=n_infinite,
        method="auto",
        escalation=2,
        degree=len(coeffs) - 1,
    )
