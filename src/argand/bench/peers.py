"""Peers: Argand against surf and POV-Ray on the same rays.

surf (Debian's surf-alggeo, ``surf-alggeo-nox -n SCRIPT.pic``) and POV-Ray
3.7 (``povray``, its ``polynomial`` object with and without ``sturm``) draw
the real surface (sigma = delta = 0) of each single-object preset with a
camera whose rays are Argand's to rounding (argand.bench.peers_scenes says
how), flat white on black, so a pixel is a hit or a miss. Every run is on
one core (this process pins itself, and so its children, to CPU 0):

* surf: the whole process's CPU time (``getrusage`` of the children);
* POV-Ray: its own "Trace Time" CPU-seconds (parse and start excluded),
  with and without ``sturm``;
* Argand: ``render_frame(..., workers=1)`` alone (``time.process_time``), and
  the whole ``argand render SCENE --size WxH --workers 1`` process (CPU time
  of the child: start-up, plan, render, EXR/PNG/JSON written).

Medians over ``runs`` interleaved rounds. Every peer pixel is compared with
Argand's answer (the frame's alpha and its ``status`` AOV); each pixel where
a peer disagrees with Argand, and each pixel Argand did not certify, is
decided by the exact truth (peers_scenes.real_truth: python-flint on the
exact ray polynomial). Wrong pixels are counted per peer and classed:
a spurious hit, a missed hit on a multiple root (a singular curve or a
tangent ray), another missed hit; on the silhouette or not.

Besides the presets, three views put a singular curve or a tangency on a
whole pixel row (odd sizes, where the centre row's rays lie exactly in a
plane): Steiner's double lines (the x and y axes) in the centre row's plane
z = 0, Whitney's double line (the z axis) in the plane y = 0, and a torus seen
from its tangent plane z = 1, which touches it along a circle.

Installs nothing: a peer whose binary is absent is reported "unavailable".
Writes peers.json, peers.md, peers.png (speed against wrong pixels) and
peers_side.png (Argand / surf / POV-Ray side by side, wrong pixels marked).
"""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from argand.bench import machine_info

SURF = "surf-alggeo-nox"
POVRAY = "povray"
PEERS = ("surf", "povray", "povray-sturm")
PEER_LABELS = {"surf": "surf", "povray": "POV-Ray", "povray-sturm": "POV-Ray sturm", "argand": "Argand"}

#: The single-object presets: Whitney, Plücker, the Bicube, Mitchell,
#: Steiner, and the classic degree 5-8 surfaces.
SURFACES = ("whitney", "plucker", "bicube", "mitchell", "steiner", "togliatti", "barth-sextic", "chmutov-septic",
            "chmutov-octic", "endrass-octic")
SIZES = (512, 1024)
SMOKE_SURFACES = ("bicube", "steiner")
SMOKE_SIZES = (96,)

#: Views with a singular curve or a tangency along the centre row (odd sizes).
SPECIAL_SCENES: dict[str, dict] = {
    "steiner-axes": {
        "objects": [{"surface": "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2", "clip_radius": 1.2}],
        "camera": {"position": [3.0, 2.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0]},
    },
    "whitney-axis": {
        "objects": [{"surface": "x^2*z + y^2", "clip_radius": 2}],
        "camera": {"position": [5.5, 0.0, 2.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0]},
    },
    "torus-tangent": {
        "objects": [{"surface": "(x^2 + y^2 + z^2 + 3)^2 - 16*(x^2 + y^2)", "clip_radius": 3.5}],
        "camera": {"position": [6.0, 0.0, 1.0], "look_at": [0.0, 0.0, 1.0], "up": [0.0, 0.0, 1.0]},
    },
}
SPECIAL_NOTES = {
    "steiner-axes": "Steiner's surface from (3, 2, 0): the centre row's rays lie in the plane z = 0, which holds two "
                    "double lines (the x and y axes; beyond |x| = 1/2 they are 1-dimensional whiskers)",
    "whitney-axis": "Whitney's umbrella from (5.5, 0, 2) with up = y: the centre row's rays lie in the plane y = 0, "
                    "which holds the double line (the z axis; its z > 0 half is the 1-dimensional handle)",
    "torus-tangent": "a torus (R = 2, r = 1) from its tangent plane z = 1: every centre-row ray that crosses the circle "
                     "x^2 + y^2 = 4, z = 1 touches the torus there (p(t) = (|x(t)|^2 - 4)^2, double roots)",
}
SPECIAL_SIZES = (511, 1023)
SMOKE_SPECIAL_SIZES = (95,)
SMOKE_SPECIAL = ("steiner-axes", "torus-tangent")

