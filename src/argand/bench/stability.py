"""The named stability suite, where root finders fail, as a table of
families x methods for docs/benchmarks.md (`argand bench stability`).

Every case is solved by argand's four methods and by numpy, python-flint,
mpmath and MPSolve. Each answer is put in one of four classes against the
exact roots (python-flint on the exact rational value of the coefficients):

* **proven**: correct, and the method proves it (argand: every disc
  verified, checked by tests/helpers/truth.py; python-flint: isolating balls, each
  holding a true root; MPSolve: disjoint inclusion discs, each holding
  exactly one true root);
* **correct, unproven**: every root approximated to a relative error of
  ``TOLERANCE`` at most, without a proof;
* **flagged**: not correct, but the method says so (an unverified disc or
  a cluster, an exception, overlapping inclusion discs);
* **wrong**: a claim that is false, or an inaccurate answer given as if it
  were right (numpy and mpmath have no way to flag one).

The cases (CASES) are the ones tests/core/test_roots_stability.py checks for false
claims; a family groups the cases of one kind of difficulty.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np

from argand.bench import machine_info

#: Relative error at most which an unproven approximation counts as correct.
TOLERANCE = 1e-6
CLASSES = ("proven", "correct, unproven", "flagged", "wrong")
OUR_METHODS = ("auto", "smith", "paper", "unverified")
OTHERS = ("numpy", "python-flint", "mpmath", "MPSolve")


def exact_expand(roots) -> list[float]:
    """prod (t - r) expanded in exact rationals, then each coefficient rounded
    once to float64 (exact when it is representable)."""
    c = [Fraction(1)]
    for r in roots:
        r = Fraction(r)
        nxt = [Fraction(0)] * (len(c) + 1)
        for k, v in enumerate(c):
            nxt[k + 1] += v
            nxt[k] -= r * v
        c = nxt
    return [float(v) for v in c]


def float_expand(roots) -> list[float]:
    """prod (t - r) expanded in float64 arithmetic."""
    c = np.array([1.0])
    for r in roots:
        c = np.convolve(c, [-float(r), 1.0])
    return [float(v) for v in c]


def quartic_minus(eps: float) -> list[float]:
    """(t - 1)^4 - eps."""
    return [1.0 - eps, -4.0, 6.0, -4.0, 1.0]


def mignotte(n: int, a: int) -> list[float]:
    """t^n - 2 (a t - 1)^2: two roots very close to 1/a."""
    c = [0.0] * (n + 1)
    c[n] = 1.0
    c[0] = -2.0
    c[1] = 4.0 * a
    c[2] = -2.0 * a * a
    return c


def _signs(n: int) -> list[float]:
    rng = np.random.default_rng(150)
    return [float(s) for s in rng.choice([-1.0, 1.0], n)]


SPAN = [10.0 ** (150 - 25 * k) for k in range(13)]  # 1e150 .. 1e-150

#: The named cases, by family.
FAMILIES: dict[str, dict[str, list[float]]] = {
    "multiple roots": {
        "double_root (t-1)^2": exact_expand([1, 1]),
        "triple_root (t-2)^3": exact_expand([2, 2, 2]),
        "(t-1)^2(t+3)": exact_expand([1, 1, -3]),
        "quadruple_root (t-1)^4": exact_expand([1, 1, 1, 1]),
    },
    "clusters": {
        "cluster 1e-6": float_expand([1.0, 1.0 + 1e-6, -2.0]),
        "cluster 1e-10": float_expand([1.0, 1.0 + 1e-10, -2.0]),
        "cluster 1e-15": float_expand([1.0, 1.0 + 1e-15, -2.0]),
        "(t-1)^4 - 1e-8": quartic_minus(1e-8),
        "(t-1)^4 - 1e-12": quartic_minus(1e-12),
        "(t-1)^4 - 1e-16": quartic_minus(1e-16),
        "close complex pair t^2-2t+1+1e-14": [1.0 + 1e-14, -2.0, 1.0],
    },
    "ill-conditioned": {
        "wilkinson 10": exact_expand(range(1, 11)),
        "wilkinson 20": exact_expand(range(1, 21)),
        "mignotte n=7 a=10": mignotte(7, 10),
        "mignotte n=10 a=100": mignotte(10, 100),
    },
    "extreme scales": {
        "span 1e150..1e-150": SPAN,
        "span 1e150..1e-150 random signs": [s * v for s, v in zip(_signs(len(SPAN)), SPAN)],
        "tiny leading 1e-300 t^3 + t + 1": [1.0, 1.0, 0.0, 1e-300],
        "tiny leading 1e-320 t^2 + t - 1": [-1.0, 1.0, 1e-320],
        "denormal 5e-324 t^2 - 5e-324": [-5e-324, 0.0, 5e-324],
        "denormal [1e-310, 1, 1e-310]": [1e-310, 1.0, 1e-310],
    },
    "zeros and imaginary roots": {
        "roots at zero t^3(t-1)": [0.0, 0.0, 0.0, -1.0, 1.0],
        "roots at zero t^2(t^2+1)": [0.0, 0.0, 1.0, 0.0, 1.0],
        "imaginary t^2+1": [1.0, 0.0, 1.0],
        "imaginary t^4+5t^2+4": [4.0, 0.0, 5.0, 0.0, 1.0],
        "imaginary t^2+1e-20": [1e-20, 0.0, 1.0],
    },
    "degenerate degrees": {
        "leading zeros [1,1,0,0]": [1.0, 1.0, 0.0, 0.0],
        "degree 0 [3]": [3.0],
        "degree 1 [2,-4]": [2.0, -4.0],
        "degree 1 [1,3]": [1.0, 3.0],
    },
}
#: Every case by name (the stability tests run them all).
CASES: dict[str, list[float]] = {name: c for family in FAMILIES.values() for name, c in family.items()}


# ---------------------------------------------------------------------------
# Truth and classification
# ---------------------------------------------------------------------------


def _truth_module():
    """tests/helpers/truth.py, the project's independent checker of argand's
    claims (the report is made from the repository root)."""
    root = Path.cwd()
    if not (root / "tests" / "helpers" / "truth.py").exists():
        raise RuntimeError("argand bench stability runs from the repository root: it checks argand's claims "
                           f"with tests/helpers/truth.py, not found under {root}")
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    from tests.helpers import truth

    return truth


def true_roots(coeffs: list[float], prec: int = 256) -> list[tuple[object, int]]:
    """(acb ball, multiplicity) of every finite root of the exact polynomial."""
    import flint

    values = list(coeffs)
    while values and values[-1] == 0.0:
        values.pop()
    if len(values) < 2:
        return []
    poly = flint.fmpq_poly([flint.fmpq(*Fraction(v).as_integer_ratio()) for v in values])
    old = flint.ctx.prec
    flint.ctx.prec = prec
    try:
        return [(ball, int(m)) for ball, m in poly.complex_roots()]
    finally:
        flint.ctx.prec = old


def accurate(approx: list[complex], truth: list[tuple[object, int]]) -> bool:
    """Every true root, with multiplicity, matched (greedily, nearest first)
    to its own approximation within TOLERANCE relative error, and no
    approximation left over."""
    wanted = [complex(float(b.real.mid()), float(b.imag.mid())) for b, m in truth for _ in range(m)]
    pool = [complex(z) for z in approx]
    if len(pool) != len(wanted) or not all(np.isfinite(z) for z in pool):
        return False
    for w in sorted(wanted, key=abs):
        j = min(range(len(pool)), key=lambda i: abs(pool[i] - w))
        if abs(pool[j] - w) > TOLERANCE * max(abs(w), 1e-300):
            return False
        pool.pop(j)
    return True


def classify_argand(coeffs: list[float], method: str, truth_mod) -> str:
    from argand.core import find_roots

    roots = find_roots(coeffs, method=method)
    if method != "unverified" and truth_mod.check_roots(coeffs, roots):
        return "wrong"
    if method != "unverified" and (len(roots) == 0 or roots.all_verified):
        return "proven" if len(roots) > 0 or not true_roots(coeffs) else "wrong"
    approx = [complex(roots.center[i]) for i in range(len(roots)) for _ in range(int(roots.count[i]))]
    return "correct, unproven" if accurate(approx, true_roots(coeffs)) else "flagged"


def classify_numpy(coeffs: list[float]) -> str:
    values = list(coeffs)
    while values and values[-1] == 0.0:
        values.pop()
    try:
        with np.errstate(all="ignore"):  # overflow on the extreme cases is part of the answer (inf: wrong)
            approx = np.roots(values[::-1]) if len(values) > 1 else np.array([])
    except np.linalg.LinAlgError:
        return "flagged"
    return "correct, unproven" if accurate(list(approx), true_roots(coeffs)) else "wrong"


def classify_flint(coeffs: list[float]) -> str:
    """acb_poly.roots() at its defaults: isolating balls, or an exception
    when it cannot isolate (a multiple root, a cluster)."""
    import flint

    values = list(coeffs)
    while values and values[-1] == 0.0:
        values.pop()
    try:
        found = flint.acb_poly([flint.acb(v) for v in values]).roots() if len(values) > 1 else []
    except ValueError:
        return "flagged"
    truth = true_roots(coeffs)
    if sum(m for _, m in truth) != len(found):
        return "wrong"
    for ball in found:
        inside = [t for t, m in truth if ball.overlaps(t)]
        if len(inside) != 1 or not ball.contains(inside[0]):
            return "wrong"
    return "proven"


def classify_mpmath(coeffs: list[float]) -> str:
    import mpmath

    values = list(coeffs)
    while values and values[-1] == 0.0:
        values.pop()
    if len(values) < 2:  # a constant: no roots, nothing to prove
        return "correct, unproven" if not true_roots(coeffs) else "wrong"
    import inspect

    # Newer mpmath takes ascending coefficients (asc=True) and warns on the old order.
    args = (values, {"asc": True}) if "asc" in inspect.signature(mpmath.polyroots).parameters else (values[::-1], {})
    try:  # as argand bench roots runs it: a second try with more room, as its docs advise
        try:
            approx = mpmath.polyroots(args[0], maxsteps=200, extraprec=30, **args[1])
        except mpmath.libmp.NoConvergence:
            approx = mpmath.polyroots(args[0], maxsteps=2000, extraprec=200, **args[1])
    except mpmath.libmp.NoConvergence:
        return "flagged"
    return "correct, unproven" if accurate([complex(z) for z in approx], true_roots(coeffs)) else "wrong"


def classify_mpsolve(results: dict, coeffs: list[float]) -> str:
    """MPSolve's inclusion discs: proven when disjoint and each holds exactly
    one true root (with its multiplicity counted), flagged when they overlap
    (a cluster it did not separate), wrong when one holds no true root."""
    import flint

    if results is None:
        return "flagged"
    truth = true_roots(coeffs)
    centers, radii = results
    # The worker hands over MPSolve's centers rounded to doubles; the disc
    # around the double center that holds MPSolve's own disc is wider by the
    # rounding (half an ulp per component, and the subnormal floor).
    radii = [r + abs(c) * 2.0**-52 + 2.0**-1073 for c, r in zip(centers, radii)]
    if sum(m for _, m in truth) != len(centers):
        return "wrong"

    def holds(c: complex, r: float, ball) -> bool | None:
        d = abs(ball - flint.acb(c.real, c.imag))
        return True if d <= flint.arb(r) else (False if d > flint.arb(r) else None)

    overlap = False
    for i, (c, r) in enumerate(zip(centers, radii)):
        if not math.isfinite(r) or not all(map(math.isfinite, (c.real, c.imag))):
            return "flagged"
        inside = [holds(c, r, t) for t, _ in truth]
        if not any(v is not False for v in inside):
            return "wrong"
        for c2, r2 in list(zip(centers, radii))[i + 1:]:
            overlap |= abs(c - c2) <= r + r2
        if sum(1 for v in inside if v) != 1:
            overlap = True
    return "flagged" if overlap else "proven"


def run_mpsolve(cases: dict[str, list[float]]) -> tuple[dict, str]:
    """MPSolve on every case with a finite degree >= 1, in the system Python
    (Debian's python3-mpsolve), or ({}, why not)."""
    from argand.bench.roots import SYSTEM_PYTHON, mpsolve_available

    ok, note = mpsolve_available()
    if not ok:
        return {}, note
    names, polys = [], []
    for name, coeffs in cases.items():
        values = list(coeffs)
        while values and values[-1] == 0.0:
            values.pop()
        if len(values) > 1:
            names.append(name)
            polys.append(values)
    worker = Path(__file__).with_name("mpsolve_worker.py")
    out = {}
    for name, poly in zip(names, polys):  # one at a time: a crash on one case does not hide the others
        proc = subprocess.run([SYSTEM_PYTHON, str(worker)], input=json.dumps({"polys": [poly], "repeats": 1}),
                              capture_output=True, text=True, timeout=120)
        if proc.returncode != 0:
            out[name] = None
            continue
        r = json.loads(proc.stdout)
        out[name] = ([complex(a, b) for a, b in r["roots"][0]], [float(x) for x in r["radii"][0]])
    return out, note


def stability_table(progress=lambda m: None) -> dict:
    """{family: {case: {method: class}}} and the notes on how it was made."""
    truth_mod = _truth_module()
    progress("stability: MPSolve")
    mps, mps_note = run_mpsolve(CASES)
    table: dict = {}
    for family, cases in FAMILIES.items():
        progress(f"stability: {family}")
        table[family] = {}
        for name, coeffs in cases.items():
            row = {m: classify_argand(coeffs, m, truth_mod) for m in OUR_METHODS}
            row["numpy"] = classify_numpy(coeffs)
            row["python-flint"] = classify_flint(coeffs)
            row["mpmath"] = classify_mpmath(coeffs)
            if mps:
                finite = true_roots(coeffs)
                row["MPSolve"] = classify_mpsolve(mps.get(name), coeffs) if name in mps else (
                    "proven" if not finite else "flagged")
            table[family][name] = row
    return {"table": table, "tolerance": TOLERANCE, "mpsolve": mps_note if mps else f"unavailable: {mps_note}"}


# ---------------------------------------------------------------------------
# The picture: unverified vs auto on a preset and a degree-6 surface
# ---------------------------------------------------------------------------

#: A preset with singular lines, and a degree-6 surface (argand.bench.ray_samples).
PICTURE_SCENES = {"steiner": None, "sextic x^6+y^6+z^6": "x^6 + y^6 + z^6 - 20000"}


def picture(path: Path, size: int = 256, delta: float = 0.0) -> dict:
    """Each scene rendered with method="unverified" and "auto", side by side,
    and a third panel: auto's image with the pixels where the two differ
    (hit or miss, or a colour differing by more than 1/255) in magenta.
    Returns the differing shares."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from argand.render import FrameParams, render_frame
    from argand.media.frame_files import to_srgb8
    from argand.scene import load_scene, scene_from_dict

    shares = {}
    fig, axes = plt.subplots(len(PICTURE_SCENES), 3, figsize=(10.5, 3.6 * len(PICTURE_SCENES)), squeeze=False)
    for row, (name, surface) in zip(axes, PICTURE_SCENES.items()):
        scene = load_scene(name) if surface is None else scene_from_dict({"objects": [{"surface": surface, "clip_radius": 8}]})
        images = {}
        for method in ("unverified", "auto"):
            r = render_frame(scene, FrameParams(delta=delta, width=size, height=size, method=method), workers=1)
            images[method] = (to_srgb8(r.rgba), r.rgba[..., 3] > 0, r.certified_share)
        (u, u_hit, _), (a, a_hit, cert) = images["unverified"], images["auto"]
        differ = (u_hit != a_hit) | (np.abs(u[..., :3].astype(int) - a[..., :3].astype(int)).max(axis=-1) > 1)
        shares[name] = {"differing_share": float(differ.mean()), "differing_pixels": int(differ.sum()),
                        "auto_certified_share": cert}
        marked = a[..., :3].copy()
        marked[differ] = (255, 0, 255)
        for ax, img, title in ((row[0], u[..., :3], "unverified"), (row[1], a[..., :3], "auto (verified)"),
                               (row[2], marked, f"differing pixels: {int(differ.sum())} "
                                               f"({100 * differ.mean():.2f}%)")):
            ax.imshow(img)
            ax.set_title(f"{name}: {title}", fontsize=9)
            ax.axis("off")
    fig.suptitle(f"the same frame (delta = {delta:.4f}, {size}x{size}) without and with proofs; magenta: the pixels that differ")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return shares


def bench_stability(out_dir: Path = Path("docs/bench"), smoke: bool = False, progress=lambda m: None) -> dict:
    report = {"benchmark": "stability", "machine": machine_info(), **stability_table(progress)}
    progress("stability: the picture")
    out_dir.mkdir(parents=True, exist_ok=True)
    report["picture"] = picture(out_dir / "stability.png", size=96 if smoke else 256)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "stability.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "stability.md").write_text(markdown(report))
    return report


def markdown(report: dict) -> str:
    methods = list(next(iter(next(iter(report["table"].values())).values())))
    counts = {m: {c: 0 for c in CLASSES} for m in methods}
    lines = ["| family | case | " + " | ".join(methods) + " |", "|---|---|" + "---|" * len(methods)]
    short = {"proven": "✅ proven", "correct, unproven": "◻ correct", "flagged": "⚠ flagged", "wrong": "❌ wrong"}
    for family, cases in report["table"].items():
        for name, row in cases.items():
            lines.append(f"| {family} | {name} | " + " | ".join(short[row[m]] for m in methods) + " |")
            for m in methods:
                counts[m][row[m]] += 1
    notes = {"MPSolve": "its Python binding returns no entry for a root at zero (1 root for t^3(t-1)), and its "
                        "centers come as doubles: each disc is widened by the rounding"}
    lines += ["", "| method | " + " | ".join(CLASSES) + " |", "|---|" + "---:|" * len(CLASSES)]
    for m in methods:
        lines.append(f"| {m} | " + " | ".join(str(counts[m][c]) for c in CLASSES) + " |")
    lines += ["", f"✅ correct and proven; ◻ correct (every root within {report['tolerance']:g} relative error) but unproven; "
              "⚠ not correct but honestly flagged (an unverified disc or cluster, an exception, overlapping inclusion "
              "discs); ❌ a false claim, or an inaccurate answer given as right. MPSolve: " + report["mpsolve"] + "; "
              + notes["MPSolve"] + "."]
    return "\n".join(lines) + "\n"
