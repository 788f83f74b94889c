"""Independent exact truth for a pixel: nothing here calls the renderer or
the root finder.

Given a scene (each object's terms, transform, clip radius and space), the
band (sigma, delta) and a pixel's ray as the exact doubles the renderer uses
(``argand.render.primary_ray``), :func:`pixel_truth` decides the pixel
exactly:

* every double is taken at its exact value (``flint.fmpq``); per object the
  ray is moved to object space exactly, ``o' = L (o - T)``, ``d' = L d``
  (``L``, ``T`` the object's ``linear`` and ``translate`` doubles), and the
  ray polynomial ``p(t) = F(o' + t d')`` is expanded in rationals
  (``fmpq_poly``), each term coefficient at its exact double value;
* its roots come from ``fmpq_poly.complex_roots`` (isolating balls, exact
  multiplicities, real roots with an exactly zero imaginary part), at 128
  bits and more when a decision needs it;
* a root ``t = rho e^{i theta}`` is **eligible** when theta, taken modulo
  2 pi, lies in the closed band ``[sigma, sigma + delta]`` or its conjugate
  ``[-sigma - delta, -sigma]`` (the band edges are the exact reals sigma and
  sigma + delta); a real root has theta exactly 0 (t > 0) or pi (t < 0). An
  object with ``space: real`` shows only its positive real roots;
* a root is **kept** when its hit point lies in the closed clipping ball,
  ``|o' + |t| d'| <= clip_radius`` (object space; no ball when the radius is
  <= 0). Roots at ``t = 0`` exactly (``F(o') = 0``) are excluded;
* the pixel **hits** when some root of some object is eligible and kept; it
  shows the eligible kept root of least modulus (a root and its conjugate are
  the same choice).

The answer is ``"hit"`` (with the chosen root), ``"miss"``, or
``"degenerate"`` when the truth itself sits on a decision boundary and no
precision separates it: a modulus tie between two different chosen
candidates, a root on the clipping sphere, a ray that lies in a surface (p
identically zero), or a comparison still open at the highest precision
(``reasons`` says which). A degenerate pixel may still know that it hits
(``hit`` is True when some candidate is certainly eligible and kept).

:func:`check_pixel` compares what the renderer says of a pixel with the
truth and returns the contradictions of a certified (status 0) pixel as
readable strings, like ``tests/truth.py`` does for discs.

Run as a script, it checks sampled pixels of a scene against this truth::

    .venv/bin/python tests/pixel_truth.py bicube --size 129x129 -n 2000
    .venv/bin/python tests/pixel_truth.py random:8:3 --delta 0.1 -n 500
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import flint

#: Working precisions (bits) of the root balls, tried in order until every
#: decision of the pixel is certain.
PRECISIONS: tuple[int, ...] = (128, 512, 2048, 8192)

#: The AOVs are float32: a root read back from them is within half an ulp
#: of float32 per component, plus the (tiny) radius of a certified disc.
AOV_RELATIVE_TOLERANCE = 2.0**-21


class _Prec:
    """``with _Prec(bits):`` sets ``flint.ctx.prec`` and restores it."""

    def __init__(self, bits: int) -> None:
        self.bits = bits

    def __enter__(self) -> None:
        self.old = flint.ctx.prec
        flint.ctx.prec = self.bits

    def __exit__(self, *exc: object) -> None:
        flint.ctx.prec = self.old


def exact(x: float) -> flint.fmpq:
    """The exact value of a finite double as a rational."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"not a finite number: {x!r}")
    return flint.fmpq(*x.as_integer_ratio())


# ---------------------------------------------------------------------------
# The scene, exactly
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class TruthObject:
    """One object of the scene with every double at its exact value."""

    terms: tuple[tuple[int, int, int, flint.fmpq], ...]
    complex_space: bool
    clip_radius: flint.fmpq | None  # None: no clipping ball
    linear: tuple[tuple[flint.fmpq, ...], ...]  # 3x3, object = linear (world - translate)
    translate: tuple[flint.fmpq, ...]


