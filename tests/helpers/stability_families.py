"""Adversarial families of polynomials for the verified root finder, checked
against the exact truth (truth.py), with a time limit per chunk of
polynomials (the solver runs in a child process: a hang fails the run, it
does not stall it).

The families: Mignotte polynomials t^n - 2(a t - 1)^k; exact
multiple roots with a perturbation near the smallest subnormal; subnormal
roots and close subnormal pairs; coefficients spanning the whole double
range; leading coefficients near overflow.

Used by tests/core/test_roots_adversarial.py (a CI-sized sample) and as a command
for a larger run:

    .venv/bin/python tests/helpers/stability_families.py --per-family 5000 --expensive-share 0.1 --workers 2

which prints, per method and family, the polynomials run and the false
claims found (the target is 0), and writes build/stability_families.json.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root, for tests.helpers
from tests.helpers.truth import Truth, check_roots, reproducer  # noqa: E402

VERIFIED_METHODS = ("auto", "smith", "paper")
DENORM_MIN = 5e-324
MAX_DOUBLE = sys.float_info.max

# ---------------------------------------------------------------------------
# The families: each is rng -> coefficient list (lowest degree first).
# ---------------------------------------------------------------------------


def mignotte(n: int, a: float, k: int) -> list[float]:
    """t^n - 2 (a t - 1)^k (k < n): k roots very close to 1/a."""
    c = [0.0] * (n + 1)
    c[n] = 1.0
    for j in range(k + 1):  # (a t - 1)^k = sum_j C(k, j) a^j t^j (-1)^(k-j)
        c[j] -= 2.0 * math.comb(k, j) * a**j * (-1.0) ** (k - j)
    return c


def _mignotte(rng: np.random.Generator) -> list[float]:
    k = int(rng.integers(2, 5))
    n = int(rng.integers(k + 2, 65))
    a = float(rng.choice([2.0, 3.0, 7.0, 10.0, 16.0, 100.0, 1000.0, 1e4, 1e6, 0.5, 0.1]))
    return mignotte(n, a, k)


def _expand(factors: list[list[float]]) -> list[float]:
    c = np.array([1.0])
    for f in factors:
        c = np.convolve(c, f)
    return [float(v) for v in c]


def _multiple_perturbed(rng: np.random.Generator) -> list[float]:
    """Exact multiple roots (dyadic roots and dyadic complex pairs, whose
    expansion is exact) with one exactly-zero coefficient replaced by a few
    smallest subnormals; or a multiple root at 0 whose zero constant terms
    get the same treatment (roots of size ~ (1e-323)^(1/m))."""
    factors: list[list[float]] = []
    zeros = int(rng.integers(0, 4)) if rng.random() < 0.5 else 0
    degree = zeros
    target = int(rng.integers(2, 15))
    while degree < target:
        m = int(rng.integers(1, 4))
        if rng.random() < 0.5:
            re, im = float(rng.integers(-16, 17)) / 8.0, float(rng.integers(1, 17)) / 8.0
            f = [re * re + im * im, -2.0 * re, 1.0]
        else:
            f = [-float(rng.integers(-16, 17)) / 8.0, 1.0]
        for _ in range(m):
            factors.append(f)
        degree += m * (len(f) - 1)
    c = [0.0] * zeros + _expand(factors)
    zero_at = [k for k in range(len(c) - 1) if c[k] == 0.0]
    if zero_at:
        k = int(rng.choice(zero_at))
        c[k] = float(rng.choice([-1.0, 1.0])) * DENORM_MIN * float(rng.integers(1, 5))
    else:
        c.insert(0, DENORM_MIN * float(rng.integers(1, 5)))  # t p(t) + tiny
    return c


def _subnormal_roots(rng: np.random.Generator) -> list[float]:
    """Quadratics whose roots are subnormal (the leading coefficient near
    overflow, the constant term a few subnormals), sometimes times a factor
    with normal roots."""
    c2 = float(rng.choice([-1.0, 1.0])) * math.ldexp(1.0 + float(rng.random()), int(rng.integers(960, 1023)))
    c1 = float(rng.choice([-1.0, 1.0])) * math.ldexp(1.0 + float(rng.random()), int(rng.integers(-60, 0)))
    c0 = float(rng.choice([-1.0, 1.0])) * DENORM_MIN * float(rng.integers(1, 1 << int(rng.integers(1, 40))))
    c = [c0, c1, c2]
    if rng.random() < 0.3:
        c = _expand([c, [float(rng.normal()), 1.0]])
    return c


def _subnormal_pairs(rng: np.random.Generator) -> list[float]:
    """c2 (t - r)^2 + tiny: two subnormal roots a few ulps apart (a double
    root, a close real pair or a close complex pair), like the regression
    example [1e-323, -5.960464477539065e-08, 8.98846567431158e+307]."""
    r = math.ldexp(1.0 + float(rng.random()), int(rng.integers(-1070, -1022)))
    c2 = math.ldexp(1.0 + float(rng.random()), int(rng.integers(990, 1023)))
    c1 = -2.0 * r * c2
    c0 = r * r * c2  # underflows to a few subnormals, or to 0
    c0 += float(rng.integers(-2, 3)) * DENORM_MIN
    if c0 == 0.0:
        c0 = DENORM_MIN
    return [c0, c1, c2]


def _full_range(rng: np.random.Generator) -> list[float]:
    """Coefficients spanning the whole double range (1e-323 .. 1e308), some
    exactly zero, degree 2 to 64 (overflowing Aberth iterates once hung
    on one of degree 28)."""
    n = int(rng.integers(2, 65))
    exps = rng.uniform(-323.0, 308.0, n + 1)
    c = rng.choice([-1.0, 1.0], n + 1) * 10.0**exps
    c[rng.random(n + 1) < 0.1] = 0.0
    if c[n] == 0.0:
        c[n] = 1.0
    if c[0] == 0.0 and rng.random() < 0.5:
        c[0] = DENORM_MIN
    return [float(v) for v in c]


def _near_overflow(rng: np.random.Generator) -> list[float]:
    """A leading coefficient within a few ulps of the largest double; the
    others normal (roots tiny) or also huge (roots near 1), degree 1 to 20."""
    n = int(rng.integers(1, 21))
    c = rng.standard_normal(n + 1)
    if rng.random() < 0.5:
        c *= 10.0 ** rng.uniform(200.0, 308.0, n + 1)
    c[n] = float(rng.choice([-1.0, 1.0])) * (MAX_DOUBLE - math.ulp(MAX_DOUBLE) * float(rng.integers(0, 8)))
    return [float(v) for v in c]


FAMILIES: dict[str, Callable[[np.random.Generator], list[float]]] = {
    "mignotte": _mignotte,
    "multiple+subnormal": _multiple_perturbed,
    "subnormal roots": _subnormal_roots,
    "subnormal pairs": _subnormal_pairs,
    "full range": _full_range,
    "near overflow": _near_overflow,
}


def generate(family: str, count: int, seed: int) -> list[list[float]]:
    rng = np.random.default_rng([seed, list(FAMILIES).index(family)])
    return [FAMILIES[family](rng) for _ in range(count)]


# ---------------------------------------------------------------------------
# Running: the solver in a child process per chunk, under a time limit.
# ---------------------------------------------------------------------------

_CHILD = r"""
import json, sys, time
from argand.core import find_roots
cases, methods = json.loads(sys.stdin.read())
out = []
for coeffs in cases:
    row = {}
    for m in methods:
        t = time.perf_counter()
        r = find_roots(coeffs, method=m)
        row[m] = {"re": [c.real for c in r.center.tolist()], "im": [c.imag for c in r.center.tolist()],
                  "radius": r.radius.tolist(), "count": r.count.tolist(), "verified": r.verified.tolist(),
                  "real": r.real.tolist(), "n_infinite": r.n_infinite, "degree": r.degree,
                  "escalation": r.escalation, "seconds": time.perf_counter() - t}
    out.append(row)
