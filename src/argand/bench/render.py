"""`argand bench render`: the paper's presets and the degree 5-8 surfaces of
the roots benchmark (argand.bench.ray_samples), two sizes, three deltas, one core,
with the same frame in method="unverified" beside it (the price of the
proof); then the classic presets of degree 5 to 8 (certified share, status
breakdown, ns per pixel, escalation share, the exact tier's share) and ns
per pixel per degree; a picture of where escalation happened (the
escalation AOV: the ladder level each pixel needed) on a few surfaces; and
the cost of antialiasing: the same frames at 1, 4 and 16 samples per pixel,
in ns per pixel and ns per sample; and the root kernel of the primary rays:
the same frames with the scalar kernel (find_roots sample by sample) and the
batched one (find_roots_rows, the widest instruction set this CPU runs), in
CPU time, against the kernel's targets (KERNEL_FRAMES)."""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable

from argand.bench import machine_info
from argand.render import FrameParams, render_frame
from argand.media.contact_sheet import contact_sheet
from argand.media.frame_files import to_srgb8, write_png
from argand.render.frames import LADDER_LEVEL_NAMES, STATUS_NAMES
from argand.render.options import EngineOptions
from argand.scene import load_scene
from argand.scene.presets import CLASSIC_PRESETS, PAPER_PRESETS

DELTAS = (0.0, math.pi / 18, math.pi / 9)
#: Samples per pixel measured by bench_samples, and its scenes (degree 3, 4, 6, 8).
SAMPLES = (1, 4, 16)
SAMPLE_SCENES = ("whitney", "bicube", "barth-sextic", "chmutov-octic")


