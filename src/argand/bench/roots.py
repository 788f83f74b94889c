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
from argand.core import batch_kernel, find_roots_batch

OUR_METHODS = ("auto", "smith", "paper", "unverified")
#: Methods also timed with kernel="scalar" (find_roots row by row, the
#: reference and today's path before the batched kernels): rows
#: "argand-<method> (scalar)".
SCALAR_REFERENCE = ("auto", "smith", "unverified")
#: How the headline names each suite.
SUITE_LABELS = {"quartic": "quartics", "mixed_2_8": "mixed degrees 2-8", "rays": "real ray polynomials",
                "degree_10": "degree 10", "degree_12": "degree 12"}
#: Suites of the kernel comparison only (kernel_table, no contenders): the
#: kernels' top degrees (surfaces go to degree 12). Degrees (lo, hi).
KERNEL_ONLY_SUITES = {"degree_10": (10, 10), "degree_12": (12, 12)}
#: What each row measures (written into roots.json).
CONTENDERS = {
    "argand-*": "argand.core.find_roots_batch(matrix, method) on one (N, n+1) batch per degree: the batched "
                "kernel of the instruction set named in `batch_kernel` for degrees 1-12 (auto, smith, unverified), "
                "rows it does not prove answered by the scalar path",
    "argand-* (scalar)": "the same call with kernel='scalar': find_roots row by row (the reference)",
    "numpy-eigvals": "numpy: build the (N, n, n) companion matrices and np.linalg.eigvals on the stack (both timed)",
    "flint-acb_poly.roots": "python-flint acb_poly(coeffs).roots() per polynomial, defaults (53 bits, isolation); "
                            "acb_poly construction not timed",
    "flint-acb_poly.roots(tol=1e-14)": "the same refined with roots(tol=1e-14, maxprec=1024)",
    "mpmath-polyroots": "mpmath.polyroots(maxsteps=200, extraprec=30) per polynomial, on a subset",
    "mpsolve": "MPSolve (libmps) through Debian's python3-mpsolve, per polynomial, on a subset",
}
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


def run_ours(method: str, polys: list[np.ndarray], repeats: int, kernel: str = "auto"):
    groups = by_degree(polys)
    seconds = 0.0
    for n, mat in groups.items():
        seconds += median_time(lambda: find_roots_batch(mat, method, kernel), repeats)
    # Results in the original order (for accuracy), one batch per degree.
    approx, radii, verified_rows = [], [], 0
    results = {n: find_roots_batch(mat, method, kernel) for n, mat in groups.items()}
    kept = sum(b.lanes_kept for b in results.values())
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
    kernels = sorted({b.kernel for b in results.values()})
    return seconds, approx, radii, verified_rows / len(polys), kept / len(polys), "+".join(kernels)


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
        try:
            return p.roots(tol, maxprec=1024) if tol is not None else p.roots()
        except ValueError:  # "failed to converge": a multiple root or a cluster it cannot isolate
            return None

    seconds = median_time(lambda: [solve(p) for p in prepared], repeats)
    approx, radii, failed = [], [], 0
    for p in prepared:
        r = solve(p)
        failed += r is None
        approx.append(np.array([complex(float(z.real.mid()), float(z.imag.mid())) for z in r or []]))
        radii.append(np.array([float(z.rad()) for z in r or []]))
    return seconds, approx, radii, failed / max(len(prepared), 1)


def run_mpmath(polys: list[np.ndarray], repeats: int):
    import mpmath

    def solve(p):
        coeffs = [float(c) for c in p[::-1]]
        try:
            return mpmath.polyroots(coeffs, maxsteps=200, extraprec=30)
        except mpmath.libmp.NoConvergence:  # rare: give it more room, as its docs advise
            try:
                return mpmath.polyroots(coeffs, maxsteps=2000, extraprec=200)
            except mpmath.libmp.NoConvergence:  # no answer (the accuracy counts none for it)
                return []

    seconds = median_time(lambda: [solve(p) for p in polys], repeats)
    approx = [np.array([complex(z) for z in solve(p)]) for p in polys]
    return seconds, approx, None


def mpsolve_available() -> tuple[bool, str]:
    if not Path(SYSTEM_PYTHON).exists():
        return False, f"{SYSTEM_PYTHON} not found"
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import mpsolve"], capture_output=True, text=True)
    if probe.returncode != 0:
        return False, "Debian package python3-mpsolve not installed (make setup installs it as root)"
    return True, (
        "python3-mpsolve (libmps 3, Debian) run by Debian's python3 in one worker process per suite; "
        "the time is measured inside that process around the solves only (process start, JSON and "
        "import excluded); Context.solve() defaults: secular-equation algorithm (SECULAR_GA), output "
        "goal APPROXIMATE at 100 bits, radii from get_inclusion_radii()"
    )


