"""`argand bench render`: the paper's presets and the degree 5-8 surfaces of
the roots benchmark (argand.bench.rays), two sizes, three deltas, one core,
with the same frame in method="unverified" beside it (the price of the
proof); then the classic presets of degree 5 to 8 (certified share, status
breakdown, ns per pixel, escalation share, the exact tier's share) and ns
per pixel per degree; and a picture of where escalation happened (the
escalation AOV: the ladder level each pixel needed) on a few surfaces."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable

from argand.bench import machine_info
from argand.render import FrameParams, render_frame
from argand.render.contact import contact_sheet
from argand.render.frames import ESCALATION_NAMES, STATUS_NAMES
from argand.scene import load_scene
from argand.scene.presets import CLASSIC_PRESETS, PAPER_PRESETS

DELTAS = (0.0, math.pi / 18, math.pi / 9)


def bench_render(out_dir: Path = Path("docs/bench"), smoke: bool = False, progress: Callable[[str], None] = lambda m: None) -> dict:
    sizes = (64, 128) if smoke else (512, 1024)
    from argand.bench.rays import scenes

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
    big = [f for f in frames if f["scene"] == "bicube" and f["width"] == sizes[-1] and abs(f["delta"] - math.pi / 9) < 1e-12]
    report = {
        "benchmark": "render",
        "machine": machine_info(),
        "threads": 1,
        "frames": frames,
        "classic_frames": classic,
        "per_degree": per_degree(frames + classic),
        "headline": {
            "bicube_largest_pi_9_ms": big[0]["ms"] if big else None,
            "min_certified_share": min(f["certified_share"] for f in frames),
            "min_certified_share_degree_5_to_8": min(f["certified_share"] for f in classic),
            "median_proof_overhead": sorted(f["ms"] / f["unverified_ms"] for f in frames)[len(frames) // 2],
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "render.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render.md").write_text(markdown(report))
    progress("contact sheet")
    sweep = [i * math.pi / 36 for i in range(5)]  # 0 .. pi/9, as in the paper's figures
    contact_sheet(PAPER_PRESETS, sweep, 96 if smoke else 192, out_dir / "render_contact.png")
    contact_sheet(CLASSIC_PRESETS, sweep, 96 if smoke else 192, out_dir / "render_contact_classic.png")
    progress("escalation picture")
    report["escalation_picture"] = escalation_picture(63 if smoke else 255, out_dir / "render_escalation.png")
    (out_dir / "render.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render.md").write_text(markdown(report))
    return report


def exact_figures(figures: dict) -> dict:
    """The exact tier's figures of a frame, for the tables."""
    return {k: figures[k] for k in ("exact_pixels", "exact_share", "exact_multiple_roots", "exact_over_cap")}


#: The escalation picture: (scene, delta) at an odd size (the centre row's and
#: column's rays then pass within rounding of the presets' singular lines).
ESCALATION_CASES = (("steiner", math.pi / 18), ("plucker", 0.0), ("chmutov-octic", 0.0), ("endrass-octic", math.pi / 18))
#: One colour per ladder level (ESCALATION_NAMES); level 0 shows the image.
LEVEL_COLOURS = {1: "#1f77b4", 2: "#17becf", 3: "#ff7f0e", 4: "#2ca02c", 5: "#d62728", 6: "#000000"}


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

    from argand.render.output import to_srgb8

    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 8.8))
    rows = []
    for col, (name, delta) in enumerate(cases):
        scene = load_scene(name)
        r = render_frame(scene, FrameParams(delta=delta, width=size, height=size))
        srgb = to_srgb8(r.rgba)[..., :3].astype(np.float64) / 255
        level = np.asarray(r.aovs["escalation"])
        grey = srgb.mean(axis=2, keepdims=True) * 0.55 + 0.4
        picture = np.repeat(grey, 3, axis=2)
        counts = {ESCALATION_NAMES[k]: int(np.count_nonzero(level == k)) for k in ESCALATION_NAMES}
        for k, colour in LEVEL_COLOURS.items():
            picture[level == k] = to_rgb(colour)
        degree = max(o.polynomial.degree for o in scene.objects)
        axes[0, col].imshow(srgb, interpolation="nearest")
        axes[0, col].set_title(f"{name} (degree {degree}), δ = {delta:.4f}", fontsize=9)
        axes[1, col].imshow(picture, interpolation="nearest")
        axes[1, col].set_title(f"certified {100 * r.certified_share:.3f}%, escalated {r.figures['escalations']}, "
                               f"exact {r.figures['exact_pixels']}", fontsize=8)
        handles = [Patch(color=LEVEL_COLOURS[k], label=f"{k} {ESCALATION_NAMES[k]}: {counts[ESCALATION_NAMES[k]]}")
                   for k in LEVEL_COLOURS if counts[ESCALATION_NAMES[k]]]
        handles.insert(0, Patch(color="0.7", label=f"0 first: {counts[ESCALATION_NAMES[0]]}"))
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
    return "\n".join(lines) + "\n"


def exact_cell(f: dict) -> str:
    """The exact tier's pixels and share of a frame (and the pixels its
    per-tile budget left out, when any)."""
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
    names = list(ESCALATION_NAMES.values())
    lines = [
        "",
        "Where the ladder escalated (the `escalation` AOV; grey: decided from the first discs, colours: the level a "
        "pixel needed; levels 4-6 are the exact tier):",
        "",
        f"![where escalation happened]({picture})",
        "",
        "| scene | degree | δ | size | certified | " + " | ".join(names) + " |",
        "|---|---:|---:|---|---:|" + "---:|" * len(names),
    ]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['degree']} | {r['delta']:.4f} | {r['size']}×{r['size']} "
                     f"| {100 * r['certified_share']:.3f}% | " + " | ".join(str(r["levels"][n]) for n in names) + " |")
    return lines
