"""The exact tier of the pixel ladder (level 5): a pixel decided on the exact
rational ray polynomial of its ray.

The C++ renderer calls :func:`decide_pixel` (through the binding, with the
GIL taken for the call) for a primary ray whose decision is still not proven
after the double-double tier, at most ``exact_pixels_per_block`` times per
8x8 block of samples. Everything here is exact or rigorous:

1. **The exact ray polynomial.** Every double at its exact rational value
   (``flint.fmpq``): the ray's origin and direction (the doubles the renderer
   casts, :func:`argand.render.primary_ray`), the object's ``linear`` and
   ``translate``, the surface's coefficients. ``o' = L (o - T)``,
   ``d' = L d`` and ``p(t) = F(o' + t d')`` are expanded in ``fmpq_poly``.
2. **Roots with proven multiplicities.** ``p = 0`` identically: the ray lies
   in the surface (status 1, proven). An exact factor ``t^m`` (the camera on
   the surface) is divided out: roots at ``t = 0`` are not shown. The rest
   is factored squarefree, ``p = c prod f_m^m`` (``f_m`` coprime and
   squarefree, so each root of ``f_m`` has multiplicity exactly ``m``:
   ``m > 1`` means ``gcd(p, p')`` vanishes there). Each ``f_m``'s roots are
   isolated with arb (``complex_roots``: disjoint balls of one root each,
   real roots with an exactly zero imaginary part, so realness is proven).
3. **Decisions in ball arithmetic**, at rising precision (64 bits, doubled
   up to ``max_bits``) while one is open: the band ``|arg t|`` in
   ``[sigma, sigma + delta]`` with the exact edges (a positive real root has
   argument exactly 0, a negative one exactly pi), the closed clipping ball
   ``|o' + |t| d'| <= clip_radius`` (a real root exactly on the sphere is
   found exactly: it is a root of ``gcd(f_m, |o' + |t| d'|^2 - R^2)``), and
   the least modulus among the
   eligible roots (a root's conjugate is the same choice).

The answer (a dict the binding reads): ``decided`` True is a proof: status 0
(a hit on ``re + i im`` of object ``object``, or a miss), or status 1 with
``multiple`` True (the pixel's root is a proven multiple root: a tangent ray
or a singular line; or the ray lies in the surface). ``decided`` False: the
precision cap left a comparison open (status 3; ``reason`` names it: a root
on a band edge or on the clipping sphere, or a modulus tie, within
``2^-max_bits``).

This module is the product's; ``tests/helpers/pixel_truth.py`` is an independent
checker written separately, and neither imports the other.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any


class _Flint:
    """python-flint, imported when the exact tier first decides a pixel: most
    frames send it none, and the import costs a process about 25 ms of CPU
    (`argand render` of one frame, docs/benchmarks.md). The first use puts
    the module itself in its place."""

    def __getattr__(self, name: str) -> Any:
        global flint
        import flint as module

        flint = module
        return getattr(module, name)


flint: Any = _Flint()

#: First working precision of the exact tier (bits); doubled up to the
#: frame's ``exact_max_bits``.
START_BITS = 64

# python-flint's precision is global: exact pixels run one at a time (they
# hold the GIL anyway), and restore it.
_LOCK = threading.Lock()

YES, NO, OPEN = "yes", "no", "open"


def exact_rational(x: float) -> flint.fmpq:
    """The exact value of a finite double."""
    n, d = float(x).as_integer_ratio()
    return flint.fmpq(n, d)


@dataclass
class ExactObject:
    """One object's data as exact rationals (built once per frame)."""

    terms: list[tuple[int, int, int, flint.fmpq]]
    degree: int
    complex_space: bool
    clip_radius: flint.fmpq | None  # None: no clipping sphere
    linear: list[flint.fmpq]
    translate: list[flint.fmpq]


