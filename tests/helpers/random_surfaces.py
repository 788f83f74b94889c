"""Random surfaces of degree 1 to 12 for the render tests, from a seeded RNG.

Each generator returns the renderer's typed core scene (the
``_core.SceneSpec`` ``argand.render.convert.to_core_scene`` makes of a Scene)
with one object:

* ``dense``: every monomial of degree <= n with a random double coefficient
  (uniform in [-1, 1]), so the picture is a generic surface of degree n;
* ``product``: a product of random quadrics and planes with small integer
  coefficients, exactly: where two factors meet the surface is singular
  (double curves), and the ray polynomials have exact double roots there;
* ``near-product``: such a product plus a random perturbation of size 1e-6,
  which turns the double curves into thin necks and near-tangent rays.

The camera looks at the origin from a random point at distance 5 to 7; the
clip ball (radius 1.6) keeps every surface bounded.
"""

from __future__ import annotations

import itertools
from typing import Iterable

import numpy as np

FAMILIES = ("dense", "product", "near-product")

Poly = dict[tuple[int, int, int], float]


def monomials(degree: int) -> list[tuple[int, int, int]]:
    return [(i, j, k) for i, j, k in itertools.product(range(degree + 1), repeat=3) if i + j + k <= degree]


def multiply(a: Poly, b: Poly) -> Poly:
    """Exact when the coefficients are small integers (as here)."""
    out: Poly = {}
    for (i, j, k), c in a.items():
        for (p, q, r), d in b.items():
            key = (i + p, j + q, k + r)
            out[key] = out.get(key, 0.0) + c * d
    return {m: c for m, c in out.items() if c != 0.0}


def random_plane(rng: np.random.Generator) -> Poly:
    a, b, c = rng.integers(-3, 4, size=3)
    while a == b == c == 0:
        a, b, c = rng.integers(-3, 4, size=3)
    e = int(rng.integers(-1, 2))
    return {m: float(v) for m, v in {(1, 0, 0): a, (0, 1, 0): b, (0, 0, 1): c, (0, 0, 0): e}.items() if v != 0}


def random_quadric(rng: np.random.Generator) -> Poly:
    """A random quadric that meets the unit ball: sum of +-x_i^2 terms, a
    few cross terms and a constant, small integers."""
    out: Poly = {}
    for m in monomials(2):
        if sum(m) == 2:
            v = int(rng.integers(-2, 3))
            if max(m) == 2 and v == 0:
                v = 1
        else:
            v = int(rng.integers(-1, 2))
        if v:
            out[m] = float(v)
    return out


def random_polynomial(family: str, degree: int, rng: np.random.Generator) -> Poly:
    if family == "dense":
        out = {m: float(rng.uniform(-1.0, 1.0)) for m in monomials(degree)}
        return out
    if family in ("product", "near-product"):
        out: Poly = {(0, 0, 0): 1.0}
        left = degree
        while left > 0:
            if left >= 2 and rng.random() < 0.6:
                out = multiply(out, random_quadric(rng))
                left -= 2
            else:
                out = multiply(out, random_plane(rng))
                left -= 1
        if family == "near-product":
            for m in monomials(degree):
                out[m] = out.get(m, 0.0) + float(rng.uniform(-1e-6, 1e-6))
        return out
    raise ValueError(f"unknown family {family!r}; families: {', '.join(FAMILIES)}")


def camera(rng: np.random.Generator) -> dict:
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    distance = float(rng.uniform(5.0, 7.0))
    return {
        "position": [float(v) for v in direction * distance],
        "look_at": [float(v) for v in rng.uniform(-0.1, 0.1, size=3)],
        "up": [0.0, 0.0, 1.0],
        "fov": 30.0,
    }


def core_scene(terms: Poly, clip_radius: float = 1.6, cam: dict | None = None, complex_space: bool = True):
    """The renderer's core scene (a _core.SceneSpec) for one object with
    these terms; ``cam`` is a scene file's camera (position, look_at, up, fov)."""
    from argand.render.convert import to_core_scene
    from argand.scene import scene_from_dict

    base = to_core_scene(scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}],
                                          "camera": cam or {"position": [6.0, 0.0, 0.0]}}))
    obj = base.objects[0]
    obj.terms = [(i, j, k, float(c)) for (i, j, k), c in sorted(terms.items())]
    obj.degree = max(sum(m) for m in terms)
    obj.clip_radius = float(clip_radius)
    obj.complex_space = complex_space
    return base


def random_scene(family: str, degree: int, seed: int):
    """A random one-object scene; the same (family, degree, seed) gives the same scene."""
    rng = np.random.default_rng([seed, degree, FAMILIES.index(family)])
    terms = random_polynomial(family, degree, rng)
    while max(sum(m) for m in terms) < degree:  # a dense draw never loses its top degree; products cannot
        terms = random_polynomial(family, degree, rng)
    return core_scene(terms, cam=camera(rng))


def parse_random_spec(spec: str):
    """``random:DEGREE:SEED`` or ``random:FAMILY:DEGREE:SEED`` -> a scene."""
    parts = spec.split(":")
    if parts[0] != "random" or len(parts) not in (3, 4):
        raise ValueError(f"expected random:DEGREE:SEED or random:FAMILY:DEGREE:SEED, got {spec!r}")
    family = parts[1] if len(parts) == 4 else "dense"
    degree, seed = int(parts[-2]), int(parts[-1])
    if not 1 <= degree <= 12:
        raise ValueError(f"degree must be in 1..12, got {degree}")
    return random_scene(family, degree, seed)


def all_specs(degrees: Iterable[int], seeds: Iterable[int]) -> list[tuple[str, int, int]]:
    return [(f, d, s) for d in degrees for f in FAMILIES for s in seeds]
