"""The peers' inputs: a surf script and a POV-Ray scene whose camera rays are
Argand's (to rounding), and the exact truth of a real pixel (sigma = delta = 0).

Camera. Argand's ray of pixel (i, j) in a W x H frame (core/src/render/camera.cpp,
``sample_direction``) is ``f + sx r + sy u`` from the eye, through the
pixel's centre: ``sx = (2 (i + 1/2) / W - 1) tan(fov/2) W/H``,
``sy = (1 - 2 (j + 1/2) / H) tan(fov/2)``, with ``f`` the unit view direction,
``r = f x up`` normalised and ``u = r x f``.

* surf's eye is at (0, 0, spec_z) on its z axis, and the ray of pixel (i, j)
  passes through (X, Y, 0) with ``X = -10 + 20 i / (W - 1)``,
  ``Y = 10 - 20 j / (H - 1)`` (pixel corners, not centres). Both grids are
  affine in i and symmetric about the frame's centre, so they coincide when
  ``10 / ((W - 1) spec_z) = tan(fov/2) aspect / W``:
  ``spec_z = 10 W / ((W - 1) tan(fov/2) aspect)`` (and the same with H for
  the rows; the frames here are square). surf's world is Argand's in the
  camera's frame (x = r, y = u, z = -f, origin at look_at) scaled by
  ``k = spec_z / |eye - look_at|``, so surf's eye is Argand's eye. surf gets
  ``G(X, Y, Z) = F(L (look_at + (X r + Y u - Z f) / k - T))`` (``L``, ``T``
  the object's linear map and translation) expanded exactly from the doubles
  in rationals and rounded once to doubles, and ``clip = sphere`` of radius
  ``k R`` about the image of the object's origin.
* POV-Ray's perspective camera shoots ``direction + x right + y up`` with
  ``x = (i + 1/2)/W - 1/2`` and ``y = 1/2 - (j + 1/2)/H`` (pixel centres when
  antialiasing is off): ``direction = f``, ``right = 2 tan(fov/2) aspect r``,
  ``up = 2 tan(fov/2) u``, at Argand's eye, in Argand's world coordinates
  (given as explicit vectors, POV-Ray's left-handedness mirrors nothing).
  The surface is ``polynomial { n, xyz(i, j, k): c, ... }`` of
  ``F(L (w - T))``, clipped by (and bounded by) the clipping sphere.

The truth (:func:`real_truth`) follows ``tests/helpers/pixel_truth.py`` for
the band sigma = delta = 0: a pixel hits when some object's exact ray
polynomial (every double at its exact rational value, python-flint) has a
positive real root t whose point lies in the closed clipping ball. Real
roots come from ``fmpq_poly.complex_roots`` (an exactly zero imaginary part
proves a root real), and the ball comparison rises in precision; a root
exactly on the sphere is decided on the rational root, and a ray lying in a
surface (p identically 0) or a comparison no precision separates is
"degenerate".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import flint

#: Working precisions (bits) for the clipping-ball decision, as pixel_truth.
PRECISIONS = (128, 512, 2048, 8192)


def exact(x: float) -> flint.fmpq:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"not a finite number: {x!r}")
    return flint.fmpq(*x.as_integer_ratio())


# ---------------------------------------------------------------------------
# The camera, as core/src/render/camera.cpp plans it
# ---------------------------------------------------------------------------


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _normalize(v):
    n = math.sqrt(_dot(v, v))
    return [v[0] / n, v[1] / n, v[2] / n] if n > 0 else list(v)


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


@dataclass(frozen=True)
class CameraFrame:
    eye: tuple[float, float, float]
    look_at: tuple[float, float, float]
    forward: tuple[float, float, float]
    right: tuple[float, float, float]
    up: tuple[float, float, float]
    tan_half_fov: float
    distance: float  # |look_at - eye|


def camera_frame(core_scene: Any) -> CameraFrame:
    """The planned camera of a ``_core.SceneSpec`` (the same double operations
    as ``plan_camera`` in core/src/render/camera.cpp)."""
    cam = core_scene.camera
    eye = [float(v) for v in cam.position]
    look = [float(v) for v in cam.look_at]
    forward = _normalize([look[a] - eye[a] for a in range(3)])
    right = _normalize(_cross(forward, [float(v) for v in cam.up]))
    up = _cross(right, forward)
    tan = math.tan(cam.fov_degrees * math.pi / 360.0)
    to_target = [look[a] - eye[a] for a in range(3)]
    return CameraFrame(tuple(eye), tuple(look), tuple(forward), tuple(right), tuple(up), tan,
                       max(1e-9, math.sqrt(_dot(to_target, to_target))))


def ray_direction(cam: CameraFrame, width: int, height: int, i: int, j: int) -> tuple[float, float, float]:
    """Argand's (unnormalised) direction of pixel (i, j); for tests."""
    aspect = width / height
    sx = (2.0 * (i + 0.5) / width - 1.0) * cam.tan_half_fov * aspect
    sy = (1.0 - 2.0 * (j + 0.5) / height) * cam.tan_half_fov
    return tuple(cam.forward[a] + sx * cam.right[a] + sy * cam.up[a] for a in range(3))


