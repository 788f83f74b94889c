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
    gives isolated roots with exact multiplicities; their float64 discs are
    grouped until proven disjoint (roots closer than double spacing become
    one cluster disc with their total count). The fallback's work is capped
    (``EXACT_MAX_DEGREE_BITS``); beyond the cap the double / double-double
    answer stands, honestly unverified where it was.
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
    #: The kernel that ran: "scalar" or the batched kernel's instruction set.
    kernel: str = "scalar"
    #: Rows answered by the batched kernel (the others by find_roots's path).
    lanes_kept: int = 0

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


#: Kernels of find_roots_batch: "auto" (the widest batched kernel this CPU
#: runs), "scalar" (find_roots row by row: the reference), or an instruction
#: set by name.
KERNELS: tuple[str, ...] = ("auto", "scalar", "sse2", "avx2", "avx512")
#: Largest degree with a batched kernel; rows of higher degree are solved row
#: by row as with kernel="scalar".
BATCH_MAX_DEGREE: int = _core.BATCH_MAX_DEGREE


def batch_kernel() -> str:
    """The instruction set of the batched kernel on this CPU ("avx512",
    "avx2" or "sse2"): what ``kernel="auto"`` runs."""
    return _core.batch_kernel()


def find_roots_batch(
    matrix: np.ndarray, method: str = "auto", kernel: str = "auto", radius: np.ndarray | None = None
) -> BatchRoots:
    """:func:`find_roots` for every row of an (N, n+1) array, in C++ with the
    GIL released. Returns :class:`BatchRoots` of shape (N, n). Raises
    ``ValueError`` naming the first bad row.

    Every row gets :func:`find_roots`'s contract (not necessarily the same
    discs). For degrees 1 to :data:`BATCH_MAX_DEGREE` (methods auto, smith
    and unverified) the rows go through a batched kernel first: 16
    polynomials at a time in the lanes of the CPU's vector registers
    (AVX-512, AVX2 or SSE2, chosen at run time), closed-form starts for
    degree <= 4, Aberth-Ehrlich, and Smith's discs with rigorous rounding
    bounds. A row is answered there only when all its discs are proven to
    hold one root each; every other row (clusters, multiple roots, exact
    zeros, subnormal or extreme coefficients, ...) is solved by
    :func:`find_roots`'s path with its escalation. ``kernel="scalar"`` skips
    the batched kernel (the reference). ``radius`` (optional, the matrix's
    shape): coefficient radii, row by row as :func:`find_roots`'s ``radius``
    (each row's discs hold for its whole family; no exact fallback for a row
    with a nonzero radius)."""
    _check_method(method)
    if kernel not in KERNELS:
        raise ValueError(f"unknown kernel {kernel!r}: expected one of {', '.join(KERNELS)}")
    mat = np.ascontiguousarray(np.asarray(matrix, dtype=np.float64))
    if mat.ndim != 2:
        raise ValueError(f"matrix must be 2-D (one polynomial per row), got shape {mat.shape}")
    rad = None
    if radius is not None:
        rad = np.ascontiguousarray(np.asarray(radius, dtype=np.float64))
        if rad.shape != mat.shape:
            raise ValueError(f"radius must have the matrix's shape {mat.shape}, got {rad.shape}")
    out = _core.find_roots_batch(mat, method, kernel, rad)
    batch = BatchRoots(
        out["center"], out["radius"], out["count"], out["verified"], out["real"],
        out["n_infinite"], out["escalation"], method, out["kernel"], int(out["lanes_kept"]),
    )
    if method == "auto":
        wants = out["wants_exact"] if rad is None else out["wants_exact"] & ~np.any(rad > 0, axis=1)
        for r in np.flatnonzero(wants):
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


#: Work cap of the exact fallback (it runs inside find_roots_batch's loop and
#: in render workers, so it must be bounded per polynomial): the largest
#: degree times coefficient bit size (of the integer polynomial after exact
#: power-of-two scaling) it accepts. Arb's isolation doubles its precision
#: until the roots separate, and the separation of the roots of an integer
#: polynomial is bounded below in terms of exactly these two numbers, so the
#: cap bounds the work (measured: at most ~2 s at the cap, on one core).
#: Beyond it the fallback gives up and the C++ answer (honestly unverified
#: where it was) stands.
EXACT_MAX_DEGREE_BITS: int = 1 << 17


def _scaled_exact_poly(values: list[float]):
    """The exact rational polynomial q(u) = p(2^e u) / lc, with e chosen from
    the end coefficients (roots of modulus ~1, fewer bits, as in the C++
    scaling), as (q, e). Its roots are those of p divided by 2^e exactly."""
    import flint

    lo = next(k for k, v in enumerate(values) if v != 0.0)
    n = len(values) - 1 - lo
    e = 0
    if n >= 1:
        e = round((math.frexp(abs(values[lo]))[1] - math.frexp(values[-1])[1]) / n)
    two = flint.fmpq(2)
    q = flint.fmpq_poly([flint.fmpq(*Fraction(v).as_integer_ratio()) * two ** (e * k) for k, v in enumerate(values)])
    return q / q[q.degree()], e


def _float_up(x) -> float:
    """A double >= the arb x (its upper bound, rounded to nearest, then one step up)."""
    return math.nextafter(float(x.upper()), math.inf)