def _objects(frame: dict) -> list[ExactObject]:
    """The frame's objects in rationals, cached in the frame dict (the binding
    builds it once per tile)."""
    cached = frame.get("_exact_objects")
    if cached is None:
        cached = []
        for o in frame["objects"]:
            clip = float(o["clip_radius"])
            cached.append(ExactObject(
                terms=[(int(a), int(b), int(c), exact_rational(v)) for a, b, c, v in o["terms"] if v != 0.0],
                degree=int(o["degree"]),
                complex_space=bool(o["complex"]),
                clip_radius=exact_rational(clip) if clip > 0.0 else None,
                linear=[exact_rational(v) for v in o["linear"]],
                translate=[exact_rational(v) for v in o["translate"]],
            ))
        frame["_exact_objects"] = cached
    return cached


def object_ray(obj: ExactObject, origin, direction) -> tuple[list[flint.fmpq], list[flint.fmpq]]:
    """o' = L (o - T) and d' = L d, exactly."""
    o = [exact_rational(origin[a]) - obj.translate[a] for a in range(3)]
    d = [exact_rational(direction[a]) for a in range(3)]
    L = obj.linear
    o_obj = [L[3 * r] * o[0] + L[3 * r + 1] * o[1] + L[3 * r + 2] * o[2] for r in range(3)]
    d_obj = [L[3 * r] * d[0] + L[3 * r + 1] * d[1] + L[3 * r + 2] * d[2] for r in range(3)]
    return o_obj, d_obj


def ray_polynomial(obj: ExactObject, o_obj, d_obj) -> flint.fmpq_poly:
    """p(t) = F(o' + t d') in exact rationals."""
    powers = []
    for a in range(3):
        line = flint.fmpq_poly([o_obj[a], d_obj[a]])
        pw = [flint.fmpq_poly([1])]
        for _ in range(obj.degree):
            pw.append(pw[-1] * line)
        powers.append(pw)
    p = flint.fmpq_poly([])
    for ex, ey, ez, c in obj.terms:
        p += c * (powers[0][ex] * powers[1][ey] * powers[2][ez])
    return p


@dataclass
class ExactRoot:
    object: int
    factor: int          # index into the object's squarefree factors
    multiplicity: int
    ball: Any = None     # acb at the current precision
    band: str = OPEN
    clip: str = OPEN
    modulus: Any = None  # arb


@dataclass
class ObjectPolynomial:
    object: int
    poly: flint.fmpq_poly
    at_origin: int                                 # multiplicity of the exact root t = 0
    factors: list[tuple[flint.fmpq_poly, int]]     # squarefree: (f_m, m)
    o_obj: list[flint.fmpq]
    d_obj: list[flint.fmpq]


def _band(root: ExactRoot, obj: ExactObject, sigma: flint.arb, delta: flint.arb, sigma_zero: bool) -> str:
    z = root.ball
    real = z.imag.is_zero()
    if real:
        if z.real > 0:
            # arg t = 0 exactly: in the band iff sigma = 0 (a real object
            # shows its positive real roots at every band).
            return YES if sigma_zero or not obj.complex_space else NO
        if z.real < 0:
            # arg t = pi exactly: in the band iff sigma + delta >= pi (a real
            # object never shows it).
            if not obj.complex_space:
                return NO
            gap = flint.arb.pi() - sigma - delta
            return NO if gap > 0 else (YES if gap <= 0 else OPEN)
        return OPEN  # (t = 0 was divided out: not reached)
    if not obj.complex_space:
        return NO if (z.imag > 0 or z.imag < 0) else OPEN
    # A nonreal root: |arg t| in (0, pi); the ball must be off the axis.
    if z.imag > 0:
        theta = z.arg()
    elif z.imag < 0:
        theta = z.conjugate().arg()
    else:
        return OPEN
    lower = theta - sigma
    upper = theta - sigma - delta
    if lower < 0 or upper > 0:
        return NO
    if lower >= 0 and upper <= 0:
        return YES
    return OPEN