# ---------------------------------------------------------------------------
# Exact substitution of a linear map into a polynomial
# ---------------------------------------------------------------------------

Poly = dict  # {(i, j, k): fmpq}


def _mul(p: Poly, q: Poly) -> Poly:
    out: Poly = {}
    for (a, b, c), u in p.items():
        for (d, e, f), v in q.items():
            key = (a + d, b + e, c + f)
            out[key] = out.get(key, flint.fmpq(0)) + u * v
    return out


def substitute(terms: Sequence[tuple[int, int, int, float]], A: Sequence[Sequence[flint.fmpq]],
               b: Sequence[flint.fmpq]) -> Poly:
    """F(A s + b) in the variables s, exactly: ``terms`` are F's (i, j, k, c)
    with c taken at its exact double value."""
    forms = []
    for a in range(3):
        form: Poly = {(0, 0, 0): b[a]} if b[a] != 0 else {}
        for c in range(3):
            if A[a][c] != 0:
                key = tuple(1 if d == c else 0 for d in range(3))
                form[key] = A[a][c]
        forms.append(form)
    top = max(i + j + k for i, j, k, _ in terms)
    powers = []
    for a in range(3):
        row = [{(0, 0, 0): flint.fmpq(1)}]
        for _ in range(top):
            row.append(_mul(row[-1], forms[a]))
        powers.append(row)
    out: Poly = {}
    for i, j, k, coeff in terms:
        c = exact(coeff)
        if c == 0:
            continue
        for key, v in _mul(_mul(powers[0][i], powers[1][j]), powers[2][k]).items():
            out[key] = out.get(key, flint.fmpq(0)) + c * v
    return {key: v for key, v in out.items() if v != 0}


def rounded(poly: Poly) -> list[tuple[int, int, int, float]]:
    """The polynomial's coefficients rounded once to doubles (largest degree
    first), zeros dropped."""
    out = []
    for key in sorted(poly, key=lambda k: (-sum(k), tuple(-v for v in k))):
        value = poly[key]
        c = int(value.p) / int(value.q)  # Python rounds p/q correctly
        if c != 0.0:
            out.append((*key, c))
    return out


def _matrix(linear: Sequence[float]) -> list[list[flint.fmpq]]:
    return [[exact(linear[3 * r + c]) for c in range(3)] for r in range(3)]


def _matmul(A, B):
    return [[sum((A[r][m] * B[m][c] for m in range(3)), flint.fmpq(0)) for c in range(3)] for r in range(3)]


def _apply(A, v):
    return [sum((A[r][c] * v[c] for c in range(3)), flint.fmpq(0)) for r in range(3)]


def _similarity_scale(A) -> float | None:
    """s when the (float) matrix A is s times an orthogonal matrix, else None."""
    m = [[float(A[r][c]) for c in range(3)] for r in range(3)]
    gram = [[sum(m[k][a] * m[k][b] for k in range(3)) for b in range(3)] for a in range(3)]
    s2 = gram[0][0]
    scale = max(abs(v) for row in gram for v in row)
    for a in range(3):
        for b in range(3):
            target = s2 if a == b else 0.0
            if abs(gram[a][b] - target) > 1e-9 * scale:
                return None
    return math.sqrt(s2)


def _clip_sphere(obj: Any, A, b) -> tuple[tuple[float, float, float], float] | None:
    """The object's clipping ball |A s + b| <= R as a ball in s: (centre,
    radius); None without clipping. Raises ValueError when A is not a
    similarity (the ball would be an ellipsoid)."""
    if not obj.clip_radius > 0:
        return None
    s = _similarity_scale(A)
    if s is None:
        raise ValueError("the object's transform is not a similarity: its clipping ball is no sphere for the peers")
    m = [[float(A[r][c]) for c in range(3)] for r in range(3)]
    # centre: A c + b = 0, c = -A^T b / s^2 (A^T A = s^2 I)
    bf = [float(v) for v in b]
    centre = tuple(-sum(m[k][a] * bf[k] for k in range(3)) / (s * s) for a in range(3))
    return centre, float(obj.clip_radius) / s


# ---------------------------------------------------------------------------
# surf
# ---------------------------------------------------------------------------


def surf_spec_z(cam: CameraFrame, width: int, height: int) -> float:
    if width != height:
        raise ValueError("surf's window is square: frames must be square")
    return 10.0 * width / ((width - 1) * cam.tan_half_fov)