print(json.dumps(out))
"""


class ChunkTimeout(Exception):
    pass


def solve_in_child(cases: list[list[float]], methods: tuple[str, ...], timeout: float) -> list[dict]:
    """find_roots for every case and method in a fresh child process; raises
    ChunkTimeout if the chunk does not finish within `timeout` seconds."""
    try:
        done = subprocess.run(
            [sys.executable, "-c", _CHILD], input=json.dumps([cases, list(methods)]),
            capture_output=True, text=True, timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        raise ChunkTimeout(f"{len(cases)} polynomials did not finish in {timeout} s; first: {cases[0]!r}") from None
    if done.returncode != 0:
        raise RuntimeError(f"child failed ({done.returncode}): {done.stderr[-2000:]}")
    return json.loads(done.stdout)


def as_roots(d: dict):
    from argand.core import Roots

    return Roots(
        center=np.array([complex(a, b) for a, b in zip(d["re"], d["im"])], dtype=np.complex128),
        radius=np.array(d["radius"], dtype=np.float64),
        count=np.array(d["count"], dtype=np.int64),
        verified=np.array(d["verified"], dtype=bool),
        real=np.array(d["real"], dtype=bool),
        n_infinite=int(d["n_infinite"]),
        escalation=int(d["escalation"]),
        degree=int(d["degree"]),
    )


def check_chunk(cases: list[list[float]], answers: list[dict]) -> tuple[dict, list[str]]:
    """Per method: [polynomials, fully verified, slowest seconds]; and the
    false claims as reproducers."""
    stats = {m: [0, 0, 0.0] for m in answers[0]} if answers else {}
    false: list[str] = []
    for coeffs, row in zip(cases, answers):
        truth = Truth(coeffs)
        for m, d in row.items():
            roots = as_roots(d)
            stats[m][0] += 1
            stats[m][1] += bool(len(roots)) and roots.all_verified
            stats[m][2] = max(stats[m][2], d["seconds"])
            problems = check_roots(coeffs, roots, truth)
            if problems:
                false.append(f"{reproducer(coeffs, m)}: {problems[:2]}")
    return stats, false


def chunks(items: list, size: int) -> Iterator[list]:
    for i in range(0, len(items), size):
        yield items[i : i + size]


#: Families whose polynomials (and exact truths) cost ~0.3-1 s each, against
#: ~10 ms for the others: sampled less.
EXPENSIVE = ("mignotte", "multiple+subnormal", "full range")


def sizes_for(per_family: int, expensive_share: float) -> dict[str, int]:
    return {f: max(1, round(per_family * expensive_share)) if f in EXPENSIVE else per_family for f in FAMILIES}


def run(sizes: dict[str, int], seed: int, workers: int, chunk: int, seconds_per_poly: float,
        methods: tuple[str, ...] = VERIFIED_METHODS) -> dict:
    """The families named in `sizes` (family -> polynomials); returns
    {family: {"polynomials", "timeouts", "methods": {m: {"fully_verified",
    "false_claims", "slowest_s"}}, "examples"}}."""
    report: dict = {}
    jobs = []
    for fam, size in sizes.items():
        for part in chunks(generate(fam, size, seed), chunk):
            jobs.append((fam, part))

    def one(job):
        fam, part = job
        try:
            answers = solve_in_child(part, methods, timeout=20.0 + seconds_per_poly * len(part))
        except ChunkTimeout as exc:
            return fam, len(part), None, [str(exc)]
        stats, false = check_chunk(part, answers)
        return fam, len(part), stats, false

    with ThreadPoolExecutor(max_workers=workers) as pool:
        for fam, size, stats, false in pool.map(one, jobs):
            entry = report.setdefault(fam, {"polynomials": 0, "timeouts": 0, "examples": [],
                                            "methods": {m: {"fully_verified": 0, "false_claims": 0, "slowest_s": 0.0}
                                                        for m in methods}})
            entry["polynomials"] += size
            if stats is None:
                entry["timeouts"] += 1
                entry["examples"] += false[:3]
                continue
            for m, (polys, full, slow) in stats.items():
                e = entry["methods"][m]
                e["fully_verified"] += full
                e["slowest_s"] = round(max(e["slowest_s"], slow), 4)
            for line in false:
                m = line.split("method='")[1].split("'")[0]
                entry["methods"][m]["false_claims"] += 1
            entry["examples"] += false[: max(0, 5 - len(entry["examples"]))]
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-family", type=int, default=1000)
    ap.add_argument("--expensive-share", type=float, default=0.1,
                    help=f"fraction of --per-family for the slow families {', '.join(EXPENSIVE)}")
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--chunk", type=int, default=200)
    ap.add_argument("--seconds-per-poly", type=float, default=2.0)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[2] / "build" / "stability_families.json"))
    args = ap.parse_args(argv)
    start = time.perf_counter()
    report = run(sizes_for(args.per_family, args.expensive_share), args.seed, args.workers, args.chunk, args.seconds_per_poly)
    elapsed = time.perf_counter() - start
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"seconds": round(elapsed, 1), "families": report}, indent=2))
    print(f"{sum(f['polynomials'] for f in report.values())} polynomials in {elapsed:.0f} s")
    print(f"{'family':22s}{'polys':>7s}{'timeouts':>9s}" + "".join(f"{m + ' false/full/slowest':>34s}" for m in VERIFIED_METHODS))
    bad = 0
    for fam, e in report.items():
        cells = ""
        for m in VERIFIED_METHODS:
            s = e["methods"][m]
            bad += s["false_claims"]
            cells += f"{s['false_claims']:>14d} {s['fully_verified']:>8d} {s['slowest_s']:>9.3f}s "
        bad += e["timeouts"]
        print(f"{fam:22s}{e['polynomials']:>7d}{e['timeouts']:>9d}{cells}")
    for fam, e in report.items():
        for line in e["examples"]:
            print(f"{fam}: {line[:400]}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