def _clip(root: ExactRoot, obj: ExactObject, poly: ObjectPolynomial) -> str:
    if obj.clip_radius is None:
        return YES
    s = root.modulus
    q = -flint.arb(obj.clip_radius) ** 2
    for a in range(3):
        v = flint.arb(poly.o_obj[a]) + s * flint.arb(poly.d_obj[a])
        q += v * v
    if q < 0:
        return YES
    if q > 0:
        return NO
    if q.is_zero():
        return YES  # on the sphere exactly (the closed ball)
    return OPEN


def _on_sphere_exactly(root: ExactRoot, roots: list[ExactRoot], obj: ExactObject, poly: ObjectPolynomial) -> bool:
    """For a real root t: True iff its point is exactly on the clipping sphere,
    decided exactly: t is a root of gcd(f, q) with f its squarefree factor
    and q(t) = |o' + |t| d'|^2 - R^2 (|t| = t or -t by t's proven sign). The
    roots of the gcd are roots of f; one lies in t's ball (and in no other
    ball of f) only if it is t."""
    z = root.ball
    if not z.imag.is_zero() or obj.clip_radius is None:
        return False
    sign = 1 if z.real > 0 else (-1 if z.real < 0 else 0)
    if sign == 0:
        return False
    q = flint.fmpq_poly([-obj.clip_radius ** 2])
    for a in range(3):
        line = flint.fmpq_poly([poly.o_obj[a], sign * poly.d_obj[a]])
        q += line * line
    f = poly.factors[root.factor][0]
    g = f.gcd(q)
    if g.degree() < 1:
        return False
    same_factor = [r for r in roots if r.object == root.object and r.factor == root.factor]
    for b, _m in g.complex_roots():
        meeting = [r for r in same_factor if r.ball.overlaps(b)]
        if len(meeting) == 1 and meeting[0] is root:
            return True
    return False


def _conjugate_of(a: ExactRoot, b: ExactRoot, roots: list[ExactRoot]) -> bool:
    """True iff b is proven to be the conjugate of a: same object and factor,
    and b's ball is the only ball of that factor meeting a's mirror image (the
    conjugate of a's root, a root of the same factor, lies in one of them)."""
    if a.object != b.object or a.factor != b.factor or a is b:
        return False
    mirror = a.ball.conjugate()
    meeting = [r for r in roots if r.object == a.object and r.factor == a.factor and r.ball.overlaps(mirror)]
    return len(meeting) == 1 and meeting[0] is b


def _fmt(z) -> str:
    return f"{float(z.real.mid())!r}{float(z.imag.mid()):+.17g}i (radius {float(z.rad()):.2e})"


def decide_pixel(frame: dict, query: dict) -> dict:
    """The exact tier for one pixel: see the module's docstring. ``frame``:
    the objects (terms, degree, complex, clip_radius, linear, translate),
    sigma, delta and max_bits; ``query``: x, y, origin, direction, explain."""
    with _LOCK:
        saved = flint.ctx.prec
        try:
            return _decide(frame, query)
        finally:
            flint.ctx.prec = saved


def _answer(**kw) -> dict:
    out = {"decided": False, "status": 3, "multiple": False, "hit": False, "object": -1, "re": 0.0, "im": 0.0,
           "modulus": 0.0, "eligible": 0, "reason": "", "steps": []}
    out.update(kw)
    return out


#: What the exact tier computed for a ray, kept for the other bands of the
#: same frames (a sweep's, a grid's, a farm window's: they share rays, and a
#: pixel one band sends here the next band often does too). Only what does
#: not read σ or δ: the exact ray polynomials and their squarefree factors,
#: and each factor's root balls at each precision tried. Each is a function
#: of the objects and the ray alone (flint's answers are deterministic), so
#: a band takes what it would compute. Keyed by the frame's objects as
#: given (a 256-bit BLAKE2 digest of their exact repr) and the ray's
#: doubles; the last RAY_CACHE rays (an API process keeps them across band
#: requests too; some 5 KB a ray at degree 12).
RAY_CACHE = 2048
_rays: OrderedDict[tuple, "_SolvedRay"] = OrderedDict()