def _surf_poly(terms: Sequence[tuple[int, int, int, float]]) -> str:
    parts = []
    for i, j, k, c in terms:
        mono = "*".join(f"{v}^{e}" if e > 1 else v for v, e in (("x", i), ("y", j), ("z", k)) if e)
        parts.append(f"({c!r})" + (f"*{mono}" if mono else ""))
    return " + ".join(parts) if parts else "0"


def surf_script(core_scene: Any, width: int, height: int, image: str) -> tuple[str, dict]:
    """A surf script drawing the scene's (single) object flat white on
    black into the PPM ``image``, and what it used (spec_z, scale k, clip)."""
    if len(core_scene.objects) != 1:
        raise ValueError("the peers draw one object per scene")
    obj = core_scene.objects[0]
    cam = camera_frame(core_scene)
    spec_z = surf_spec_z(cam, width, height)
    k = exact(spec_z) / exact(cam.distance)
    # world = look + C^T s / k, C^T's columns r, u, -f; object = L (world - T)
    ct = [[exact(cam.right[a]), exact(cam.up[a]), -exact(cam.forward[a])] for a in range(3)]
    L = _matrix(obj.linear)
    A = [[v / k for v in row] for row in _matmul(L, ct)]
    b = _apply(L, [exact(cam.look_at[a]) - exact(obj.translate[a]) for a in range(3)])
    poly = rounded(substitute(obj.terms, A, b))
    clip = _clip_sphere(obj, A, b)
    lines = [
        f"width = {width};", f"height = {height};", f"spec_z = {spec_z!r};",
        "background_red = 0; background_green = 0; background_blue = 0;",
        "surface_red = 255; surface_green = 255; surface_blue = 255;",
        "inside_red = 255; inside_green = 255; inside_blue = 255;",
        "illumination = ambient_light;", "ambient = 100;", "antialiasing = 1;", "perspective = central;",
    ]
    if clip is not None:
        (cx, cy, cz), radius = clip
        lines += ["clip = sphere;", f"radius = {radius!r};", f"center_x = {cx!r};", f"center_y = {cy!r};",
                  f"center_z = {cz!r};"]
    else:
        lines.append("clip = none;")
    lines += [f"surface = {_surf_poly(poly)};", "draw_surface;", f'filename = "{image}";',
              "color_file_format = ppm;", "save_color_image;"]
    return "\n".join(lines) + "\n", {"spec_z": spec_z, "scale": float(k), "clip": clip, "terms": len(poly)}


# ---------------------------------------------------------------------------
# POV-Ray
# ---------------------------------------------------------------------------


def _vec(v) -> str:
    return "<" + ", ".join(repr(float(c)) for c in v) + ">"


def pov_scene(core_scene: Any, width: int, height: int, sturm: bool) -> str:
    """A POV-Ray 3.7 scene of the (single) object, flat white on black."""
    if len(core_scene.objects) != 1:
        raise ValueError("the peers draw one object per scene")
    obj = core_scene.objects[0]
    cam = camera_frame(core_scene)
    aspect = width / height
    L = _matrix(obj.linear)
    b = [-v for v in _apply(L, [exact(v) for v in obj.translate])]
    poly = rounded(substitute(obj.terms, L, b))
    degree = max(i + j + k for i, j, k, _ in poly)
    coeffs = ",\n    ".join(f"xyz({i}, {j}, {k}): {c!r}" for i, j, k, c in poly)
    clip = _clip_sphere(obj, L, b)
    clip_text = ""
    if clip is not None:
        centre, radius = clip
        sphere = f"sphere {{ {_vec(centre)}, {radius!r} }}"
        clip_text = f"  clipped_by {{ {sphere} }}\n  bounded_by {{ {sphere} }}\n"
    right = [2.0 * cam.tan_half_fov * aspect * v for v in cam.right]
    up = [2.0 * cam.tan_half_fov * v for v in cam.up]
    return (
        "#version 3.7;\n"
        "global_settings { assumed_gamma 1.0 }\n"
        "background { rgb 0 }\n"
        f"camera {{ perspective location {_vec(cam.eye)} direction {_vec(cam.forward)}\n"
        f"         right {_vec(right)} up {_vec(up)} }}\n"
        f"polynomial {{ {max(degree, 2)},\n    {coeffs}\n"
        f"  {'sturm' if sturm else ''}\n{clip_text}"
        "  pigment { rgb 1 } finish { ambient 1 diffuse 0 specular 0 }\n  no_shadow\n}\n"
    )