def _exact_disjoint(a: tuple[float, float, float], b: tuple[float, float, float]) -> bool:
    """Closed discs (re, im, r) with double entries certainly disjoint, decided
    exactly in rationals (never rounded)."""
    from flint import fmpq

    if not all(math.isfinite(v) for v in (*a, *b)):
        return False  # nothing proven about an unbounded disc
    q = lambda v: fmpq(*float(v).as_integer_ratio())  # noqa: E731
    dx, dy, s = q(a[0]) - q(b[0]), q(a[1]) - q(b[1]), q(a[2]) + q(b[2])
    return dx * dx + dy * dy > s * s


def _enclosing_radius(center: tuple[float, float], ball) -> float:
    """A double >= sup |z - center| over the acb ball (so the closed disc
    D(center, result) contains the ball); inf when unbounded."""
    import flint

    gap = abs(ball - flint.acb(center[0], center[1]))
    r = _float_up(gap)
    return r if math.isfinite(r) else math.inf


def exact_roots(coeffs: np.ndarray) -> Roots | None:
    """The exact fallback: the roots of the exact rational polynomial,
    isolated by python-flint (``fmpq_poly.complex_roots``: isolating balls
    with exact multiplicities, real roots with an exactly zero imaginary
    part), turned into float64 discs. Returns None if the polynomial is
    constant after removing roots at infinity, or beyond the work cap
    EXACT_MAX_DEGREE_BITS.

    Rounding a ball's centre to a double enlarges its disc, possibly past a
    neighbouring root; so the discs are never trusted one by one. Every root
    lies in the disc of its own ball (a covering family, each member holding
    its root's multiplicity), and the discs are grouped until the groups'
    enclosures are pairwise disjoint, decided exactly in rationals: a group
    then holds exactly the roots of its members (a root lies in its own
    member's disc, which lies in its group's enclosure and in no other). A
    group of several members is an honest cluster disc (count > 1). A root
    whose centre is not a finite double leaves its group unverified, and the
    verified enclosures are proven to exclude its ball. ``real`` is claimed
    for a disc that holds a root flint proved real, or that is centred on the
    real axis with an odd count (p is real, so its non-real roots pair up
    inside a symmetric disc).
    """
    import flint

    values = [float(c) for c in coeffs]
    top = len(values) - 1
    while top >= 0 and values[top] == 0.0:
        top -= 1
    if top <= 0:
        return None
    n_infinite = len(values) - 1 - top
    values = values[: top + 1]
    old_prec = flint.ctx.prec
    try:
        flint.ctx.prec = 64
        q, e = _scaled_exact_poly(values)
        bits = max(int(abs(int(c))).bit_length() for c in (q * q.denom()).coeffs())
        if q.degree() * bits > EXACT_MAX_DEGREE_BITS:
            return None
        flint.ctx.prec = 128
        scale = flint.arb(flint.fmpq(2) ** e)
        balls = [(z * scale, int(mult)) for z, mult in q.complex_roots()]
        flint.ctx.prec = 256
        # Members: each ball's disc around its centre rounded to doubles.
        members = []
        for ball, mult in balls:
            re, im = float(ball.real.mid()), float(ball.imag.mid())
            if math.isfinite(re) and math.isfinite(im):
                r = _enclosing_radius((re, im), ball)
                members.append([re, im, r, mult, ball])
            else:
                members.append([re, im, math.inf, mult, ball])
        discs = _group_members(members)
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


def _group_members(members: list[list]) -> list[list]:
    """Groups member discs [re, im, r, mult, ball] (every root in its own
    member's disc) into enclosures proven pairwise disjoint; returns entries
    [center, radius, count, verified, real] (see exact_roots)."""
    finite = [m for m in members if math.isfinite(m[2])]
    lost = [m for m in members if not math.isfinite(m[2])]
    groups = [[m] for m in finite]

    def enclosure(group: list[list], on_axis: bool) -> tuple[float, float, float]:
        if len(group) == 1 and not on_axis:
            return group[0][0], group[0][1], group[0][2]
        re = math.fsum(m[0] for m in group) / len(group)
        im = 0.0 if on_axis else math.fsum(m[1] for m in group) / len(group)
        r = 0.0
        for m in group:
            r = max(r, _enclosing_radius((re, im), m[4]))
        return re, im, r

    # Merge until every pair of enclosures is proven disjoint.
    while True:
        encs = [enclosure(g, False) for g in groups]
        pair = next(
            ((a, b) for a in range(len(groups)) for b in range(a) if not _exact_disjoint(encs[a], encs[b])), None
        )
        if pair is None:
            break
        a, b = pair
        groups[b] += groups.pop(a)
    # A real-centred (symmetric) enclosure where it stays disjoint from the others.
    for i, g in enumerate(groups):
        count = sum(m[3] for m in g)
        if count % 2 == 1 and encs[i][1] != 0.0 and all(m[4].imag.contains(0) for m in g):
            sym = enclosure(g, True)
            if math.isfinite(sym[2]) and all(_exact_disjoint(sym, encs[j]) for j in range(len(groups)) if j != i):
                encs[i] = sym
    out = []
    for g, (re, im, r) in zip(groups, encs):
        count = sum(m[3] for m in g)
        ok = math.isfinite(r)
        if ok:
            import flint

            centre = flint.acb(re, im)
            ok = all(abs(m[4] - centre) > flint.arb(r) for m in lost)
        proven_real = any(m[4].imag.is_exact() and m[4].imag.is_zero() for m in g)
        out.append([complex(re, im), r, count, ok, ok and (proven_real or (im == 0.0 and count % 2 == 1))])
    for m in lost:
        out.append([complex(m[0], m[1]), math.inf, m[3], False, False])
    return out