def scene_objects(scene: Any) -> list[TruthObject]:
    """The objects of a scene (an ``argand.scene.Scene`` or the core dict the
    renderer plans from), exactly."""
    if not (isinstance(scene, dict) and "objects" in scene):
        from argand.render.convert import to_core_scene  # the scene's doubles, as the renderer gets them

        scene = to_core_scene(scene)
    out = []
    for obj in scene["objects"]:
        linear = [exact(v) for v in obj.get("linear", [1, 0, 0, 0, 1, 0, 0, 0, 1])]
        clip = float(obj.get("clip_radius", 0.0) or 0.0)
        out.append(
            TruthObject(
                terms=tuple((int(i), int(j), int(k), exact(c)) for i, j, k, c in obj["terms"]),
                complex_space=bool(obj.get("complex", True)),
                clip_radius=exact(clip) if clip > 0 else None,
                linear=tuple(tuple(linear[3 * r : 3 * r + 3]) for r in range(3)),
                translate=tuple(exact(v) for v in obj.get("translate", [0, 0, 0])),
            )
        )
    return out


def object_ray(obj: TruthObject, origin: Sequence[float], direction: Sequence[float]):
    """(o', d'): the ray in the object's space, exactly."""
    o = [exact(v) - t for v, t in zip(origin, obj.translate)]
    d = [exact(v) for v in direction]
    oo = tuple(sum((row[c] * o[c] for c in range(3)), flint.fmpq(0)) for row in obj.linear)
    od = tuple(sum((row[c] * d[c] for c in range(3)), flint.fmpq(0)) for row in obj.linear)
    return oo, od


def ray_polynomial(obj: TruthObject, oo: Sequence[flint.fmpq], od: Sequence[flint.fmpq]) -> flint.fmpq_poly:
    """p(t) = F(o' + t d') in rationals."""
    top = max((i + j + k for i, j, k, _ in obj.terms), default=0)
    powers = []
    for axis in range(3):
        line = flint.fmpq_poly([oo[axis], od[axis]])
        row = [flint.fmpq_poly([1])]
        for _ in range(top):
            row.append(row[-1] * line)
        powers.append(row)
    p = flint.fmpq_poly([])
    for i, j, k, c in obj.terms:
        p += powers[0][i] * powers[1][j] * powers[2][k] * c
    return p


# ---------------------------------------------------------------------------
# The decision
# ---------------------------------------------------------------------------


@dataclass
class TruthRoot:
    """A root of one object's ray polynomial, up to conjugation (the
    representative with imaginary part >= 0)."""

    object: int
    ball: flint.acb
    multiplicity: int
    real: bool
    modulus: flint.arb
    eligible: bool | None  # None: undecided at this precision
    kept: bool | None  # inside the clipping ball; None: undecided

    @property
    def candidate(self) -> bool | None:
        if self.eligible is False or self.kept is False:
            return False
        if self.eligible and self.kept:
            return True
        return None


@dataclass
class PixelTruth:
    decision: str  # "hit", "miss" or "degenerate"
    hit: bool | None  # None only when degenerate and no candidate is certain
    root: TruthRoot | None  # the chosen root on a hit
    roots: list[TruthRoot]  # every root of every object (one of each conjugate pair)
    polynomials: list[flint.fmpq_poly]
    reasons: list[str] = field(default_factory=list)
    prec: int = 0

    def describe(self) -> str:
        if self.decision == "hit":
            r = self.root
            return f"hit object {r.object} at t = {r.ball} (x{r.multiplicity}, |t| = {r.modulus})"
        if self.decision == "miss":
            return "miss"
        return f"degenerate (hit {self.hit}): " + "; ".join(self.reasons)


def _in_band(theta: flint.arb, lo: flint.fmpq, hi: flint.fmpq, exact_theta: flint.fmpq | None) -> bool | None:
    """theta (mod 2 pi) in the closed interval [lo, hi]? None: undecided.
    ``exact_theta`` is theta when it is exactly rational (0), so the k = 0
    comparison is exact."""
    two_pi = 2 * flint.arb.pi()
    if hi - lo >= 7:  # longer than 2 pi: every angle is in
        return True
    k_lo = math.floor(float(lo) / (2 * math.pi)) - 1
    k_hi = math.ceil(float(hi) / (2 * math.pi)) + 1
    undecided = False
    for k in range(k_lo, k_hi + 1):
        if k == 0 and exact_theta is not None:
            if lo <= exact_theta <= hi:
                return True
            continue
        value = theta + k * two_pi
        if value >= flint.arb(lo) and value <= flint.arb(hi):
            return True
        if not (value < flint.arb(lo) or value > flint.arb(hi)):
            undecided = True
    return None if undecided else False