#: The pictures in peers_side.png: (case, size) pairs, the first ones found.
SIDE_CASES = (("steiner", 512), ("steiner-axes", 511), ("torus-tangent", 511), ("chmutov-octic", 512),
              ("steiner", 96), ("steiner-axes", 95), ("torus-tangent", 95), ("bicube", 96))


def peer_versions() -> dict[str, str]:
    out = {}
    for peer, package in (("surf", "surf-alggeo-nox"), ("povray", "povray")):
        if not shutil.which(SURF if peer == "surf" else POVRAY):
            out[peer] = "unavailable"
            continue
        r = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", package], capture_output=True, text=True) \
            if shutil.which("dpkg-query") else None
        out[peer] = r.stdout.strip() if r is not None and r.returncode == 0 else "installed (version unknown)"
    return out


def _scene(case: str):
    from argand.scene import load_scene, scene_from_dict

    return scene_from_dict(SPECIAL_SCENES[case]) if case in SPECIAL_SCENES else load_scene(case)


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


# ---------------------------------------------------------------------------
# One run of each renderer
# ---------------------------------------------------------------------------


def run_surf(core_scene: Any, size: int, work: Path) -> tuple[Any, float, dict]:
    """(hit mask, CPU seconds of the whole surf process, script info)."""
    import numpy as np
    from PIL import Image

    from argand.bench.peers_scenes import surf_script

    image = work / "surf.ppm"
    if image.exists():
        image.unlink()
    text, info = surf_script(core_scene, size, size, image.name)
    (work / "surf.pic").write_text(text)
    before = _children_cpu()
    r = subprocess.run([SURF, "-n", "surf.pic"], cwd=work, capture_output=True, text=True)
    cpu = _children_cpu() - before
    if r.returncode != 0 or not image.exists():
        raise RuntimeError(f"surf failed ({r.returncode}): {(r.stderr or r.stdout)[-500:]}")
    hit = np.asarray(Image.open(image).convert("RGB")).max(axis=2) > 0
    return hit, cpu, info


_TRACE = re.compile(r"Trace Time:.*?\(([\d.]+) seconds\)\s*using \d+ thread\(s\) with ([\d.]+) CPU-seconds", re.S)


def run_povray(core_scene: Any, size: int, sturm: bool, work: Path) -> tuple[Any, float, float]:
    """(hit mask, trace CPU seconds, whole process CPU seconds)."""
    import numpy as np
    from PIL import Image

    from argand.bench.peers_scenes import pov_scene

    image = work / "pov.png"
    if image.exists():
        image.unlink()
    (work / "scene.pov").write_text(pov_scene(core_scene, size, size, sturm))
    before = _children_cpu()
    r = subprocess.run([POVRAY, "+Iscene.pov", f"+O{image.name}", f"+W{size}", f"+H{size}", "-A", "-D", "+FN",
                        "+WT1", "-P", "+GS"], cwd=work, capture_output=True, text=True,
                       env={**os.environ, "HOME": str(work)})
    cpu = _children_cpu() - before
    m = _TRACE.search(r.stderr + r.stdout)
    if r.returncode != 0 or not image.exists() or not m:
        raise RuntimeError(f"povray failed ({r.returncode}): {(r.stderr or r.stdout)[-800:]}")
    hit = np.asarray(Image.open(image).convert("RGB")).max(axis=2) > 127
    return hit, float(m.group(2)), cpu


def run_argand(scene: Any, size: int, real: bool = False) -> tuple[Any, float]:
    """(the FrameResult, CPU seconds of render_frame on one worker); `real`:
    with the real-root path (EngineOptions(real=True))."""
    from argand.render import FrameParams, render_frame
    from argand.render.options import EngineOptions

    params = FrameParams(sigma=0.0, delta=0.0, width=size, height=size, engine=EngineOptions(real=real))
    start = time.process_time()
    result = render_frame(scene, params, workers=1)
    return result, time.process_time() - start


