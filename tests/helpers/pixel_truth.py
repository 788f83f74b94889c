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
readable strings, like ``tests/helpers/truth.py`` does for discs.

Run as a script, it checks sampled pixels of a scene against this truth::

    .venv/bin/python tests/helpers/pixel_truth.py bicube --size 129x129 -n 2000
    .venv/bin/python tests/helpers/pixel_truth.py random:8:3 --delta 0.1 -n 500
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import flint

if __name__ == "__main__":  # run as a script: the repository root, for tests.helpers
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.helpers.truth import Precision  # noqa: E402

#: Working precisions (bits) of the root balls, tried in order until every
#: decision of the pixel is certain.
PRECISIONS: tuple[int, ...] = (128, 512, 2048, 8192)

#: The AOVs are float32: a root read back from them is within half an ulp
#: of float32 per component, plus the (tiny) radius of a certified disc.
AOV_RELATIVE_TOLERANCE = 2.0**-21


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
    """The objects of a scene (an ``argand.scene.Scene`` or the
    ``_core.SceneSpec`` the renderer plans from), exactly."""
    from argand.render.convert import to_core_scene  # the scene's doubles, as the renderer gets them

    scene = to_core_scene(scene)
    out = []
    for obj in scene.objects:
        linear = [exact(v) for v in obj.linear]
        clip = obj.clip_radius
        out.append(
            TruthObject(
                terms=tuple((int(i), int(j), int(k), exact(c)) for i, j, k, c in obj.terms),
                complex_space=obj.complex_space,
                clip_radius=exact(clip) if clip > 0 else None,
                linear=tuple(tuple(linear[3 * r : 3 * r + 3]) for r in range(3)),
                translate=tuple(exact(v) for v in obj.translate),
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
    with Precision(prec):
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
        with Precision(prec):
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


def _nearest_root(truth: PixelTruth, point: complex) -> TruthRoot | None:
    """The root (of any object, either conjugate) nearest ``point``, when
    certainly nearer than every other root."""
    g = flint.acb(point.real, abs(point.imag))  # roots are kept with imag >= 0
    dist = [(abs(r.ball - g), r) for r in truth.roots]
    for d, r in dist:
        if all(d < e for e, q in dist if q is not r):
            return r
    return None


def check_pixel(truth: PixelTruth, status: int, hit: bool, re: float, im: float, z: float) -> list[str]:
    """The contradictions between a rendered pixel and the truth, as readable
    strings; only a certified pixel (status 0) claims anything, so any other
    status gives []. ``re``, ``im``, ``z`` are the pixel's AOVs (the chosen
    root and its modulus), ``hit`` its alpha > 0.

    Each string starts with its kind: ``"wrong: "`` when the pixel claims a
    different answer (hit for miss, miss for hit, another root than the
    chosen one, a single root where the chosen root is multiple), and
    ``"imprecise: "`` when it shows the right root but farther from it than
    float32 AOVs allow (AOV_RELATIVE_TOLERANCE relative to |t|)."""
    if status != 0:
        return []
    if truth.hit is None:
        return []  # degenerate without a certain candidate: nothing to contradict
    if hit != truth.hit:
        said = "hit" if hit else "miss"
        return [f"wrong: certified {said}, but the exact answer is {truth.describe()}"]
    if not hit or truth.root is None:
        return []
    r = truth.root
    scale = float(r.modulus.mid())
    problems = []
    on_root = _near(re, r.ball.real, scale) and (
        _near(im, r.ball.imag, scale) or _near(im, -r.ball.imag, scale)
    )
    if not on_root:
        nearest = _nearest_root(truth, complex(re, im))
        kind = "imprecise" if nearest is r else "wrong"
        gap = abs(r.ball - flint.acb(re, abs(im)))
        problems.append(f"{kind}: certified hit at t = {complex(re, im)}, {float(gap.mid()):.3g} from the exact "
                        f"chosen root: {truth.describe()}")
    if not _near(z, r.modulus, scale):
        # Beside re and im on the root: Z that is their modulus is the same
        # root, as imprecise as they are (their errors add up in it); Z
        # that is not shows another value than the root written.
        if on_root:
            kind = "imprecise" if abs(z - math.hypot(re, im)) <= AOV_RELATIVE_TOLERANCE * scale else "wrong"
        problems.append(f"{kind}: certified Z = {z!r}, but the exact chosen root has |t| = {r.modulus}")
    if r.multiplicity > 1:
        problems.append(f"wrong: certified a single root, but the chosen root has multiplicity {r.multiplicity}")
    return problems


def is_wrong(problems: Sequence[str]) -> bool:
    """Whether any of check_pixel's problems is a wrong answer (not only an
    imprecise AOV)."""
    return any(p.startswith("wrong: ") for p in problems)


# ---------------------------------------------------------------------------
# Checking a rendered frame (the glue that calls the renderer; the truth
# above never does)
# ---------------------------------------------------------------------------


@dataclass
class FrameCheck:
    """The outcome of checking pixels of one rendered frame."""

    pixels: int = 0  # pixels checked
    certified: int = 0  # of those, status 0
    certified_hits: int = 0
    degenerate: int = 0  # pixels whose truth is degenerate
    by_status: list[int] = field(default_factory=lambda: [0, 0, 0, 0])
    disagreements: list[tuple[int, int, list[str]]] = field(default_factory=list)
    seconds_truth: float = 0.0

    @property
    def wrong(self) -> int:
        """Certified pixels whose answer the truth contradicts."""
        return sum(is_wrong(p) for _, _, p in self.disagreements)

    @property
    def imprecise(self) -> int:
        """Certified pixels with the right answer but AOVs off by more than float32."""
        return len(self.disagreements) - self.wrong

    def add(self, other: FrameCheck) -> None:
        self.pixels += other.pixels
        self.certified += other.certified
        self.certified_hits += other.certified_hits
        self.degenerate += other.degenerate
        self.by_status = [a + b for a, b in zip(self.by_status, other.by_status)]
        self.disagreements += other.disagreements
        self.seconds_truth += other.seconds_truth


def rendered_pixel(result: Any, x: int, y: int) -> tuple[int, bool, float, float, float]:
    """(status, hit, re, im, Z) of pixel (x, y) of a FrameResult or TileAOVs
    whose arrays start at pixel (0, 0)."""
    a = result.aovs
    return (int(a["status"][y, x]), bool(result.rgba[y, x, 3] > 0), float(a["re"][y, x]),
            float(a["im"][y, x]), float(a["Z"][y, x]))


def check_frame(scene: Any, params: Any, result: Any, pixels: Sequence[tuple[int, int]]) -> FrameCheck:
    """Checks the given pixels of ``result`` (a rendered FrameResult of
    ``scene`` with FrameParams ``params``) against the exact truth."""
    import time

    from argand.render import primary_ray

    objects = scene_objects(scene)
    out = FrameCheck()
    for x, y in pixels:
        status, hit, re, im, z = rendered_pixel(result, x, y)
        out.pixels += 1
        out.by_status[status] += 1
        if status != 0:
            continue
        out.certified += 1
        out.certified_hits += hit
        origin, direction = primary_ray(scene, params.width, params.height, x, y)
        start = time.perf_counter()
        truth = pixel_truth(scene, params.sigma, params.delta, origin, direction, objects)
        out.seconds_truth += time.perf_counter() - start
        out.degenerate += truth.decision == "degenerate"
        problems = check_pixel(truth, status, hit, re, im, z)
        if problems:
            out.disagreements.append((x, y, problems))
    return out


def sample_pixels(width: int, height: int, count: int, seed: int) -> list[tuple[int, int]]:
    """``count`` distinct pixels of the frame (all of them when count >= w h)."""
    import random

    every = [(x, y) for y in range(height) for x in range(width)]
    if count >= len(every):
        return every
    return random.Random(seed).sample(every, count)


def _scene_from_spec(spec: str) -> Any:
    if spec.startswith("random:"):
        from tests.helpers.random_surfaces import parse_random_spec

        return parse_random_spec(spec)
    from argand.scene import load_scene

    return load_scene(spec)


def main(argv: Sequence[str] | None = None) -> int:
    import argparse
    import time

    from argand.render import FrameParams, render_frame
    from argand.frames.angles import parse_angle

    parser = argparse.ArgumentParser(
        prog="tests/helpers/pixel_truth.py",
        description="Check sampled pixels of rendered frames against the exact truth; print every certified "
        "pixel the truth contradicts. Exit status 1 when there is one.",
    )
    parser.add_argument("scenes", nargs="+", help="preset names, scene files, or random:[FAMILY:]DEGREE:SEED")
    parser.add_argument("--size", default="64x64", help="frame size WxH (default 64x64)")
    parser.add_argument("--sigma", default="0", help="band start (radians, or e.g. pi/36)")
    parser.add_argument("--delta", action="append", help="band width(s); repeat for several (default 0)")
    parser.add_argument("-n", "--pixels", type=int, default=1000, help="pixels sampled per frame (default 1000)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--method", default="auto")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    deltas = [parse_angle(d) for d in (args.delta or ["0"])]
    total = FrameCheck()
    for spec in args.scenes:
        scene = _scene_from_spec(spec)
        for delta in deltas:
            params = FrameParams(sigma=parse_angle(args.sigma), delta=delta, width=width, height=height,
                                 method=args.method)
            start = time.perf_counter()
            result = render_frame(scene, params, workers=1)
            render_s = time.perf_counter() - start
            check = check_frame(scene, params, result, sample_pixels(width, height, args.pixels, args.seed))
            total.add(check)
            share = check.certified / max(1, check.pixels)
            print(f"{spec} delta={delta:.6g}: {check.pixels} pixels, certified {100 * share:.2f}% "
                  f"(status 0/1/2/3: {'/'.join(map(str, check.by_status))}), {check.degenerate} degenerate, "
                  f"{check.wrong} wrong, {check.imprecise} imprecise; render {render_s:.2f} s, truth {check.seconds_truth:.2f} s")
            for x, y, problems in check.disagreements:
                for p in problems:
                    print(f"  {spec} delta={delta!r} pixel ({x}, {y}): {p}")
    print(f"total: {total.pixels} pixels, {total.certified} certified checked ({total.certified_hits} hits), "
          f"{total.degenerate} degenerate, {total.wrong} wrong, {total.imprecise} imprecise")
    return 1 if total.disagreements else 0


if __name__ == "__main__":
    raise SystemExit(main())