def _eligible(root_ball: flint.acb, real: bool, complex_space: bool, sigma: flint.fmpq, top: flint.fmpq) -> bool | None:
    if real:
        if not (root_ball.real > 0 or root_ball.real < 0):
            return None  # t = 0 is excluded, so more precision separates it
        positive = bool(root_ball.real > 0)
        if not complex_space:
            return positive
        theta = flint.arb(0) if positive else flint.arb.pi()
        exact_theta = flint.fmpq(0) if positive else None
    else:
        if not complex_space:
            return False
        theta = root_ball.arg()
        exact_theta = None
    answers = [_in_band(theta, sigma, top, exact_theta), _in_band(theta, -top, -sigma, exact_theta)]
    if True in answers:
        return True
    if None in answers:
        return None
    return False


def _rational_root(poly: flint.fmpq_poly, ball: flint.acb) -> flint.fmpq | None:
    """The root in ``ball`` when it is rational (a linear factor of poly)."""
    _, factors = poly.factor()
    for f, _mult in factors:
        if f.degree() == 1:
            r = -f[0] / f[1]
            if ball.real.overlaps(flint.arb(r)):
                return r
    return None


def _kept(obj: TruthObject, oo, od, root: TruthRoot, poly: flint.fmpq_poly, last: bool) -> bool | None:
    """|o' + rho d'| <= R, i.e. |o'|^2 - R^2 + rho (2 o'.d' + rho |d'|^2) <= 0."""
    if obj.clip_radius is None:
        return True
    a = sum((v * v for v in oo), flint.fmpq(0)) - obj.clip_radius * obj.clip_radius
    b = 2 * sum((u * v for u, v in zip(oo, od)), flint.fmpq(0))
    c = sum((v * v for v in od), flint.fmpq(0))
    rho = root.modulus
    f = flint.arb(a) + rho * (flint.arb(b) + rho * flint.arb(c))
    if f <= 0:
        return True
    if f > 0:
        return False
    if last and root.real:
        r = _rational_root(poly, root.ball)
        if r is not None:
            rho_q = r if r > 0 else -r
            return a + rho_q * (b + rho_q * c) <= 0
    return None


def _roots_at(poly: flint.fmpq_poly, prec: int) -> list[tuple[flint.acb, int]] | None:
    with _Prec(prec):
        pairs = poly.complex_roots()
    total = sum(int(m) for _, m in pairs)
    assert total == poly.degree(), (total, poly.degree())
    return [(ball, int(m)) for ball, m in pairs]


def pixel_truth(
    scene: Any, sigma: float, delta: float, origin: Sequence[float], direction: Sequence[float],
    objects: list[TruthObject] | None = None,
) -> PixelTruth:
    """The exact decision for the ray ``origin + t direction`` (doubles, taken
    exactly) in ``scene`` with the band (sigma, delta). ``objects`` may pass
    :func:`scene_objects` of the scene to reuse it across pixels."""
    if objects is None:
        objects = scene_objects(scene)
    s, top = exact(sigma), exact(sigma) + exact(delta)
    polys: list[flint.fmpq_poly] = []
    rays = []
    reasons: list[str] = []
    for index, obj in enumerate(objects):
        oo, od = object_ray(obj, origin, direction)
        p = ray_polynomial(obj, oo, od)
        rays.append((oo, od))
        if p.degree() < 0:
            reasons.append(f"the ray lies in the surface of object {index} (p is identically zero)")
        # Roots at t = 0 exactly are excluded (the camera sits on the surface).
        while p.degree() > 0 and p[0] == 0:
            p = flint.fmpq_poly(p.coeffs()[1:])
        polys.append(p)
    if reasons:
        return PixelTruth("degenerate", None, None, [], polys, reasons)

    roots: list[TruthRoot] = []
    for prec in PRECISIONS:
        last = prec == PRECISIONS[-1]
        with _Prec(prec):
            roots = []
            unsure_half = False
            for index, (obj, p, (oo, od)) in enumerate(zip(objects, polys, rays)):
                if p.degree() < 1:
                    continue
                for ball, mult in _roots_at(p, prec):
                    real = bool(ball.imag.is_exact() and ball.imag.is_zero())
                    if not real:
                        if ball.imag < 0:
                            continue  # the conjugate of a root kept below
                        if not ball.imag > 0:
                            unsure_half = True
                            continue
                    root = TruthRoot(index, ball, mult, real, abs(ball), None, None)
                    root.eligible = _eligible(ball, real, obj.complex_space, s, top)
                    root.kept = _kept(obj, oo, od, root, p, last)
                    roots.append(root)
            if unsure_half:
                if last:
                    return PixelTruth("degenerate", None, None, roots, polys, ["a root's half plane is undecided"], prec)
                continue
            answer = _choose(roots, last)
            if answer is not None:
                answer.polynomials = polys
                answer.prec = prec
                return answer
    raise AssertionError("unreachable: the last precision always answers")