def run_argand_process(case: str, size: int, work: Path) -> float:
    """CPU seconds of the whole `argand render` child (one worker)."""
    target = case
    if case in SPECIAL_SCENES:
        target = str(work / f"{case}.json")
        Path(target).write_text(json.dumps(SPECIAL_SCENES[case]))
    out = work / "argand-out"
    before = _children_cpu()
    r = subprocess.run([sys.executable, "-m", "argand.cli", "render", target, "--size", f"{size}x{size}",
                        "--workers", "1", "--out", str(out), "--overwrite"], capture_output=True, text=True)
    cpu = _children_cpu() - before
    if r.returncode != 0:
        raise RuntimeError(f"argand render failed ({r.returncode}): {(r.stderr or r.stdout)[-800:]}")
    return cpu


# ---------------------------------------------------------------------------
# Comparison with the exact truth
# ---------------------------------------------------------------------------


def _boundary(mask) -> Any:
    """Pixels whose 4-neighbourhood holds the other answer (the silhouette)."""
    import numpy as np

    b = np.zeros_like(mask)
    b[1:, :] |= mask[1:, :] != mask[:-1, :]
    b[:-1, :] |= mask[:-1, :] != mask[1:, :]
    b[:, 1:] |= mask[:, 1:] != mask[:, :-1]
    b[:, :-1] |= mask[:, :-1] != mask[:, 1:]
    return b


def compare(scene: Any, size: int, result: Any, peers: dict[str, Any], truth_cap: int) -> dict:
    """Each peer's wrong pixels (decided by the exact truth), Argand's own
    uncertain and wrong pixels, and the per-pixel masks for the pictures."""
    import numpy as np

    from argand.bench.peers_scenes import real_truth, truth_objects
    from argand.render import primary_ray
    from argand.render.convert import to_core_scene

    core = to_core_scene(scene)
    objects = truth_objects(core)
    a_hit = np.asarray(result.rgba[..., 3] > 0)
    status = np.asarray(result.aovs["status"]).astype(int)
    uncertified = status != 0
    ask = uncertified.copy()
    for mask in peers.values():
        ask |= mask != a_hit
    pixels = [tuple(p) for p in np.argwhere(ask)]  # (row, column)
    sampled = len(pixels) > truth_cap
    if sampled:  # decide a deterministic sample, scale the counts up
        step = len(pixels) / truth_cap
        pixels = [pixels[int(k * step)] for k in range(truth_cap)]
    weight = (int(ask.sum()) / len(pixels)) if pixels else 1.0
    start = time.perf_counter()
    truth: dict[tuple[int, int], Any] = {}
    for y, x in pixels:
        origin, direction = primary_ray(core, size, size, int(x), int(y))
        truth[(int(y), int(x))] = real_truth(objects, origin, direction)
    truth_s = time.perf_counter() - start
    edge = _boundary(a_hit)
    out: dict[str, Any] = {"pixels": size * size, "argand_hits": int(a_hit.sum()),
                           "status_counts": [int(v) for v in np.bincount(status.ravel(), minlength=4)],
                           "truth_pixels": len(pixels), "truth_sampled": sampled, "truth_s": truth_s,
                           "degenerate": sum(t.decision == "degenerate" for t in truth.values()), "peers": {}}
    # Argand: certified pixels the truth contradicts (should be none), and
    # uncertified ones (not claims; counted separately).
    a_wrong = [(y, x) for (y, x), t in truth.items() if t.hit is not None and status[y, x] == 0 and a_hit[y, x] != t.hit]
    out["argand"] = {"wrong": round(len(a_wrong) * weight), "uncertified": int(uncertified.sum()),
                     "uncertified_hits_true": sum(1 for (y, x), t in truth.items() if uncertified[y, x] and t.hit)}
    masks = {"argand_wrong": np.zeros_like(a_hit), "argand_uncertified": uncertified}
    for name, mask in peers.items():
        wrong = np.zeros_like(a_hit)
        kinds = {"spurious_hit": 0, "missed_multiple_root": 0, "missed_simple_root": 0, "silhouette": 0,
                 "centre_row": 0, "centre_column": 0}
        for (y, x), t in truth.items():
            if t.hit is None or bool(mask[y, x]) == t.hit:
                continue
            wrong[y, x] = True
            if mask[y, x]:
                kinds["spurious_hit"] += 1
            elif t.multiple:
                kinds["missed_multiple_root"] += 1
            else:
                kinds["missed_simple_root"] += 1
            kinds["silhouette"] += bool(edge[y, x])
            kinds["centre_row"] += size % 2 == 1 and y == size // 2
            kinds["centre_column"] += size % 2 == 1 and x == size // 2 and y != size // 2
        disagree = int((mask != a_hit).sum())
        out["peers"][name] = {"hits": int(mask.sum()), "disagree_with_argand": disagree,
                              "wrong": round(int(wrong.sum()) * weight),
                              **{k: round(v * weight) for k, v in kinds.items()}}
        masks[name] = mask
        masks[name + "_wrong"] = wrong
    for y, x in a_wrong:
        masks["argand_wrong"][y, x] = True
    masks["argand"] = a_hit
    out["_masks"] = masks
    return out