def bench_render(out_dir: Path = Path("docs/bench"), smoke: bool = False, progress: Callable[[str], None] = lambda m: None) -> dict:
    sizes = (64, 128) if smoke else (512, 1024)
    from argand.bench.ray_samples import scenes

    frames = []
    for name, scene in scenes().items():
        degree = "+".join(str(o.polynomial.degree) for o in scene.objects)
        for size in sizes:
            for delta in DELTAS:
                progress(f"{name} {size}x{size} delta={delta:.4f}")
                row = {"scene": name, "degree": degree, "width": size, "height": size, "delta": delta}
                for method in ("auto", "unverified"):
                    r = render_frame(scene, FrameParams(delta=delta, width=size, height=size, method=method), workers=1)
                    key = "" if method == "auto" else "unverified_"
                    row[f"{key}ms"] = r.seconds * 1000
                    if method == "auto":
                        row.update(
                            ns_per_pixel=r.seconds / (size * size) * 1e9,
                            certified_share=r.certified_share,
                            status_shares=r.status_shares(),
                            escalated_share=r.figures["escalated_share"],
                            **exact_figures(r.figures),
                            hit_share=float((r.rgba[..., 3] > 0).mean()),
                        )
                frames.append(row)
    classic = bench_classic(64 if smoke else 384, progress)
    kernels = bench_kernels(smoke, progress)
    sampled = bench_samples_report(out_dir, smoke, progress)["samples"]
    big = [f for f in frames if f["scene"] == "bicube" and f["width"] == sizes[-1] and abs(f["delta"] - math.pi / 9) < 1e-12]
    report = {
        "benchmark": "render",
        "machine": machine_info(),
        "threads": 1,
        "frames": frames,
        "classic_frames": classic,
        "kernels": kernels,
        "per_degree": per_degree(frames + classic),
        "samples": sampled,
        "headline": {
            "bicube_largest_pi_9_ms": big[0]["ms"] if big else None,
            "min_certified_share": min(f["certified_share"] for f in frames),
            "min_certified_share_degree_5_to_8": min(f["certified_share"] for f in classic),
            "median_proof_overhead": sorted(f["ms"] / f["unverified_ms"] for f in frames)[len(frames) // 2],
            # ns per sample at 16 samples over ns per pixel at 1 (median over the scenes and deltas).
            "median_sample_cost_16": _median([f["sample_cost"] for f in sampled if f["samples"] == 16]),
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "render.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render.md").write_text(markdown(report))
    progress("contact sheet")
    sweep = [i * math.pi / 36 for i in range(5)]  # 0 .. pi/9, as in the paper's figures
    preset_sheet(PAPER_PRESETS, sweep, 96 if smoke else 192, out_dir / "render_contact.png")
    preset_sheet(CLASSIC_PRESETS, sweep, 96 if smoke else 192, out_dir / "render_contact_classic.png")
    progress("escalation picture")
    report["escalation_picture"] = escalation_picture(63 if smoke else 255, out_dir / "render_escalation.png")
    (out_dir / "render.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render.md").write_text(markdown(report))
    return report


#: The preset sheets' gaps: white, as the README shows them.
SHEET_BACKGROUND = (255, 255, 255)


def preset_sheet(scenes: list[str] | tuple[str, ...], deltas: list[float], size: int, path: Path,
                 sigma: float = 0.0) -> None:
    """Renders every (scene, δ) at size x size and writes them as one PNG
    contact sheet (argand.media.contact_sheet): the scenes in rows, δ in columns."""
    cells = {}
    for row, name in enumerate(scenes):
        scene = load_scene(name)
        for column, delta in enumerate(deltas):
            result = render_frame(scene, FrameParams(sigma=sigma, delta=delta, width=size, height=size))
            cells[(row, column)] = to_srgb8(result.rgba)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_png(contact_sheet(cells, (len(scenes), len(deltas)), (size, size), background=SHEET_BACKGROUND), path)


def exact_figures(figures: dict) -> dict:
    """The exact tier's figures of a frame, for the tables."""
    return {k: figures[k] for k in ("exact_pixels", "exact_share", "exact_multiple_roots", "exact_over_cap")}


#: The escalation picture: (scene, delta) at an odd size (the centre row's and
#: column's rays then pass within rounding of the presets' singular lines).
ESCALATION_CASES = (("steiner", math.pi / 18), ("plucker", 0.0), ("chmutov-octic", 0.0), ("endrass-octic", math.pi / 18))
#: One colour per ladder level (LADDER_LEVEL_NAMES); level 0 shows the image.
LEVEL_COLOURS = {1: "#1f77b4", 2: "#17becf", 3: "#bcbd22", 4: "#ff7f0e", 5: "#2ca02c", 6: "#d62728", 7: "#000000"}


def escalation_picture(size: int, path: Path, cases=ESCALATION_CASES) -> list[dict]:
    """For each case, the frame and its escalation AOV: the pixels decided
    from the first discs show the frame in grey, the others the colour of
    the ladder level they needed, with a legend of the levels and their
    pixel counts. Writes a PNG; returns each frame's level counts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch

    from argand.media.frame_files import to_srgb8

    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 8.8))
    rows = []
    for col, (name, delta) in enumerate(cases):
        scene = load_scene(name)
        r = render_frame(scene, FrameParams(delta=delta, width=size, height=size))
        srgb = to_srgb8(r.rgba)[..., :3].astype(np.float64) / 255
        level = np.asarray(r.aovs["escalation"])
        grey = srgb.mean(axis=2, keepdims=True) * 0.55 + 0.4
        picture = np.repeat(grey, 3, axis=2)
        counts = {LADDER_LEVEL_NAMES[k]: int(np.count_nonzero(level == k)) for k in LADDER_LEVEL_NAMES}
        for k, colour in LEVEL_COLOURS.items():
            picture[level == k] = to_rgb(colour)
        degree = max(o.polynomial.degree for o in scene.objects)
        axes[0, col].imshow(srgb, interpolation="nearest")
        axes[0, col].set_title(f"{name} (degree {degree}), δ = {delta:.4f}", fontsize=9)
        axes[1, col].imshow(picture, interpolation="nearest")
        axes[1, col].set_title(f"certified {100 * r.certified_share:.3f}%, escalated {r.figures['escalations']}, "
                               f"exact {r.figures['exact_pixels']}", fontsize=8)
        handles = [Patch(color=LEVEL_COLOURS[k], label=f"{k} {LADDER_LEVEL_NAMES[k]}: {counts[LADDER_LEVEL_NAMES[k]]}")
                   for k in LEVEL_COLOURS if counts[LADDER_LEVEL_NAMES[k]]]
        handles.insert(0, Patch(color="0.7", label=f"0 first: {counts[LADDER_LEVEL_NAMES[0]]}"))
        axes[1, col].legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.02), frameon=False)
        for ax in axes[:, col]:
            ax.set_xticks([])
            ax.set_yticks([])
        rows.append({"scene": name, "degree": degree, "delta": delta, "size": size, "levels": counts,
                     "certified_share": r.certified_share, "status_shares": r.status_shares()})
    fig.suptitle(f"argand bench render — where the ladder escalated ({size}×{size}; grey: decided from the first "
                 "discs; colours: the ladder level a pixel needed)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return rows


def bench_classic(size: int, progress: Callable[[str], None]) -> list[dict]:
    """The classic surfaces of degree 5 to 8, one core, method auto."""
    rows = []
    for name in CLASSIC_PRESETS:
        scene = load_scene(name)
        degree = max(o.polynomial.degree for o in scene.objects)
        for delta in DELTAS:
            progress(f"{name} {size}x{size} delta={delta:.4f}")
            r = render_frame(scene, FrameParams(delta=delta, width=size, height=size), workers=1)
            rows.append({
                "scene": name, "degree": degree, "width": size, "height": size, "delta": delta,
                "ms": r.seconds * 1000,
                "ns_per_pixel": r.figures["ns_per_pixel"],
                "certified_share": r.certified_share,
                "status_shares": r.status_shares(),
                "escalated_share": r.figures["escalated_share"],
                **exact_figures(r.figures),
                "hit_share": r.hit_share,
            })
    return rows


def bench_samples_report(out_dir: Path = Path("docs/bench"), smoke: bool = False,
                         progress: Callable[[str], None] = lambda m: None) -> dict:
    """bench_samples alone (`argand bench render --samples-only`), written to
    render_samples.{json,md,png} (the full benchmark includes it too)."""
    rows = bench_samples(32 if smoke else 256, progress)
    report = {
        "benchmark": "render samples",
        "machine": machine_info(),
        "threads": 1,
        "samples": rows,
        "headline": {f"median_sample_cost_{n}": _median([f["sample_cost"] for f in rows if f["samples"] == n])
                     for n in SAMPLES[1:]},
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "render_samples.json").write_text(json.dumps(report, indent=2) + "\n")
    text = markdown({"frames": [], "samples": rows})
    (out_dir / "render_samples.md").write_text(text[text.index("Antialiasing"):])
    samples_chart(rows, out_dir / "render_samples.png")
    return report


def samples_chart(rows: list[dict], path: Path) -> None:
    """ns per sample against samples per pixel, one line per scene and delta."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.2))
    for key in sorted({(f["scene"], f["degree"], f["delta"]) for f in rows}, key=lambda k: (k[1], k[0], k[2])):
        line = [f for f in rows if (f["scene"], f["degree"], f["delta"]) == key]
        ax.plot([f["samples"] for f in line], [f["ns_per_sample"] for f in line], marker="o",
                label=f"{key[0]} (degree {key[1]}), δ = {key[2]:.3f}")
    ax.set_xscale("log", base=2)
    ax.set_xticks(list(SAMPLES), [str(s) for s in SAMPLES])
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("ns per sample (one core)")
    ax.set_title(f"Antialiasing: the cost of a sample, {rows[0]['width']}×{rows[0]['height']}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def bench_samples(size: int, progress: Callable[[str], None]) -> list[dict]:
    """Antialiasing's cost: SAMPLE_SCENES at SAMPLES samples per pixel, one
    core, method auto, timed in CPU time (the render runs on the calling
    thread). ``sample_cost``: ns per sample over the ns per pixel of the
    same frame at one sample (1: a sample costs what a pixel did)."""
    rows = []
    for name in SAMPLE_SCENES:
        scene = load_scene(name)
        for delta in (0.0, math.pi / 18):
            base = None
            for samples in SAMPLES:
                progress(f"{name} {size}x{size} delta={delta:.4f} samples={samples}")
                cpu = time.process_time()
                r = render_frame(scene, FrameParams(delta=delta, width=size, height=size, samples=samples), workers=1)
                cpu = time.process_time() - cpu  # CPU seconds: steadier than wall time on a shared machine
                ns_per_pixel = cpu / (size * size) * 1e9
                base = base or ns_per_pixel
                rows.append({
                    "scene": name, "degree": max(o.polynomial.degree for o in scene.objects), "width": size,
                    "height": size, "delta": delta, "samples": samples, "ms": r.seconds * 1000, "cpu_ms": cpu * 1000,
                    "ns_per_pixel": ns_per_pixel, "ns_per_sample": ns_per_pixel / samples,
                    "sample_cost": ns_per_pixel / samples / base,
                    # Pixels whose every sample is certified, and certified samples among all.
                    "certified_share": r.certified_share,
                    "certified_sample_share": float(r.aovs["certified_share"].mean()),
                    "edge_share": float(((r.rgba[..., 3] > 0) & (r.rgba[..., 3] < 1)).mean()),
                })
    return rows


#: The kernel table: (scene, size, delta). Its targets: the Bicube at
#: 1024x1024, delta = pi/9 in <= 0.2 s on one core; surfaces of degree 6 to 8
#: in <= 1 us per pixel at 512x512 (every preset of degree 6 to 8 among them).
#: (Whitney in a sphere, with its secondary rays, at a smaller size.)
KERNEL_FRAMES = (
    ("bicube", 1024, math.pi / 9),
    ("whitney", 512, math.pi / 9),
    ("plucker", 512, math.pi / 9),
    ("steiner", 512, math.pi / 9),
    ("mitchell", 512, math.pi / 9),
    ("whitney-in-sphere", 256, math.pi / 9),
    ("quintic x^5+y^5+z^5+10xyz", 512, math.pi / 9),
    ("sextic x^6+y^6+z^6", 512, math.pi / 9),
    ("octic x^8+y^8+z^8+10x^2y^2z^2", 512, math.pi / 9),
    ("togliatti", 512, math.pi / 9),
    ("barth-sextic", 512, math.pi / 9),
    ("chmutov-septic", 512, math.pi / 9),
    ("chmutov-octic", 512, math.pi / 9),
    ("endrass-octic", 512, math.pi / 9),
)


def bench_kernels(smoke: bool, progress: Callable[[str], None], rounds: int = 3) -> dict:
    """Each KERNEL_FRAMES frame (method auto, one core, in process) with the
    scalar root kernel and the batched one, in CPU time (the best of
    ``rounds`` interleaved renders: steadier than wall time on a shared
    machine); whether the two agree on every pixel's status and hit; the
    certified share of each."""
    from argand.core import _core
    from argand.bench.ray_samples import scenes as ray_scenes

    import numpy as np

    batched = _core.batch_kernel()
    extra = ray_scenes()
    rows = []
    for name, size, delta in KERNEL_FRAMES:
        size = min(size, 64) if smoke else size
        scene = extra[name] if name in extra else load_scene(name)
        params = FrameParams(delta=delta, width=size, height=size)
        best = {"scalar": math.inf, batched: math.inf}
        frames = {}
        for _ in range(1 if smoke else rounds):
            for kernel in ("scalar", batched):
                progress(f"kernels: {name} {size}x{size} delta={delta:.4f} {kernel}")
                cpu = time.process_time()
                frames[kernel] = render_frame(scene, replace(params, engine=EngineOptions(kernel=kernel)), workers=1)
                best[kernel] = min(best[kernel], time.process_time() - cpu)
        a, b = frames["scalar"], frames[batched]
        same_status = bool(np.array_equal(np.asarray(a.aovs["status"]), np.asarray(b.aovs["status"])))
        same_hit = bool(np.array_equal(a.rgba[..., 3] > 0, b.rgba[..., 3] > 0))
        pixels = size * size
        rows.append({
            "scene": name, "degree": "+".join(str(o.polynomial.degree) for o in scene.objects),
            "width": size, "height": size, "delta": delta,
            "scalar_cpu_ms": best["scalar"] * 1000, "batched_cpu_ms": best[batched] * 1000,
            "scalar_ns_per_pixel": best["scalar"] / pixels * 1e9, "batched_ns_per_pixel": best[batched] / pixels * 1e9,
            "speedup": best["scalar"] / best[batched],
            "scalar_certified_share": a.certified_share, "batched_certified_share": b.certified_share,
            "same_status": same_status, "same_hit": same_hit,
        })
    bicube = [r for r in rows if r["scene"] == "bicube"]
    high = [r for r in rows if max(int(d) for d in r["degree"].split("+")) >= 6 and r["width"] >= 512]
    return {
        "instruction_set": batched,
        "rounds": 1 if smoke else rounds,
        "rows": rows,
        "targets": {
            "bicube_1024_pi_9_batched_s": bicube[0]["batched_cpu_ms"] / 1000 if bicube and not smoke else None,
            "bicube_1024_pi_9_target_s": 0.2,
            "degree_6_to_8_512_batched_ns_per_pixel_max": max((r["batched_ns_per_pixel"] for r in high), default=None),
            "degree_6_to_8_target_ns_per_pixel": 1000,
        },
    }


def bench_kernels_report(out_dir: Path = Path("docs/bench"), smoke: bool = False,
                         progress: Callable[[str], None] = lambda m: None) -> dict:
    """bench_kernels alone (`argand bench render --kernels-only`): written to
    render_kernels.{json,md}, and into render.json / render.md (the full
    benchmark's report, whose other tables stay as they were measured)."""
    kernels = bench_kernels(smoke, progress)
    progress("kernels: the culling figure")
    kernels["culled_share"] = cull_figure(out_dir, smoke)
    report = {"benchmark": "render kernels", "machine": machine_info(), "threads": 1, "kernels": kernels}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "render_kernels.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render_kernels.md").write_text("\n".join(kernel_section(kernels)).lstrip() + "\n")
    full = out_dir / "render.json"
    if full.exists():
        whole = json.loads(full.read_text())
        whole["kernels"] = kernels
        full.write_text(json.dumps(whole, indent=2) + "\n")
        (out_dir / "render.md").write_text(markdown(whole))
    return report


#: The scenes of the culling figure (docs/bench/render_cull.png).
CULL_SCENES = ("bicube", "barth-sextic", "chmutov-octic")


def cull_figure(out_dir: Path = Path("docs/bench"), smoke: bool = False) -> dict:
    """Which primary rays skip their roots because they provably miss the
    clipping sphere (``--explain``'s ``outside_sphere``, pixel by pixel),
    over the rendered frame, for CULL_SCENES at δ = π/9; writes
    render_cull.png and returns each scene's culled share."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from argand.render.explain import explain_pixel

    size = 24 if smoke else 96
    shares = {}
    fig, axes = plt.subplots(1, len(CULL_SCENES), figsize=(4 * len(CULL_SCENES), 4.4))
    for ax, name in zip(axes, CULL_SCENES):
        scene = load_scene(name)
        params = FrameParams(delta=math.pi / 9, width=size, height=size)
        frame = render_frame(scene, params, workers=1)
        culled = np.array([[explain_pixel(scene, params, x, y)["polynomials"][0]["outside_sphere"]
                            for x in range(size)] for y in range(size)])
        shares[name] = float(culled.mean())
        rgb = np.clip(frame.rgba[..., :3], 0, 1).copy()
        tint = np.array([0.25, 0.45, 0.85])
        rgb[culled] = 0.45 * rgb[culled] + 0.55 * tint
        ax.imshow(rgb, interpolation="nearest")
        ax.set_title(f"{name}: {100 * shares[name]:.0f}% of rays culled", fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("Primary rays proven to miss the clipping sphere (blue): no roots solved, a certified miss", fontsize=10)
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "render_cull.png", dpi=90)
    plt.close(fig)
    return shares


def kernel_section(kernels: dict | None) -> list[str]:
    """The table of the primary rays' root kernels (scalar vs batched)."""
    if not kernels:
        return []
    isa = kernels["instruction_set"]
    lines = [
        "",
        f"Root kernel of the primary rays (`EngineOptions.kernel`, `ARGAND_KERNEL`): scalar (`find_roots` sample by sample, neighbour seeds) "
        f"against batched (`find_roots_rows`, runs of 32 samples, instruction set **{isa}**); method auto, one core, "
        f"CPU time, the best of {kernels.get('rounds', 2)} interleaved renders. Same status / same hit: every pixel "
        "of the two frames agrees.",
        "",
        f"| scene | degree | size | δ | scalar, ms | {isa}, ms | scalar ns / pixel | {isa} ns / pixel | speed-up "
        "| certified (scalar / batched) | same status | same hit |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|",
    ]
    for r in kernels["rows"]:
        lines.append(
            f"| {r['scene']} | {r['degree']} | {r['width']}×{r['height']} | {r['delta']:.4f} | {r['scalar_cpu_ms']:.0f} "
            f"| {r['batched_cpu_ms']:.0f} | {r['scalar_ns_per_pixel']:.0f} | {r['batched_ns_per_pixel']:.0f} "
            f"| {r['speedup']:.2f}× | {100 * r['scalar_certified_share']:.3f}% / {100 * r['batched_certified_share']:.3f}% "
            f"| {'yes' if r['same_status'] else 'NO'} | {'yes' if r['same_hit'] else 'NO'} |"
        )
    t = kernels["targets"]
    if t.get("bicube_1024_pi_9_batched_s") is not None:
        lines += [
            "",
            f"Targets: Bicube 1024×1024, δ = π/9: {t['bicube_1024_pi_9_batched_s']:.3f} s batched "
            f"(target {t['bicube_1024_pi_9_target_s']} s); degree 6 to 8 at 512×512: at most "
            f"{t['degree_6_to_8_512_batched_ns_per_pixel_max']:.0f} ns per pixel batched "
            f"(target {t['degree_6_to_8_target_ns_per_pixel']} ns).",
        ]
    if kernels.get("culled_share"):
        shares = ", ".join(f"{name} {100 * v:.0f}%" for name, v in kernels["culled_share"].items())
        lines += [
            "",
            "Both kernels skip the roots of a primary ray that provably misses the object's clipping sphere "
            f"(`EngineOptions.cull`, `ARGAND_CULL`; share of such rays at δ = π/9: {shares}):",
            "",
            "![Culled primary rays](render_cull.png)",
        ]
    return lines


def per_degree(frames: list[dict]) -> list[dict]:
    """ns per pixel and certified share per surface degree (the highest
    degree of a scene's objects), as the median over its frames."""
    by_degree: dict[int, list[dict]] = {}
    for f in frames:
        degree = max(int(d) for d in str(f["degree"]).split("+"))
        by_degree.setdefault(degree, []).append(f)
    out = []
    for degree in sorted(by_degree):
        rows = by_degree[degree]
        out.append({
            "degree": degree,
            "frames": len(rows),
            "scenes": sorted({f["scene"] for f in rows}),
            "median_ns_per_pixel": _median([f["ns_per_pixel"] for f in rows]),
            "min_certified_share": min(f["certified_share"] for f in rows),
            "median_escalated_share": _median([f["escalated_share"] for f in rows]),
            "exact_pixels": sum(f.get("exact_pixels", 0) for f in rows),
            "pixels": sum(f["width"] * f["height"] for f in rows),
        })
    return out


def _median(values: list[float]) -> float:
    v = sorted(values)
    mid = len(v) // 2
    return v[mid] if len(v) % 2 else (v[mid - 1] + v[mid]) / 2


def markdown(report: dict) -> str:
    lines = [
        "| scene | degree | size | δ | ms / frame | ns / pixel | certified | escalated | exact tier | unverified method, ms "
        "| proof overhead |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in report["frames"]:
        lines.append(
            f"| {f['scene']} | {f.get('degree', '')} | {f['width']}×{f['height']} | {f['delta']:.4f} | {f['ms']:.0f} "
            f"| {f['ns_per_pixel']:.0f} | {100 * f['certified_share']:.3f}% | {100 * f.get('escalated_share', 0.0):.3f}% "
            f"| {exact_cell(f)} | {f['unverified_ms']:.0f} | {f['ms'] / f['unverified_ms']:.2f}× |"
        )
    lines += kernel_section(report.get("kernels"))
    statuses = list(STATUS_NAMES.values())
    lines += [
        "",
        "Classic surfaces of degree 5 to 8 (method auto, one core):",
        "",
        "| scene | degree | size | δ | ns / pixel | certified | " + " | ".join(statuses[1:]) + " | escalated | exact tier |",
        "|---|---:|---|---:|---:|---:|" + "---:|" * (len(statuses) - 1) + "---:|---:|",
    ]
    for f in report.get("classic_frames", []):
        shares = " | ".join(f"{100 * f['status_shares'][s]:.2f}%" for s in statuses[1:])
        lines.append(
            f"| {f['scene']} | {f['degree']} | {f['width']}×{f['height']} | {f['delta']:.4f} | {f['ns_per_pixel']:.0f} "
            f"| {100 * f['certified_share']:.3f}% | {shares} | {100 * f['escalated_share']:.2f}% | {exact_cell(f)} |"
        )
    lines += [
        "",
        "Per degree (medians over the frames above):",
        "",
        "| degree | scenes | frames | ns / pixel | lowest certified share | escalated | exact tier (all frames) |",
        "|---:|---|---:|---:|---:|---:|---:|",
    ]
    for d in report.get("per_degree", []):
        lines.append(
            f"| {d['degree']} | {', '.join(d['scenes'])} | {d['frames']} | {d['median_ns_per_pixel']:.0f} "
            f"| {100 * d['min_certified_share']:.3f}% | {100 * d['median_escalated_share']:.2f}% "
            f"| {d.get('exact_pixels', 0)} px ({100 * d.get('exact_pixels', 0) / max(1, d.get('pixels', 1)):.4f}%) |"
        )
    lines += escalation_section(report)
    lines += [
        "",
        "Antialiasing (samples per pixel, one core, method auto, CPU time). Sample cost: ns per sample over the ns per "
        "pixel of the same frame at one sample. Certified pixels: every sample certified; certified samples: "
        "the mean of the certified_share AOV; edge pixels: partly covered (0 < A < 1).",
        "",
        "| scene | degree | size | δ | samples | CPU ms / frame | ns / pixel | ns / sample | sample cost | certified pixels "
        "| certified samples | edge pixels |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in report.get("samples", []):
        lines.append(
            f"| {f['scene']} | {f['degree']} | {f['width']}×{f['height']} | {f['delta']:.4f} | {f['samples']} "
            f"| {f['cpu_ms']:.0f} | {f['ns_per_pixel']:.0f} | {f['ns_per_sample']:.0f} | {f['sample_cost']:.2f}× "
            f"| {100 * f['certified_share']:.3f}% | {100 * f['certified_sample_share']:.3f}% "
            f"| {100 * f['edge_share']:.2f}% |"
        )
    return "\n".join(lines) + "\n"


def exact_cell(f: dict) -> str:
    """The exact tier's pixels and share of a frame (and the pixels its
    per-block budget left out, when any)."""
    if "exact_pixels" not in f:
        return "–"
    cell = f"{f['exact_pixels']} ({100 * f['exact_share']:.4f}%)"
    if f.get("exact_over_cap"):
        cell += f", {f['exact_over_cap']} over the cap"
    return cell


def escalation_section(report: dict, picture: str = "render_escalation.png") -> list[str]:
    """The escalation picture and its counts per ladder level."""
    rows = report.get("escalation_picture")
    if not rows:
        return []
    names = list(LADDER_LEVEL_NAMES.values())
    lines = [
        "",
        "Where the ladder escalated (the `escalation` AOV; grey: decided from the first discs, colours: the level a "
        "pixel needed; levels 5-7 are the exact tier):",
        "",
        f"![where escalation happened]({picture})",
        "",
        "| scene | degree | δ | size | certified | " + " | ".join(names) + " |",
        "|---|---:|---:|---|---:|" + "---:|" * len(names),
    ]
    for r in rows:
        # (By name: a report written before a level existed shows "–" there.)
        lines.append(f"| {r['scene']} | {r['degree']} | {r['delta']:.4f} | {r['size']}×{r['size']} "
                     f"| {100 * r['certified_share']:.3f}% | "
                     + " | ".join(str(r["levels"].get(n, "–")) for n in names) + " |")
    return lines