def _choose(roots: list[TruthRoot], last: bool) -> PixelTruth | None:
    """The pixel's answer from the roots' flags; None when the flags at this
    precision do not decide it (and it is not the last precision)."""
    sure = [r for r in roots if r.candidate is True]
    open_ = [r for r in roots if r.candidate is None]
    if not sure and not open_:
        return PixelTruth("miss", False, None, roots, [])
    # The chosen root: a sure candidate whose modulus is certainly below
    # every other sure or open candidate's.
    for r in sure:
        others = [q for q in sure + open_ if q is not r]
        if all(r.modulus < q.modulus for q in others):
            return PixelTruth("hit", True, r, roots, [])
    if not last:
        return None
    reasons = []
    for r in open_:
        what = "band membership" if r.eligible is None else "clipping sphere"
        reasons.append(f"{what} of root {r.ball} of object {r.object} undecided")
    for i, r in enumerate(sure):
        for q in sure[i + 1 :]:
            if not (r.modulus < q.modulus or q.modulus < r.modulus):
                reasons.append(f"modulus tie between {r.ball} (object {r.object}) and {q.ball} (object {q.object})")
    if not reasons:
        reasons.append("the least modulus is undecided")
    return PixelTruth("degenerate", True if sure else None, None, roots, [], reasons)


# ---------------------------------------------------------------------------
# Comparing a rendered pixel with the truth
# ---------------------------------------------------------------------------


def _near(value: float, target: flint.arb, scale: float) -> bool:
    """|value - target| <= AOV_RELATIVE_TOLERANCE * scale, certainly."""
    return abs(flint.arb(value) - target) <= AOV_RELATIVE_TOLERANCE * scale


def check_pixel(truth: PixelTruth, status: int, hit: bool, re: float, im: float, z: float) -> list[str]:
    """The contradictions between a rendered pixel and the truth, as readable
    strings; only a certified pixel (status 0) claims anything, so any other
    status gives []. ``re``, ``im``, ``z`` are the pixel's AOVs (the chosen
    root and its modulus), ``hit`` its alpha > 0."""
    if status != 0:
        return []
    if truth.hit is None:
        return []  # degenerate without a certain candidate: nothing to contradict
    if hit != truth.hit:
        said = "hit" if hit else "miss"
        return [f"certified {said}, but the exact answer is {truth.describe()}"]
    if not hit or truth.root is None:
        return []
    r = truth.root
    scale = float(r.modulus.mid())
    problems = []
    on_root = _near(re, r.ball.real, scale) and (
        _near(im, r.ball.imag, scale) or _near(im, -r.ball.imag, scale)
    )
    if not on_root:
        problems.append(f"certified hit at t = {complex(re, im)}, but the exact chosen root is {truth.describe()}")
    if not _near(z, r.modulus, scale):
        problems.append(f"certified Z = {z!r}, but the exact chosen root has |t| = {r.modulus}")
    if r.multiplicity > 1:
        problems.append(f"certified a single root, but the chosen root has multiplicity {r.multiplicity}")
    return problems