# ---------------------------------------------------------------------------
# The benchmark
# ---------------------------------------------------------------------------


def _median(values: list[float]) -> float | None:
    values = sorted(v for v in values if v is not None)
    if not values:
        return None
    n = len(values)
    return values[n // 2] if n % 2 else 0.5 * (values[n // 2 - 1] + values[n // 2])


def bench_peers(out_dir: Path = Path("docs/bench"), smoke: bool = False, runs: int | None = None,
                surfaces: tuple[str, ...] | None = None, sizes: tuple[int, ...] | None = None,
                special_sizes: tuple[int, ...] | None = None, special: tuple[str, ...] | None = None,
                truth_cap: int = 20000,
                progress: Callable[[str], None] = lambda m: None) -> dict:
    runs = runs if runs is not None else (1 if smoke else 3)
    surfaces = tuple(surfaces or (SMOKE_SURFACES if smoke else SURFACES))
    sizes = tuple(sizes or (SMOKE_SIZES if smoke else SIZES))
    special_sizes = tuple(special_sizes or (SMOKE_SPECIAL_SIZES if smoke else SPECIAL_SIZES))
    special = tuple(special if special is not None else (SMOKE_SPECIAL if smoke else SPECIAL_SCENES))
    available = {"surf": shutil.which(SURF) is not None, "povray": shutil.which(POVRAY) is not None}
    available["povray-sturm"] = available["povray"]
    cases = [(c, s, False) for s in sizes for c in surfaces] + [(c, s, True) for s in special_sizes for c in special]

    from argand.render.convert import to_core_scene

    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    if affinity is not None:
        os.sched_setaffinity(0, {min(affinity)})  # one core, inherited by every child
    times: dict[tuple, dict[str, list[float]]] = {(c, s): {k: [] for k in
                                                          ("surf", "povray", "povray-sturm", "povray_process",
                                                           "povray-sturm_process", "argand", "argand_process",
                                                           "argand_real")}
                                                  for c, s, _ in cases}
    last: dict[tuple, dict] = {}
    errors: dict[str, str] = {}
    try:
        with tempfile.TemporaryDirectory(prefix="argand-bench-peers-") as tmp:
            work = Path(tmp)
            for round_ in range(runs):
                for index, (case, size, _sp) in enumerate(cases):
                    progress(f"peers: round {round_ + 1}/{runs}, {case} {size}x{size} ({index + 1}/{len(cases)})")
                    scene = _scene(case)
                    core = to_core_scene(scene)
                    t = times[(case, size)]
                    masks: dict[str, Any] = {}
                    info: dict = {}
                    if available["surf"]:
                        try:
                            masks["surf"], cpu, info = run_surf(core, size, work)
                            t["surf"].append(cpu)
                        except Exception as e:  # noqa: BLE001 - a peer's failure is a finding, not a crash
                            errors[f"surf {case} {size}"] = str(e)
                    if available["povray"]:
                        for sturm in (False, True):
                            name = "povray-sturm" if sturm else "povray"
                            try:
                                masks[name], trace, whole = run_povray(core, size, sturm, work)
                                t[name].append(trace)
                                t[name + "_process"].append(whole)
                            except Exception as e:  # noqa: BLE001
                                errors[f"{name} {case} {size}"] = str(e)
                    result, cpu = run_argand(scene, size)
                    t["argand"].append(cpu)
                    t["argand_process"].append(run_argand_process(case, size, work))
                    real, cpu = run_argand(scene, size, real=True)
                    t["argand_real"].append(cpu)
                    if round_ == 0:
                        # The real-root path must decide every pixel as the
                        # complex path does (status and hit).
                        import numpy as np

                        differ = int(((np.asarray(real.aovs["status"]) != np.asarray(result.aovs["status"]))
                                      | ((real.rgba[..., 3] > 0) != (result.rgba[..., 3] > 0))).sum())
                        last[(case, size)] = {"result": result, "masks": masks, "surf_info": info,
                                              "real_differs": differ}
    finally:
        if affinity is not None:
            os.sched_setaffinity(0, affinity)

    rows = []
    pictures = {}
    for case, size, sp in cases:
        progress(f"peers: exact truth for {case} {size}x{size}")
        keep = last[(case, size)]
        cmp = compare(_scene(case), size, keep["result"], keep["masks"], truth_cap)
        masks = cmp.pop("_masks")
        if (case, size) in SIDE_CASES:
            pictures[(case, size)] = masks
        t = times[(case, size)]
        med = {k: _median(v) for k, v in t.items()}
        row = {"case": case, "size": size, "special": sp, "degree": max(o.polynomial.degree for o in _scene(case).objects),
               "cpu_s": med, "runs": runs, "real_path_differs": keep["real_differs"], **cmp}
        if sp:
            row["note"] = SPECIAL_NOTES[case]
        if keep["surf_info"]:
            row["surf_spec_z"] = keep["surf_info"]["spec_z"]
        rows.append(row)

    totals = {}
    groups = [(str(size), size, False) for size in sorted({s for _, s, sp in cases if not sp})]
    groups += [(f"{size} centre-row views", size, True) for size in sorted({s for _, s, sp in cases if sp})]
    for key, size, sp in groups:
        sel = [r for r in rows if r["size"] == size and r["special"] == sp]
        entry: dict[str, Any] = {"cases": len(sel), "special": sp, "size": size}
        for who in ("argand", *PEERS):
            cpu = [r["cpu_s"].get(who) for r in sel]
            wrong = [r["argand"]["wrong"] if who == "argand" else r["peers"].get(who, {}).get("wrong") for r in sel]
            if any(v is None for v in cpu) or any(v is None for v in wrong):
                continue
            entry[who] = {"cpu_s": sum(cpu), "wrong": sum(wrong)}
        entry["argand"]["uncertified"] = sum(r["argand"]["uncertified"] for r in sel)
        entry["argand_process"] = {"cpu_s": sum(r["cpu_s"]["argand_process"] for r in sel)}
        entry["argand_real"] = {"cpu_s": sum(r["cpu_s"]["argand_real"] for r in sel),
                                "differs": sum(r["real_path_differs"] for r in sel)}
        for who in PEERS:
            if who in entry:
                entry[who]["over_argand"] = entry[who]["cpu_s"] / entry["argand"]["cpu_s"]
        totals[key] = entry

    report = {
        "benchmark": "peers", "smoke": smoke, "machine": machine_info(), "versions": peer_versions(),
        "available": available, "runs": runs, "surfaces": list(surfaces), "sizes": list(sizes),
        "special_sizes": list(special_sizes), "special": list(special), "cpu": "one core (sched_setaffinity to CPU 0, inherited by children)",
        "timing": {"surf": "whole surf process, CPU (getrusage of children)",
                   "povray": "POV-Ray's own Trace Time CPU-seconds (+WT1; parse excluded); *_process: the whole process",
                   "argand": "render_frame(workers=1), time.process_time",
                   "argand_process": "`argand render SCENE --size WxH --workers 1`, CPU of the child",
                   "argand_real": "render_frame(workers=1) with EngineOptions(real=True), time.process_time"},
        "rows": rows, "totals": totals, "errors": errors,
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "peers.json").write_text(json.dumps(report, indent=2) + "\n")
    chart(report, out_dir / "peers.png")
    side_by_side(pictures, report, out_dir / "peers_side.png")
    (out_dir / "peers.md").write_text("\n".join(markdown(report)) + "\n")
    return report


# ---------------------------------------------------------------------------
# Charts and the page
# ---------------------------------------------------------------------------

COLORS = {"argand": "#1f77b4", "surf": "#2ca02c", "povray": "#ff7f0e", "povray-sturm": "#d62728"}


def chart(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    groups = list(report["totals"])
    fig, axes = plt.subplots(1, max(1, len(groups)), figsize=(4.6 * max(1, len(groups)), 4.2), squeeze=False)
    for ax, key in zip(axes[0], groups):
        entry = report["totals"][key]
        top = 1
        for who in COLORS:
            if who not in entry:
                continue
            v = entry[who]
            top = max(top, v["wrong"])
            ax.scatter([v["cpu_s"]], [v["wrong"]], s=70, color=COLORS[who], label=PEER_LABELS[who], zorder=3,
                       alpha=0.85)
        if "argand" in entry:
            ax.scatter([entry["argand_process"]["cpu_s"]], [entry["argand"]["wrong"]], s=70, marker="s",
                       facecolors="none", edgecolors=COLORS["argand"], label="Argand, whole process", zorder=3)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_yscale("symlog", linthresh=1)
        ax.set_ylim(-0.3, 4 * top)
        ax.set_xlabel("CPU seconds (sum), one core")
        ax.set_ylabel("wrong pixels (exact truth, sum)")
        size = entry["size"]
        what = "centre-row views" if entry["special"] else "presets"
        ax.set_title(f"{entry['cases']} {what} at {size}x{size}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle("Peers: speed against wrong pixels (lower left is better; Argand's uncertified pixels are not claims)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def side_by_side(pictures: dict, report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    chosen = [k for k in SIDE_CASES if k in pictures][:4] or list(pictures)[:4]
    cols = ["argand", *[p for p in PEERS if report["available"].get(p)]]
    fig, axes = plt.subplots(max(1, len(chosen)), len(cols), figsize=(3.2 * len(cols), 3.3 * max(1, len(chosen))),
                             squeeze=False)
    for r, key in enumerate(chosen):
        masks = pictures[key]
        for c, who in enumerate(cols):
            ax = axes[r][c]
            ax.set_xticks([]), ax.set_yticks([])
            if who not in masks:
                ax.set_title(f"{PEER_LABELS[who]}: no picture", fontsize=8)
                continue
            hit = masks[who]
            img = np.zeros(hit.shape + (3,), dtype=float)
            img[hit] = (0.85, 0.85, 0.85)
            img[~hit] = (0.08, 0.08, 0.1)
            if who == "argand":
                wrong = masks["argand_wrong"]
                img[masks["argand_uncertified"]] = (1.0, 0.85, 0.0)
                count = int(wrong.sum())
                label = f"{count} wrong, {int(masks['argand_uncertified'].sum())} uncertified"
            else:
                wrong = masks[who + "_wrong"]
                count = int(wrong.sum())
                label = f"{count} wrong"
            if count:  # make single pixels visible: a 3x3 marker
                grown = wrong.copy()
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        grown |= np.roll(np.roll(wrong, dy, 0), dx, 1)
                img[grown] = (1.0, 0.0, 0.9)
            ax.imshow(img, interpolation="nearest")
            ax.set_title(f"{PEER_LABELS[who]}: {label}", fontsize=8)
            if c == 0:
                ax.set_ylabel(f"{key[0]} {key[1]}x{key[1]}", fontsize=9)
    fig.suptitle("Real surface (σ = δ = 0), same rays; magenta: pixels the exact truth says are wrong, "
                 "yellow: not certified by Argand", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _fmt(v: float | None) -> str:
    return "–" if v is None else f"{v * 1000:.0f}"


def markdown(report: dict, chart_path: str = "peers.png", side_path: str = "peers_side.png") -> list[str]:
    v = report["versions"]
    lines = ["## Peers: surf and POV-Ray on the same rays", "",
             "`argand bench peers`: surf " + v.get("surf", "?") + " and POV-Ray " + v.get("povray", "?")
             + " draw the real surface (σ = δ = 0) of each single-object preset with Argand's camera rays (to "
             "rounding: surf's window and eye distance, POV-Ray's explicit camera vectors; see "
             "src/argand/bench/peers_scenes.py), flat white on black. One core; medians of "
             f"{report['runs']} interleaved round(s). CPU times: surf's whole process, POV-Ray's own trace time "
             "(parse excluded), Argand's `render_frame(workers=1)` alone and its whole `argand render --workers 1` "
             "process (which also writes the EXR, PNG and JSON), and its render with the real-root path "
             "(`EngineOptions(real=True)`, `ARGAND_REAL=on`; docs/rendering.md), which must decide every pixel as the "
             "default path does. Every pixel where a peer disagrees with Argand, and "
             "every pixel Argand did not certify, is decided by the exact truth (python-flint on the exact rational "
             "ray polynomial); **wrong** counts the pixels it contradicts.", ""]
    if report.get("smoke"):
        lines += ["**Smoke run: tiny sizes, not figures to quote.**", ""]
    missing = [p for p in ("surf", "povray") if not report["available"].get(p)]
    if missing:
        lines += [f"Unavailable here (binary not found): {', '.join(missing)}.", ""]
    lines += [f"![peers: speed against wrong pixels]({chart_path})", ""]
    for key, entry in report["totals"].items():
        if "argand" not in entry:
            continue
        a = entry["argand"]
        what = "centre-row views" if entry["special"] else "presets"
        real = entry.get("argand_real")
        real_text = (f", real-root path {real['cpu_s']:.2f} s ({a['cpu_s'] / real['cpu_s']:.2f}× the default's speed, "
                     f"{real['differs']} pixels decided otherwise)" if real and real["cpu_s"] else "")
        lines += [f"The {entry['cases']} {what} at {entry['size']}×{entry['size']}: Argand {a['cpu_s']:.2f} s CPU "
                  f"(whole process {entry['argand_process']['cpu_s']:.2f} s{real_text}), {a['wrong']} wrong, "
                  f"{a['uncertified']} not certified; "
                  + "; ".join(f"{PEER_LABELS[p]} {entry[p]['cpu_s']:.2f} s ({entry[p]['over_argand']:.2f}× Argand's "
                              f"render), {entry[p]['wrong']} wrong" for p in PEERS if p in entry) + ".", ""]
    lines += ["| surface | size | degree | Argand ms | Argand process ms | Argand real path ms | surf ms | POV-Ray ms "
              "| POV-Ray sturm ms | Argand uncertified | surf wrong | POV-Ray wrong | POV-Ray sturm wrong |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in report["rows"]:
        c = r["cpu_s"]
        wrong = [str(r["peers"][p]["wrong"]) if p in r["peers"] else "–" for p in PEERS]
        aw = r["argand"]["wrong"]
        differs = r.get("real_path_differs", 0)
        lines.append(f"| {r['case']} | {r['size']} | {r['degree']} | {_fmt(c['argand'])} | {_fmt(c['argand_process'])} | "
                     f"{_fmt(c.get('argand_real'))}{f' ({differs} decided otherwise!)' if differs else ''} | "
                     f"{_fmt(c['surf'])} | {_fmt(c['povray'])} | {_fmt(c['povray-sturm'])} | "
                     f"{r['argand']['uncertified']}{f' ({aw} wrong!)' if aw else ''} | " + " | ".join(wrong) + " |")
    lines += ["", "What the wrong pixels are (spurious hit / missed on a multiple root / missed on a simple root; "
              "on the silhouette; on an odd frame's centre row or column):", ""]
    lines += ["| surface | size | peer | wrong | spurious hit | missed, multiple root | missed, simple root "
              "| silhouette | centre row | centre column |", "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in report["rows"]:
        for p in PEERS:
            e = r["peers"].get(p)
            if e and e["wrong"]:
                lines.append(f"| {r['case']} | {r['size']} | {PEER_LABELS[p]} | {e['wrong']} | {e['spurious_hit']} | "
                             f"{e['missed_multiple_root']} | {e['missed_simple_root']} | {e['silhouette']} | "
                             f"{e['centre_row']} | {e.get('centre_column', 0)} |")
    sampled = [f"{r['case']} {r['size']}" for r in report["rows"] if r["truth_sampled"]]
    if sampled:
        lines += ["", f"Too many disagreements to decide all of them for {', '.join(sampled)}: a deterministic sample "
                  "was decided and the counts scaled up."]
    specials = [r for r in report["rows"] if r["special"]]
    if specials:
        lines += ["", "### A singular curve and a tangency along the centre row", "",
                  "At an odd size the centre row's rays have sy = 0 exactly, so they lie exactly in the plane "
                  "through the eye spanned by the view direction and the right vector. Three views put that plane "
                  "on a singular curve or a tangent plane:", ""]
        for case in dict.fromkeys(r["case"] for r in specials):
            lines.append(f"- **{case}**: {SPECIAL_NOTES[case]}.")
        lines += [""]
    lines += [f"![Argand, surf, POV-Ray side by side]({side_path})", ""]
    lines += explain(report)
    if report["errors"]:
        lines += ["", "Peer failures: " + "; ".join(f"{k}: {v[:200]}" for k, v in report["errors"].items())]
    return lines


def explain(report: dict) -> list[str]:
    """The reading of the wrong pixels, from the counts of this run."""
    def total(peer: str, key: str, special: bool) -> int:
        return sum(r["peers"].get(peer, {}).get(key, 0) for r in report["rows"] if r["special"] == special)

    lines = ["### Reading the wrong pixels", ""]
    for p in PEERS:
        if not report["available"].get(p):
            continue
        parts = []
        for special, what in ((False, "the presets"), (True, "the centre-row views")):
            w = total(p, "wrong", special)
            parts.append(f"on {what} {w} wrong" + (
                f" ({total(p, 'spurious_hit', special)} spurious hits, {total(p, 'missed_multiple_root', special)} "
                f"missed hits on a multiple root, {total(p, 'missed_simple_root', special)} other missed hits; "
                f"{total(p, 'silhouette', special)} on the silhouette, {total(p, 'centre_row', special)} on the "
                f"centre row, {total(p, 'centre_column', special)} on the centre column)" if w else ""))
        worst = sorted(((r["peers"][p]["wrong"], r["case"], r["size"]) for r in report["rows"]
                        if r["peers"].get(p, {}).get("wrong")), reverse=True)[:4]
        lines.append(f"- **{PEER_LABELS[p]}**: " + "; ".join(parts) + "."
                     + (" Most: " + ", ".join(f"{c} {s}² ({w})" for w, c, s in worst) + "." if worst else ""))
    lines += ["",
              "The peers find real roots in doubles: surf subdivides and bisects on sign changes of the rounded "
              "ray polynomial, POV-Ray counts them with Sturm sequences (`sturm`; for degree > 4 POV-Ray always "
              "uses them) or solves a quartic in closed form. Where the exact polynomial has a real double root (a "
              "ray through a singular curve, or tangent to the surface) rounding splits it into a complex pair with "
              "a tiny imaginary part or two close real roots, and the peer may see no real root: a **missed hit on "
              "a multiple root** (POV-Ray's quartic solver along Steiner's double lines and the torus's tangent "
              "circle, the centre row). The reverse is a **spurious hit**: where the exact polynomial has only a "
              "complex pair with a tiny imaginary part, the rounded one has a real double root and the peer draws "
              "it: isolated dots along Steiner's 1-dimensional whiskers (the z axis passes the centre column's rays "
              "at a rounding's distance, not exactly), or along a grazing silhouette. A **missed simple root** is "
              "a pair of close simple roots that a sign-change search steps over (surf on rays that graze the "
              "torus just below its tangent plane).",
              "",
              "Argand certifies a pixel only with a proof: a pixel on a double root is reported as not certified "
              "(status cluster) rather than guessed, and the exact truth decides those pixels here as well. "
              f"Argand: {sum(r['argand']['wrong'] for r in report['rows'])} certified pixels contradicted by the "
              "truth among those checked (every pixel where a peer disagrees with it, and every uncertified one); "
              f"{sum(r['argand']['uncertified'] for r in report['rows'])} pixels not certified, of which the truth "
              f"says {sum(r['argand']['uncertified_hits_true'] for r in report['rows'])} hit."]
    return lines
