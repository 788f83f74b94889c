"""`argand bench roots`: speed and accuracy of every method against numpy,
python-flint (Arb), mpmath and MPSolve, on the same polynomials, in one run.

Reported as ratios: absolute times on shared, noisy machines mean little.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from fractions import Fraction
from pathlib import Path
from typing import Callable

import numpy as np

from argand.bench import machine_info, median_time
from argand.core import find_roots_batch

OUR_METHODS = ("auto", "smith", "paper", "unverified")
SYSTEM_PYTHON = "/usr/bin/python3"


def random_polys(rng: np.random.Generator, count: int, degrees: tuple[int, int]) -> list[np.ndarray]:
    """Standard normal coefficients; degrees drawn uniformly in [lo, hi]."""
    lo, hi = degrees
    return [rng.standard_normal(int(rng.integers(lo, hi + 1)) + 1) for _ in range(count)]


def by_degree(polys: list[np.ndarray]) -> dict[int, np.ndarray]:
    groups: dict[int, list[np.ndarray]] = {}
    for p in polys:
        groups.setdefault(len(p) - 1, []).append(p)
    return {n: np.array(rows) for n, rows in groups.items()}


# ---------------------------------------------------------------------------
# Truth and accuracy
# ---------------------------------------------------------------------------


def true_roots(coeffs: np.ndarray) -> np.ndarray:
    import flint

    poly = flint.fmpq_poly([flint.fmpq(*Fraction(float(c)).as_integer_ratio()) for c in coeffs])
    old = flint.ctx.prec
    flint.ctx.prec = 128
    try:
        out = []
        for ball, mult in poly.complex_roots():
            z = complex(float(ball.real.mid()), float(ball.imag.mid()))
            out += [z] * int(mult)
        return np.array(out)
    finally:
        flint.ctx.prec = old


def accuracy(approx: list[np.ndarray], radii: list[np.ndarray] | None, truth: list[np.ndarray]) -> dict:
    """Relative error of each approximation against its nearest true root,
    and radius / |root| where radii are given."""
    errors, rel_radii = [], []
    for k, (a, t) in enumerate(zip(approx, truth)):
        a = np.asarray(a, dtype=complex)
        for i, z in enumerate(a):
            if not np.isfinite(z):
                continue
            j = int(np.argmin(np.abs(t - z)))
            scale = max(abs(t[j]), 1e-300)
            errors.append(abs(z - t[j]) / scale)
            if radii is not None:
                rel_radii.append(float(radii[k][i]) / scale)
    out = {
        "median_rel_error": float(np.median(errors)) if errors else None,
        "max_rel_error": float(np.max(errors)) if errors else None,
    }
    if radii is not None and rel_radii:
        finite = [r for r in rel_radii if math.isfinite(r)]
        out["median_rel_radius"] = float(np.median(finite)) if finite else None
        out["max_rel_radius"] = float(np.max(finite)) if finite else None
    return out


# ---------------------------------------------------------------------------
# Contenders
# ---------------------------------------------------------------------------


def run_ours(method: str, polys: list[np.ndarray], repeats: int):
    groups = by_degree(polys)
    seconds = 0.0
    for n, mat in groups.items():
        seconds += median_time(lambda: find_roots_batch(mat, method), repeats)
    # Results in the original order (for accuracy), one batch per degree.
    approx, radii, verified_rows = [], [], 0
    results = {n: find_roots_batch(mat, method) for n, mat in groups.items()}
    cursor = {n: 0 for n in groups}
    for p in polys:
        n = len(p) - 1
        b = results[n]
        r = b.row(cursor[n])
        cursor[n] += 1
        # A disc with count m stands for m roots: repeat its centre.
        approx.append(np.repeat(r.center, r.count))
        radii.append(np.repeat(r.radius, r.count))
        verified_rows += bool(r.all_verified)
    return seconds, approx, radii, verified_rows / len(polys)


def run_numpy(polys: list[np.ndarray], repeats: int):
    groups = by_degree(polys)

    def companion_eigvals(mat: np.ndarray) -> np.ndarray:
        n = mat.shape[1] - 1
        comp = np.zeros((len(mat), n, n))
        comp[:, 1:, :-1] = np.eye(n - 1)
        comp[:, :, -1] = -mat[:, :-1] / mat[:, -1:]
        return np.linalg.eigvals(comp)

    seconds = sum(median_time(lambda: companion_eigvals(mat), repeats) for mat in groups.values())
    eig = {n: companion_eigvals(mat) for n, mat in groups.items()}
    cursor = {n: 0 for n in groups}
    approx = []
    for p in polys:
        n = len(p) - 1
        approx.append(eig[n][cursor[n]])
        cursor[n] += 1
    return seconds, approx, None


def run_flint(polys: list[np.ndarray], repeats: int, tol: float | None = None):
    """acb_poly.roots() on prebuilt polynomials (construction not timed);
    tol=None is flint's default (isolation, radii ~1e-8 at 53 bits), a tol
    refines to about our accuracy."""
    import flint

    prepared = [flint.acb_poly([flint.acb(float(c)) for c in p]) for p in polys]

    def solve(p):
        return p.roots(tol, maxprec=1024) if tol is not None else p.roots()

    seconds = median_time(lambda: [solve(p) for p in prepared], repeats)
    approx, radii = [], []
    for p in prepared:
        r = solve(p)
        approx.append(np.array([complex(float(z.real.mid()), float(z.imag.mid())) for z in r]))
        radii.append(np.array([float(z.rad()) for z in r]))
    return seconds, approx, radii


def run_mpmath(polys: list[np.ndarray], repeats: int):
    import mpmath

    def solve(p):
        return mpmath.polyroots([float(c) for c in p[::-1]], maxsteps=200, extraprec=30)

    seconds = median_time(lambda: [solve(p) for p in polys], repeats)
    approx = [np.array([complex(z) for z in solve(p)]) for p in polys]
    return seconds, approx, None


def mpsolve_available() -> tuple[bool, str]:
    if not Path(SYSTEM_PYTHON).exists():
        return False, f"{SYSTEM_PYTHON} not found"
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import mpsolve"], capture_output=True, text=True)
    if probe.returncode != 0:
        return False, "Debian package python3-mpsolve not installed (make setup installs it as root)"
    return True, "python3-mpsolve (libmps 3) under Debian's python3, timed inside that process"


def run_mpsolve(polys: list[np.ndarray], repeats: int):
    worker = Path(__file__).with_name("mpsolve_worker.py")
    job = json.dumps({"polys": [[float(c) for c in p] for p in polys], "repeats": repeats})
    proc = subprocess.run([SYSTEM_PYTHON, str(worker)], input=job, capture_output=True, text=True, check=True)
    out = json.loads(proc.stdout)
    approx = [np.array([complex(re, im) for re, im in r]) for r in out["roots"]]
    radii = [np.array(r, dtype=float) for r in out["radii"]]
    return out["seconds"], approx, radii


# ---------------------------------------------------------------------------
# The benchmark
# ---------------------------------------------------------------------------


def bench_roots(
    count: int = 20000,
    seed: int = 1,
    out_dir: Path = Path("docs/bench"),
    smoke: bool = False,
    progress: Callable[[str], None] = lambda msg: None,
) -> dict:
    rng = np.random.default_rng(seed)
    if smoke:
        count = min(count, 200)
    sizes = {
        "ours": count,
        "numpy": count,
        "flint": max(20, count // 10),
        "mpsolve": max(10, count // 40),
        "mpmath": max(10, count // 100),
        "truth": max(20, min(count, 2000 if not smoke else 50)),
    }
    repeats = 3 if smoke else 5
    suites = {
        "quartic": random_polys(rng, count, (4, 4)),
        "mixed_2_8": random_polys(rng, count, (2, 8)),
    }
    have_mpsolve, mpsolve_note = mpsolve_available()
    report: dict = {
        "benchmark": "roots",
        "machine": machine_info(),
        "versions": versions(),
        "sizes": sizes,
        "repeats": repeats,
        "mpsolve": {"available": have_mpsolve, "note": mpsolve_note},
        "suites": {},
    }
    for suite, polys in suites.items():
        progress(f"{suite}: truth for {sizes['truth']} polynomials (python-flint, 128 bits, exact rationals)")
        truth_idx = list(range(sizes["truth"]))
        truth = [true_roots(polys[i]) for i in truth_idx]
        rows: dict[str, dict] = {}

        def record(name: str, n_polys: int, seconds: float, approx, radii, extra: dict | None = None) -> None:
            k = min(len(approx), len(truth))
            acc = accuracy(approx[:k], radii[:k] if radii is not None else None, truth[:k])
            rows[name] = {"polynomials": n_polys, "ns_per_poly": seconds / n_polys * 1e9, **acc, **(extra or {})}

        # Warm the process up once (allocator, caches, clock) so that the
        # first method timed does not pay for it.
        for method in OUR_METHODS:
            run_ours(method, polys[: sizes["ours"]], 1)
        for method in OUR_METHODS:
            progress(f"{suite}: argand {method}")
            seconds, approx, radii, verified = run_ours(method, polys[: sizes["ours"]], repeats)
            record(f"argand-{method}", sizes["ours"], seconds, approx, radii if method != "unverified" else None,
                   {"fully_verified_share": verified})
        progress(f"{suite}: numpy companion eigenvalues")
        seconds, approx, radii = run_numpy(polys[: sizes["numpy"]], repeats)
        record("numpy-eigvals", sizes["numpy"], seconds, approx, None)
        progress(f"{suite}: python-flint acb_poly.roots")
        seconds, approx, radii = run_flint(polys[: sizes["flint"]], max(1, repeats // 2))
        record("flint-acb_poly.roots", sizes["flint"], seconds, approx, radii)
        progress(f"{suite}: python-flint acb_poly.roots(tol=1e-14), accuracy matched")
        seconds, approx, radii = run_flint(polys[: sizes["flint"]], max(1, repeats // 2), tol=1e-14)
        record("flint-acb_poly.roots(tol=1e-14)", sizes["flint"], seconds, approx, radii)
        progress(f"{suite}: mpmath polyroots")
        seconds, approx, radii = run_mpmath(polys[: sizes["mpmath"]], 1)
        record("mpmath-polyroots", sizes["mpmath"], seconds, approx, None)
        if have_mpsolve:
            progress(f"{suite}: MPSolve")
            seconds, approx, radii = run_mpsolve(polys[: sizes["mpsolve"]], max(1, repeats // 2))
            record("mpsolve", sizes["mpsolve"], seconds, approx, radii)
        auto = rows["argand-auto"]["ns_per_poly"]
        ratios = {name: row["ns_per_poly"] / auto for name, row in rows.items() if name != "argand-auto"}
        report["suites"][suite] = {"results": rows, "slowdown_vs_auto": ratios}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "roots.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "roots.md").write_text(markdown(report))
    chart(report, out_dir / "roots.png")
    return report


def markdown(report: dict) -> str:
    """The results as Markdown tables (for the README)."""
    lines = []
    for suite, data in report["suites"].items():
        rows = data["results"]
        auto = rows["argand-auto"]["ns_per_poly"]
        lines += [
            f"**{suite}** ({rows['argand-auto']['polynomials']} polynomials; accuracy against the exact roots)",
            "",
            "| method | ns / polynomial | time ÷ auto | median radius / \\|root\\| | median error | max error | fully verified |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for name, row in rows.items():
            def fmt(key):
                v = row.get(key)
                return f"{v:.1e}" if v is not None else ""
            verified = f"{100 * row['fully_verified_share']:.2f}%" if "fully_verified_share" in row else ""
            lines.append(
                f"| {name} | {row['ns_per_poly']:.0f} | {row['ns_per_poly'] / auto:.1f} | {fmt('median_rel_radius')} "
                f"| {fmt('median_rel_error')} | {fmt('max_rel_error')} | {verified} |"
            )
        lines.append("")
    return "\n".join(lines)


def versions() -> dict:
    import flint
    import mpmath

    return {"numpy": np.__version__, "python-flint": flint.__version__, "mpmath": mpmath.__version__}


def chart(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    suites = list(report["suites"])
    floor = 1e-17  # below double precision: shown at the floor, labelled "<="
    fig, axes = plt.subplots(1, len(suites), figsize=(6.4 * len(suites), 5.0), squeeze=False)
    for ax, suite in zip(axes[0], suites):
        rows = report["suites"][suite]["results"]
        for k, (name, row) in enumerate(sorted(rows.items(), key=lambda kv: kv[1]["ns_per_poly"])):
            radius = row.get("median_rel_radius")
            y = radius if radius is not None else row.get("median_rel_error")
            if y is None:
                continue
            ours = name.startswith("argand")
            shown = max(y, floor)
            ax.scatter(row["ns_per_poly"], shown, marker="o" if ours else "s", s=70,
                       facecolors=("C0" if ours else "C1") if radius is not None else "none",
                       edgecolors="C0" if ours else "C1", zorder=3)
            label = name + (" (<=)" if y < floor else "")
            ax.annotate(label, (row["ns_per_poly"], shown), textcoords="offset points",
                        xytext=(6, 8 if k % 2 == 0 else -12), fontsize=8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(floor / 3, 1e-6)
        ax.set_xlabel("time per polynomial (ns, log scale)")
        ax.set_ylabel("median relative radius (filled) / error (hollow)")
        ax.set_title(f"{suite}: speed vs accuracy")
        ax.grid(True, which="major", alpha=0.3)
    fig.suptitle("argand bench roots — same polynomials, same run; lower-left is better")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