def run_mpsolve(polys: list[np.ndarray], repeats: int):
    worker = Path(__file__).with_name("mpsolve_worker.py")
    job = json.dumps({"polys": [[float(c) for c in p] for p in polys], "repeats": repeats})
    proc = subprocess.run([SYSTEM_PYTHON, str(worker)], input=job, capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
        raise RuntimeError(f"MPSolve worker failed: {tail}")
    out = json.loads(proc.stdout)
    approx = [np.array([complex(re, im) for re, im in r]) for r in out["roots"]]
    radii = [np.array(r, dtype=float) for r in out["radii"]]
    return out["seconds"], approx, radii


def kernel_table(polys: list[np.ndarray], rounds: int) -> dict:
    """The batched kernels against the scalar path on the same batches, timed
    in process CPU time (time.process_time: the time this process ran, so a
    busy shared machine that preempts it does not count), best of `rounds`,
    the configurations interleaved round by round so that drifts in the
    machine's speed hit them alike. Methods auto and unverified; kernels
    "scalar" and every instruction set this CPU runs."""
    import time

    from argand.core import KERNELS

    best = batch_kernel()
    isas = [k for k in ("avx512", "avx2", "sse2") if k in KERNELS and _runs(k)]
    configs = [(m, k) for m in ("auto", "unverified") for k in ["scalar", *isas]]
    groups = by_degree(polys)
    times = {c: float("inf") for c in configs}
    for mat in groups.values():  # warm-up
        for m, k in configs:
            find_roots_batch(mat, m, k)
    for _ in range(rounds):
        for c in configs:
            t = time.process_time()
            for mat in groups.values():
                find_roots_batch(mat, *c)
            times[c] = min(times[c], time.process_time() - t)
    ns = {f"{m}/{k}": times[(m, k)] / len(polys) * 1e9 for m, k in configs}
    return {
        "ns_per_poly_cpu": ns,
        "best_kernel": best,
        "auto_speedup_vs_scalar_auto": ns["auto/scalar"] / ns[f"auto/{best}"],
        "auto_speedup_vs_scalar_unverified": ns["unverified/scalar"] / ns[f"auto/{best}"],
        "rounds": rounds,
    }


def _runs(kernel: str) -> bool:
    try:
        find_roots_batch(np.array([[1.0, 0.0, 1.0]]), "auto", kernel)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------------
# The benchmark
# ---------------------------------------------------------------------------


def bench_roots(
    count: int = 20000,
    seed: int = 1,
    out_dir: Path = Path("docs/bench"),
    smoke: bool = False,
    progress: Callable[[str, int, int], None] = lambda msg, done, total: None,
) -> dict:
    """Run the benchmark, write roots.json, roots.md and roots.png into
    out_dir and return the report. ``progress(message, steps_done,
    steps_total)`` is called before each step (for a progress bar)."""
    if count < 1:
        raise ValueError(f"count must be at least 1, got {count}")
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
    # Timed repetitions after one untimed warm-up run; the median is kept.
    timed_runs = {"ours": repeats, "numpy": repeats, "flint": 3, "mpsolve": 3, "mpmath": 1}
    from argand.bench.ray_samples import ray_polynomials, summary

    # Real ray polynomials: every preset and surfaces of degree 5 to 8,
    # silhouettes and uncertified pixels included (argand.bench.ray_samples).
    rays, ray_origin = ray_polynomials(per_kind=3 if smoke else 40, size=48 if smoke else 96)
    order = rng.permutation(len(rays))  # the contenders run on leading subsets: every scene in each
    rays, ray_origin = [rays[i] for i in order], [ray_origin[i] for i in order]
    suites = {
        "quartic": random_polys(rng, count, (4, 4)),
        "mixed_2_8": random_polys(rng, count, (2, 8)),
        "rays": rays,
    }
    have_mpsolve, mpsolve_note = mpsolve_available()
    report: dict = {
        "benchmark": "roots",
        "machine": machine_info(),
        "versions": versions(),
        "sizes": sizes,  # per suite: at most these, at most the suite's size
        "repeats": timed_runs,
        "mpsolve": {"available": have_mpsolve, "note": mpsolve_note},
        "batch_kernel": batch_kernel(),
        "contenders": CONTENDERS,
        "accuracy": (
            "against python-flint fmpq_poly.complex_roots() on the exact rational value of the double "
            "coefficients at 128 bits, on the first `truth` polynomials of each suite; every computed "
            "root (a disc of count m counts m times) is matched to its nearest true root; rel error = "
            "|z - root| / |root|, rel radius = radius / |root|; an error of 0 means the correctly "
            "rounded double"
        ),
        "suites": {},
        "rays": dict(summary(ray_origin), note="the rays suite: primary rays of every preset and of surfaces of "
                     "degree 5 to 8 (argand.bench.ray_samples.HIGH_DEGREE) at delta 0, pi/18, pi/9; silhouette, uncertified, "
                     "random-hit and random pixels; one polynomial per object"),
    }
    steps_per_suite = 2 + len(OUR_METHODS) + 4 + (1 if have_mpsolve else 0)
    total = steps_per_suite * len(suites) + 2
    done = 0

    def step(message: str) -> None:
        nonlocal done
        progress(message, done, total)
        done += 1

    full_sizes = dict(sizes)
    for suite, polys in suites.items():
        sizes = {k: min(v, len(polys)) for k, v in full_sizes.items()}
        step(f"{suite}: truth for {sizes['truth']} polynomials (python-flint, 128 bits, exact rationals)")
        truth_idx = list(range(sizes["truth"]))
        truth = [true_roots(polys[i]) for i in truth_idx]
        rows: dict[str, dict] = {}

        def record(name: str, n_polys: int, seconds: float, approx, radii, extra: dict | None = None) -> None:
            k = min(len(approx), len(truth))
            acc = accuracy(approx[:k], radii[:k] if radii is not None else None, truth[:k])
            rows[name] = {"polynomials": n_polys, "ns_per_poly": seconds / n_polys * 1e9,
                          "accuracy_polynomials": k, **acc, **(extra or {})}

        # Warm the process up once (allocator, caches, clock) so that the
        # first method timed does not pay for it.
        step(f"{suite}: warm-up")
        for method in OUR_METHODS:
            run_ours(method, polys[: sizes["ours"]], 1)
        for method in OUR_METHODS:
            step(f"{suite}: argand {method}")
            runs = [("auto", f"argand-{method}")]
            if method in SCALAR_REFERENCE:
                runs.append(("scalar", f"argand-{method} (scalar)"))
            for kernel, name in runs:
                seconds, approx, radii, verified, kept, used = run_ours(method, polys[: sizes["ours"]], repeats, kernel)
                record(name, sizes["ours"], seconds, approx, radii if method != "unverified" else None,
                       {"fully_verified_share": verified, "kernel": used, "batched_share": kept})
        step(f"{suite}: numpy companion eigenvalues")
        seconds, approx, radii = run_numpy(polys[: sizes["numpy"]], repeats)
        record("numpy-eigvals", sizes["numpy"], seconds, approx, None)
        step(f"{suite}: python-flint acb_poly.roots")
        seconds, approx, radii, failed = run_flint(polys[: sizes["flint"]], timed_runs["flint"])
        record("flint-acb_poly.roots", sizes["flint"], seconds, approx, radii, {"failed_share": failed})
        step(f"{suite}: python-flint acb_poly.roots(tol=1e-14), accuracy matched")
        seconds, approx, radii, failed = run_flint(polys[: sizes["flint"]], timed_runs["flint"], tol=1e-14)
        record("flint-acb_poly.roots(tol=1e-14)", sizes["flint"], seconds, approx, radii, {"failed_share": failed})
        step(f"{suite}: mpmath polyroots")
        seconds, approx, radii = run_mpmath(polys[: sizes["mpmath"]], timed_runs["mpmath"])
        record("mpmath-polyroots", sizes["mpmath"], seconds, approx, None)
        if report["mpsolve"]["available"]:
            step(f"{suite}: MPSolve")
            try:
                seconds, approx, radii = run_mpsolve(polys[: sizes["mpsolve"]], timed_runs["mpsolve"])
            except (RuntimeError, subprocess.TimeoutExpired, ValueError) as exc:
                report["mpsolve"] = {"available": False, "note": f"{mpsolve_note}; but it failed here: {exc}"}
            else:
                record("mpsolve", sizes["mpsolve"], seconds, approx, radii)
        elif have_mpsolve:
            step(f"{suite}: MPSolve (skipped: failed before)")
        auto = rows["argand-auto"]["ns_per_poly"]
        ratios = {name: row["ns_per_poly"] / auto for name, row in rows.items() if name != "argand-auto"}
        report["suites"][suite] = {"results": rows, "slowdown_vs_auto": ratios,
                                   "kernels": kernel_table(polys[: sizes["ours"]], 3 if smoke else 7)}
    step(f"kernels only: {', '.join(KERNEL_ONLY_SUITES)}")
    report["kernel_suites"] = {name: kernel_table(random_polys(rng, count, degrees), 3 if smoke else 7)
                               for name, degrees in KERNEL_ONLY_SUITES.items()}
    report["headline"] = headline(report)
    step("writing JSON, Markdown and the chart")
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "roots.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "roots.md").write_text(markdown(report))
    chart(report, out_dir / "roots.png")
    progress("done", total, total)
    return report


def headline(report: dict) -> list[str]:
    """One sentence per comparison: how many times faster argand auto is
    than each alternative, per suite ("x times faster" = their time / ours)."""
    names = {
        "flint-acb_poly.roots": "python-flint acb_poly.roots()",
        "flint-acb_poly.roots(tol=1e-14)": "python-flint acb_poly.roots(tol=1e-14)",
        "numpy-eigvals": "numpy batched companion eigvals",
        "mpmath-polyroots": "mpmath polyroots",
        "mpsolve": "MPSolve",
        "argand-paper": "argand paper",
    }
    lines = []
    for suite, data in report["suites"].items():
        label = SUITE_LABELS.get(suite, suite)
        ratios = data["slowdown_vs_auto"]
        for key, text in names.items():
            if key in ratios:
                lines.append(f"auto is {ratios[key]:.1f} times faster than {text} on {label}")
        if "argand-unverified" in ratios:
            lines.append(f"the proof costs {1 / ratios['argand-unverified']:.2f}x the unverified time on {label}")
        if "kernels" in data:
            lines.append(_kernel_line(data["kernels"], label))
    for suite, k in report.get("kernel_suites", {}).items():
        lines.append(_kernel_line(k, SUITE_LABELS.get(suite, suite)))
    return lines


def _kernel_line(k: dict, label: str) -> str:
    ns = k["ns_per_poly_cpu"][f"auto/{k['best_kernel']}"]
    return (
        f"the batched kernel ({k['best_kernel']}) makes auto {k['auto_speedup_vs_scalar_auto']:.1f} times "
        f"faster than the scalar auto, and {k['auto_speedup_vs_scalar_unverified']:.1f} times faster than the "
        f"scalar unverified Aberth, on {label} ({ns:.0f} ns of CPU time per verified polynomial)"
    )


def markdown(report: dict) -> str:
    """The results as Markdown tables (docs/bench/roots.md and the report page)."""
    lines = []
    if "batch_kernel" in report:
        lines += [
            f"Batched kernel: **{report['batch_kernel']}** (the widest instruction set this CPU runs, chosen at "
            "run time); rows marked (scalar) are the same calls with kernel='scalar', find_roots row by row.",
            "",
        ]
    kernel_rows = [(suite, data["kernels"]) for suite, data in report["suites"].items() if "kernels" in data]
    kernel_rows += list(report.get("kernel_suites", {}).items())
    if kernel_rows:
        configs = list(kernel_rows[0][1]["ns_per_poly_cpu"])
        lines += [
            "**Batched kernels vs the scalar path** (ns of process CPU time per polynomial, best of "
            f"{kernel_rows[0][1]['rounds']} interleaved rounds: a busy machine's preemptions do not count)",
            "",
            "| suite | " + " | ".join(configs) + " | auto: batched ÷ scalar auto | batched auto ÷ scalar unverified |",
            "|---|" + "---:|" * (len(configs) + 2),
        ]
        for suite, k in kernel_rows:
            cells = " | ".join(f"{k['ns_per_poly_cpu'][c]:.0f}" for c in configs)
            lines.append(f"| {suite} | {cells} | {1 / k['auto_speedup_vs_scalar_auto']:.2f} "
                         f"| {1 / k['auto_speedup_vs_scalar_unverified']:.2f} |")
        lines.append("")
    for suite, data in report["suites"].items():
        rows = data["results"]
        auto = rows["argand-auto"]["ns_per_poly"]
        lines += [
            f"**{suite}** ({rows['argand-auto']['polynomials']} polynomials; accuracy against the exact roots)",
            "",
            "| method | kernel | ns / polynomial | time ÷ auto | median radius / \\|root\\| | median error | max error | fully verified | answered in lanes | no answer |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for name, row in rows.items():
            def fmt(key):
                v = row.get(key)
                return f"{v:.1e}" if v is not None else ""
            verified = f"{100 * row['fully_verified_share']:.2f}%" if "fully_verified_share" in row else ""
            lanes = f"{100 * row['batched_share']:.2f}%" if "batched_share" in row else ""
            lines.append(
                f"| {name} | {row.get('kernel', '')} | {row['ns_per_poly']:.0f} | {row['ns_per_poly'] / auto:.1f} "
                f"| {fmt('median_rel_radius')} "
                f"| {fmt('median_rel_error')} | {fmt('max_rel_error')} | {verified} | {lanes} | "
                + (f"{100 * row['failed_share']:.1f}%" if "failed_share" in row else "") + " |"
            )
        lines.append("")
    return "\n".join(lines)


def versions() -> dict:
    import flint
    import mpmath

    return {"numpy": np.__version__, "python-flint": flint.__version__, "mpmath": mpmath.__version__}


def chart(report: dict, path: Path) -> None:
    """Speed versus accuracy, one panel per suite, one labelled point per
    method: x = ns per polynomial, y = median radius / |root| where the
    method gives radii (filled), else median relative error (hollow)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    suites = list(report["suites"])
    floor = 1e-17  # below double precision: shown at the floor, labelled "<="
    fig, axes = plt.subplots(1, len(suites), figsize=(7.2 * len(suites), 5.4), squeeze=False)
    labelled = []
    for ax, suite in zip(axes[0], suites):
        rows = report["suites"][suite]["results"]
        points = []
        for name, row in sorted(rows.items(), key=lambda kv: kv[1]["ns_per_poly"]):
            radius = row.get("median_rel_radius")
            y = radius if radius is not None else row.get("median_rel_error")
            if y is None:
                continue
            ours = name.startswith("argand")
            shown = max(y, floor)
            colour = "C0" if ours else "C1"
            ax.scatter(row["ns_per_poly"], shown, marker="o" if ours else "s", s=70,
                       facecolors=colour if radius is not None else "none", edgecolors=colour, zorder=3)
            points.append((name + (" (<=)" if y < floor else ""), row["ns_per_poly"], shown, colour))
        xs = [x for _, x, _, _ in points]
        if xs:
            ax.set_xlim(min(xs) / 2.5, max(xs) * 2.5)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(floor / 30, 1e-6)
        ax.set_xlabel("time per polynomial (ns, log scale)")
        ax.set_ylabel("median radius / |root| (filled) or median rel. error (hollow)")
        ax.set_title(f"{suite}: speed vs accuracy ({rows['argand-auto']['polynomials']} polynomials)")
        ax.grid(True, which="major", alpha=0.3)
        labelled.append((ax, points))
    fig.suptitle("argand bench roots: same polynomials, same run; lower left is better")
    fig.text(0.005, 0.005, f"(<=): at or below {floor:.0e}, drawn at {floor:.0e}", fontsize=7, color="0.35")
    fig.tight_layout()
    # Labels last, on the final layout (they are placed in display space).
    for ax, points in labelled:
        _place_labels(fig, ax, points)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _place_labels(fig, ax, points) -> None:
    """Label each point at the first candidate offset whose text box stays
    inside the axes and overlaps no earlier label or point (greedy), with a
    short leader line to its point."""
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    dots = [ax.transData.transform((x, y)) for _, x, y, _ in points]
    placed = []
    candidates = [(7, 4, "left"), (7, -15, "left"), (-7, 4, "right"), (-7, -15, "right"),
                  (10, 16, "left"), (10, -27, "left"), (-10, 16, "right"), (-10, -27, "right"),
                  (0, 28, "center"), (0, -39, "center"), (12, 28, "left"), (-12, 28, "right"),
                  (12, -39, "left"), (-12, -39, "right"), (0, 40, "center"), (0, -51, "center")]
    for label, x, y, colour in points:
        chosen = candidates[0]
        for dx, dy, ha in candidates:
            probe = ax.annotate(label, (x, y), textcoords="offset points", xytext=(dx, dy), ha=ha, va="bottom",
                                fontsize=8)
            box = probe.get_window_extent(renderer).expanded(1.04, 1.2)
            probe.remove()
            inside = frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
            hits_dot = any(box.x0 - 5 < px < box.x1 + 5 and box.y0 - 5 < py < box.y1 + 5 for px, py in dots)
            if inside and not hits_dot and not any(box.overlaps(b) for b in placed):
                chosen = (dx, dy, ha)
                placed.append(box)
                break
        dx, dy, ha = chosen
        ax.annotate(label, (x, y), textcoords="offset points", xytext=(dx, dy), ha=ha, va="bottom", fontsize=8,
                    arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.6, "shrinkA": 1, "shrinkB": 5})