# ---------------------------------------------------------------------------
# The exact truth of a real pixel
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class TruthObject:
    terms: tuple[tuple[int, int, int, flint.fmpq], ...]
    clip_radius: flint.fmpq | None
    linear: tuple[tuple[flint.fmpq, ...], ...]
    translate: tuple[flint.fmpq, ...]


def truth_objects(core_scene: Any) -> list[TruthObject]:
    out = []
    for obj in core_scene.objects:
        out.append(TruthObject(tuple((int(i), int(j), int(k), exact(c)) for i, j, k, c in obj.terms),
                               exact(obj.clip_radius) if obj.clip_radius > 0 else None,
                               tuple(tuple(r) for r in _matrix(obj.linear)), tuple(exact(v) for v in obj.translate)))
    return out


def _ray_poly(obj: TruthObject, origin, direction):
    o = [exact(v) - t for v, t in zip(origin, obj.translate)]
    d = [exact(v) for v in direction]
    oo = _apply(obj.linear, o)
    od = _apply(obj.linear, d)
    top = max(i + j + k for i, j, k, _ in obj.terms)
    powers = []
    for a in range(3):
        line = flint.fmpq_poly([oo[a], od[a]])
        row = [flint.fmpq_poly([1])]
        for _ in range(top):
            row.append(row[-1] * line)
        powers.append(row)
    p = flint.fmpq_poly([])
    for i, j, k, c in obj.terms:
        p += powers[0][i] * powers[1][j] * powers[2][k] * c
    return p, oo, od


@dataclass
class RealTruth:
    decision: str  # "hit", "miss" or "degenerate"
    hit: bool | None
    reason: str = ""
    multiple: bool = False  # the deciding root is a multiple root (tangent ray, singular curve)


def real_truth(objects: Sequence[TruthObject], origin: Sequence[float], direction: Sequence[float]) -> RealTruth:
    """The exact answer for sigma = delta = 0: does the ray meet some
    object's real surface at t > 0 inside its clipping ball?"""
    old = flint.ctx.prec
    try:
        undecided: list[str] = []
        multiple_hit = False
        hit = False
        for index, obj in enumerate(objects):
            p, oo, od = _ray_poly(obj, origin, direction)
            if p.degree() < 0:
                return RealTruth("degenerate", None, f"the ray lies in the surface of object {index}")
            while p.degree() > 0 and p[0] == 0:
                p = flint.fmpq_poly(p.coeffs()[1:])
            if p.degree() < 1:
                continue
            if obj.clip_radius is not None:
                a = sum((v * v for v in oo), flint.fmpq(0)) - obj.clip_radius * obj.clip_radius
                b = 2 * sum((u * v for u, v in zip(oo, od)), flint.fmpq(0))
                c = sum((v * v for v in od), flint.fmpq(0))
            flint.ctx.prec = PRECISIONS[0]
            pairs = p.complex_roots()
            reals = [(ball, int(m)) for ball, m in pairs if ball.imag.is_exact() and ball.imag.is_zero()]
            for ball, mult in reals:
                answer = None
                for prec in PRECISIONS:
                    flint.ctx.prec = prec
                    if prec != PRECISIONS[0]:
                        ball = _refine(p, ball, prec)
                    t = ball.real
                    if t < 0:
                        answer = False
                        break
                    if not t > 0:
                        continue
                    if obj.clip_radius is None:
                        answer = True
                        break
                    f = flint.arb(a) + t * (flint.arb(b) + t * flint.arb(c))
                    if f <= 0:
                        answer = True
                        break
                    if f > 0:
                        answer = False
                        break
                if answer is None:
                    r = _rational_root(p, ball)
                    if r is not None and r > 0 and obj.clip_radius is not None:
                        answer = a + r * (b + r * c) <= 0
                if answer is None:
                    undecided.append(f"a real root of object {index} on its clipping sphere")
                elif answer:
                    hit = True
                    multiple_hit = multiple_hit or mult > 1
        if hit:
            return RealTruth("hit", True, multiple=multiple_hit)
        if undecided:
            return RealTruth("degenerate", None, "; ".join(undecided))
        return RealTruth("miss", False)
    finally:
        flint.ctx.prec = old


def _refine(p: flint.fmpq_poly, ball: flint.acb, prec: int) -> flint.acb:
    """The same real root at a higher precision (the root ball of p's roots
    at ``prec`` that overlaps ``ball``)."""
    for other, _m in p.complex_roots():
        if other.imag.is_exact() and other.imag.is_zero() and other.real.overlaps(ball.real):
            return other
    return ball


def _rational_root(p: flint.fmpq_poly, ball: flint.acb) -> flint.fmpq | None:
    _, factors = p.factor()
    for f, _m in factors:
        if f.degree() == 1:
            r = -f[0] / f[1]
            if ball.real.overlaps(flint.arb(r)):
                return r
    return None