@dataclass
class _SolvedRay:
    polys: list[ObjectPolynomial]
    zero: int | None  # the first object whose exact ray polynomial is 0 (the ray lies in it), or None
    roots: dict[int, list[tuple[int, int, int, Any]]]  # bits -> (object, factor, multiplicity, ball)


def _objects_key(frame: dict) -> bytes:
    """The frame's objects, exactly (the repr of floats round-trips), as a
    digest cached in the frame dict: the same for every band of a set of
    frames."""
    key = frame.get("_objects_key")
    if key is None:
        import hashlib

        key = frame["_objects_key"] = hashlib.blake2b(repr(frame["objects"]).encode(), digest_size=32).digest()
    return key


def _solve_ray(objects: list[ExactObject], origin, direction) -> _SolvedRay:
    """Steps 1-2 for a ray: exact polynomials, t = 0 divided out, squarefree
    factors (stopping at an object whose polynomial is identically 0)."""
    polys: list[ObjectPolynomial] = []
    for i, obj in enumerate(objects):
        o_obj, d_obj = object_ray(obj, origin, direction)
        p = ray_polynomial(obj, o_obj, d_obj)
        if p == 0:
            return _SolvedRay(polys, i, {})
        m0 = 0
        coeffs = p.coeffs()
        while coeffs[m0] == 0:
            m0 += 1
        if m0:
            p = flint.fmpq_poly(coeffs[m0:])
        _content, factors = p.factor_squarefree() if p.degree() > 0 else (p, [])
        polys.append(ObjectPolynomial(i, p, m0, [(f, m) for f, m in factors], o_obj, d_obj))
    return _SolvedRay(polys, None, {})


def _ray(frame: dict, objects: list[ExactObject], origin, direction) -> _SolvedRay:
    key = (_objects_key(frame), tuple(float(v) for v in origin), tuple(float(v) for v in direction))
    solved = _rays.get(key)
    if solved is None:
        solved = _rays[key] = _solve_ray(objects, origin, direction)
        while len(_rays) > RAY_CACHE:
            _rays.popitem(last=False)
    else:
        _rays.move_to_end(key)
    return solved


