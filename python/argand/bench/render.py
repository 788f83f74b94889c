"""`argand bench render`: every preset and the degree 5-8 surfaces of the
roots benchmark (argand.bench.rays), two sizes, three deltas, one core; the
same frame with method="unverified" beside it (the price of the proof)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Callable

from argand.bench import machine_info
from argand.render import FrameParams, render_frame
from argand.render.contact import contact_sheet
from argand.scene import PRESETS

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
                            escalated_share=r.escalations / (size * size),
                            hit_share=float((r.rgba[..., 3] > 0).mean()),
                        )
                frames.append(row)
    big = [f for f in frames if f["scene"] == "bicube" and f["width"] == sizes[-1] and abs(f["delta"] - math.pi / 9) < 1e-12]
    report = {
        "benchmark": "render",
        "machine": machine_info(),
        "threads": 1,
        "frames": frames,
        "headline": {
            "bicube_largest_pi_9_ms": big[0]["ms"] if big else None,
            "min_certified_share": min(f["certified_share"] for f in frames),
            "median_proof_overhead": sorted(f["ms"] / f["unverified_ms"] for f in frames)[len(frames) // 2],
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "render.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "render.md").write_text(markdown(report))
    progress("contact sheet")
    sweep = [i * math.pi / 36 for i in range(5)]  # 0 .. pi/9, as in the paper's figures
    contact_sheet(PRESETS, sweep, 96 if smoke else 192, out_dir / "render_contact.png")
    return report


def markdown(report: dict) -> str:
    lines = [
        "| scene | degree | size | δ | ms / frame | ns / pixel | certified | escalated | unverified method, ms | proof overhead |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in report["frames"]:
        lines.append(
            f"| {f['scene']} | {f.get('degree', '')} | {f['width']}×{f['height']} | {f['delta']:.4f} | {f['ms']:.0f} "
            f"| {f['ns_per_pixel']:.0f} | {100 * f['certified_share']:.3f}% | {100 * f.get('escalated_share', 0.0):.3f}% "
            f"| {f['unverified_ms']:.0f} | {f['ms'] / f['unverified_ms']:.2f}× |"
        )
    return "\n".join(lines) + "\n"