def _decide(frame: dict, query: dict) -> dict:
    objects = _objects(frame)
    explain = bool(query.get("explain"))
    steps: list[str] = []
    origin, direction = query["origin"], query["direction"]
    sigma_d, delta_d = float(frame["sigma"]), float(frame["delta"])
    max_bits = int(frame["max_bits"])

    # 1-2: exact polynomials, t = 0 divided out, squarefree factors (once
    # per ray for every band: _ray).
    solved = _ray(frame, objects, origin, direction)
    polys = solved.polys
    if explain:
        for poly in polys:
            p, m0, factors = poly.poly, poly.at_origin, poly.factors
            steps.append(
                f"object {poly.object}: exact ray polynomial of degree {p.degree() + m0} (surface degree "
                f"{objects[poly.object].degree})"
                + (f", exact root t = 0 of multiplicity {m0} divided out (not shown)" if m0 else "")
                + "; squarefree factors: " + (", ".join(f"degree {f.degree()} with multiplicity {m}" for f, m in factors)
                                              or "none (no roots)"))
    if solved.zero is not None:
        i = solved.zero
        reason = f"object {i}: the exact ray polynomial is identically zero: the ray lies in the surface (proven)"
        steps.append(reason)
        return _answer(decided=True, status=1, multiple=True, reason=reason, steps=steps)
    sigma, delta = exact_rational(sigma_d), exact_rational(delta_d)
    sigma_zero = sigma_d == 0.0

    bits = START_BITS
    while True:
        flint.ctx.prec = bits
        found = solved.roots.get(bits)
        if found is None:  # (each factor's roots at this precision, once per ray)
            found = solved.roots[bits] = [(poly.object, k, m, ball) for poly in polys
                                          for k, (f, m) in enumerate(poly.factors) for ball, _one in f.complex_roots()]
        roots = [ExactRoot(obj_index, k, m, ball) for obj_index, k, m, ball in found]
        s_arb, d_arb = flint.arb(sigma), flint.arb(delta)
        for r in roots:
            obj = objects[r.object]
            r.band = _band(r, obj, s_arb, d_arb, sigma_zero)
            r.modulus = abs(r.ball)
            r.clip = _clip(r, obj, polys[r.object]) if r.band != NO else NO
        for r in roots:
            if r.clip == OPEN and _on_sphere_exactly(r, roots, objects[r.object], polys[r.object]):
                r.clip = YES  # on the sphere: inside the closed ball (proven)
        candidates = [r for r in roots if r.band != NO and r.clip != NO]
        eligible = [r for r in candidates if r.band == YES and r.clip == YES]
        open_ = [r for r in candidates if r not in eligible]
        # The chosen root: an eligible one proven nearer than every other
        # candidate, up to its conjugate.
        chosen, tie = None, None
        if eligible:
            best = min(eligible, key=lambda r: float(r.modulus.upper()))
            blockers = [r for r in candidates if r is not best and not (best.modulus < r.modulus)
                        and not _conjugate_of(best, r, roots)]
            if not blockers:
                chosen = best
            else:
                tie = blockers
        decided = (not candidates) or (chosen is not None)
        if explain:
            steps.append(f"{bits} bits: {len(roots)} distinct roots; "
                         + "; ".join(f"obj {r.object} {_fmt(r.ball)} mult {r.multiplicity} band {r.band} clip "
                                     f"{r.clip if r.band != NO else '-'}" for r in roots))
        if decided:
            break
        if bits * 2 > max_bits:
            # The precision cap: say which comparison is still open.
            why = []
            if any(r.band == OPEN for r in open_):
                why.append("a root on a band edge")
            if any(r.clip == OPEN for r in open_):
                why.append("a root on the clipping sphere")
            if tie:
                why.append("a modulus tie between different roots")
            reason = (f"exact tier: at {bits} bits (the cap) still open: {', '.join(why) or 'a comparison'} "
                      f"(within 2^-{bits})")
            steps.append(reason)
            return _answer(status=3, reason=reason, steps=steps)
        bits *= 2

    count = sum(r.multiplicity for r in eligible)
    if chosen is None:
        reason = f"exact tier at {bits} bits: every root proven out of the band or clipped: a miss (proven)"
        steps.append(reason)
        return _answer(decided=True, status=0, eligible=count, reason=reason, steps=steps)
    z = chosen.ball
    if z.imag < 0:
        z = z.conjugate()
    re, im = float(z.real.mid()), float(z.imag.mid())
    modulus = float(chosen.modulus.mid())
    if chosen.multiplicity > 1:
        reason = (f"exact tier at {bits} bits: the pixel's root {_fmt(z)} of object {chosen.object} is a root of "
                  f"multiplicity {chosen.multiplicity} (a squarefree factor of the exact polynomial: gcd(p, p') "
                  "vanishes there): the ray is tangent or meets a singular line (proven)")
        steps.append(reason)
        return _answer(decided=True, status=1, multiple=True, hit=True, object=chosen.object, re=re, im=im,
                       modulus=modulus, eligible=count, reason=reason, steps=steps)
    reason = (f"exact tier at {bits} bits: a hit on the simple root {_fmt(z)} of object {chosen.object}, in the band, "
              "inside the clipping ball, nearer than every other eligible root (proven)")
    steps.append(reason)
    return _answer(decided=True, status=0, hit=True, object=chosen.object, re=re, im=im, modulus=modulus,
                   eligible=count, reason=reason, steps=steps)
