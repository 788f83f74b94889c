"""Bands: what a job's frames gain from sharing their rays and roots.

Three measurements, each against its alternative in the same run:

* render: a δ sweep's frames rendered together (render_bands: each tile's
  primary roots solved once) against the same frames one by one
  (render_frame), CPU time on one thread, and whether every channel of
  every frame is the same bits;
* CLI: `argand render` of the sweep (every file written) against one frame,
  whole process, wall and CPU time, one thread (--workers 1);
* band on demand: the band route's work (decide the band from the job's
  root field, encode its PNG: argand.farm.bands) over random (σ, δ) pairs,
  p50 and p95, against solving the band from scratch on the same pairs.

Writes bands.json, bands.md and bands.png under the output folder.
"""

from __future__ import annotations

import json
import math
import random
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from argand.bench import machine_info

#: (The Endrass octic: pixels that climb the ladder in many bands, whose
#: answers the bands share.)
SCENES = ("bicube", "whitney", "barth-sextic", "chmutov-octic", "endrass-octic")


def _sweep(size: int, frames: int):
    from argand.render import FrameParams

    return [FrameParams(delta=i * (math.pi / 9) / max(1, frames - 1), width=size, height=size) for i in range(frames)]


def bench_render_together(scene_name: str, size: int, frames: int, rounds: int) -> dict:
    import numpy as np

    from argand.render import exact, render_frame
    from argand.render.frames import AOV_CHANNELS, render_bands
    from argand.scene import load_scene

    scene = load_scene(scene_name)
    params = _sweep(size, frames)
    best_together = best_alone = best_one = math.inf
    for _ in range(rounds):
        exact._rays.clear()  # (each way starts without the exact tier's rays another way solved)
        cpu = time.process_time()
        together = render_bands(scene, params, workers=1)
        best_together = min(best_together, time.process_time() - cpu)
        alone = []
        cpu = time.process_time()
        for p in params:
            exact._rays.clear()  # (a frame alone, as `argand render --delta D` renders it)
            alone.append(render_frame(scene, p, workers=1))
        best_alone = min(best_alone, time.process_time() - cpu)
        exact._rays.clear()
        cpu = time.process_time()
        render_frame(scene, params[len(params) // 2], workers=1)
        best_one = min(best_one, time.process_time() - cpu)
    same = all(a.rgba.tobytes() == b.rgba.tobytes() and
               all(np.asarray(a.aovs[k]).tobytes() == np.asarray(b.aovs[k]).tobytes() for k in AOV_CHANNELS)
               for a, b in zip(together, alone))
    return {"scene": scene_name, "size": size, "frames": frames, "together_cpu_s": best_together,
            "alone_cpu_s": best_alone, "one_frame_cpu_s": best_one, "speedup": best_alone / best_together,
            "together_over_one_frame": best_together / best_one, "bit_identical": same}


def _run_cli(args: list[str]) -> tuple[float, float]:
    """(wall, CPU of the child) of one `argand ...` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "argand.cli", *args], check=True, capture_output=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def bench_cli(size: int, frames: int, atlas: int, atlas_size: int, repeat: int) -> dict:
    def median(args: list[str]) -> dict:
        runs = []
        for _ in range(repeat):
            with tempfile.TemporaryDirectory(prefix="argand-bench-bands-") as tmp:
                runs.append(_run_cli([*args, "--workers", "1", "--out", str(Path(tmp) / "out")]))
        walls, cpus = sorted(r[0] for r in runs), sorted(r[1] for r in runs)
        return {"wall_s": walls[len(walls) // 2], "cpu_s": cpus[len(cpus) // 2]}

    one = median(["render", "bicube", "--delta", "pi/18", "--size", f"{size}x{size}"])
    sweep = median(["render", "bicube", "--deltas", f"0:pi/9:{frames}", "--size", f"{size}x{size}"])
    one_small = median(["render", "bicube", "--delta", "pi/18", "--size", f"{atlas_size}x{atlas_size}"])
    atlas_run = median(["render", "bicube", "--atlas", str(atlas), "--size", f"{atlas_size}x{atlas_size}"])
    return {"size": size, "frames": frames, "one_frame": one, "sweep": sweep,
            "sweep_over_one": sweep["wall_s"] / one["wall_s"],
            "atlas": atlas, "atlas_frames": atlas * (atlas + 1) // 2, "atlas_size": atlas_size,
            "one_frame_atlas_size": one_small, "atlas_run": atlas_run,
            "atlas_over_one": atlas_run["wall_s"] / one_small["wall_s"]}


#: The scenes of the whole-process figure: `argand render SCENE` of one frame, every core (the default).
CLI_PROCESS_SCENES = ("bicube", "whitney", "chmutov-octic")


def bench_cli_process(size: int, scenes: tuple[str, ...], repeat: int) -> dict:
    """cli_process_cpu_s: the CPU (user + sys, every thread, from
    getrusage(RUSAGE_CHILDREN)) of a whole `argand render SCENE --size
    SIZExSIZE` process, one frame as a user runs it (every core, every file
    written), median of ``repeat``: the interpreter, the imports, the render
    and the files (issue 25 asks for at most 0.25 s at 512²)."""
    figures = {}
    for scene in scenes:
        cpus = []
        for _ in range(repeat):
            with tempfile.TemporaryDirectory(prefix="argand-bench-cli-") as tmp:
                cpus.append(_run_cli(["render", scene, "--size", f"{size}x{size}", "--out", str(Path(tmp) / "out")])[1])
        figures[scene] = sorted(cpus)[len(cpus) // 2]
    return {"size": size, "runs": repeat, "cli_process_cpu_s": figures}


def bench_band_route(scene_name: str, size: int, pairs: int, tile: int = 64) -> dict:
    """The band route's work per request (argand.farm.bands: the band on
    every core, then its PNG) over random pairs of the band rule, two ways
    on the same pairs, interleaved: decided from the job's root field
    (recorded once, as the farm's workers do) and solved from scratch. Every
    derived frame is compared with the scratch frame, every channel."""
    from argand.farm.bands import _png_bytes
    from argand.render import FrameParams, render_frame
    from argand.render.field import RootField
    from argand.render.frames import AOV_CHANNELS, render_bands
    from argand.scene import load_scene

    scene = load_scene(scene_name)
    field = RootField(0, 0, 0, 0)
    record_start = time.perf_counter()
    render_bands(scene, [FrameParams(width=size, height=size)], tile=tile, record=field)
    record_s = time.perf_counter() - record_start
    rng = random.Random(7)
    solved, derived, same = [], [], True
    for _ in range(pairs):
        sigma = rng.uniform(0, math.pi)
        p = FrameParams(sigma=sigma, delta=rng.uniform(0, math.pi - sigma), width=size, height=size)
        start = time.perf_counter()
        a = render_bands(scene, [p], tile=tile, field=field)[0]
        _png_bytes(a)
        derived.append(time.perf_counter() - start)
        start = time.perf_counter()
        b = render_frame(scene, p, tile=tile)
        _png_bytes(b)
        solved.append(time.perf_counter() - start)
        same = same and a.rgba.tobytes() == b.rgba.tobytes() and all(
            a.aovs[n].tobytes() == b.aovs[n].tobytes() for n in AOV_CHANNELS)

    def pick(times: list, q: float) -> float:
        times = sorted(times)
        return times[min(len(times) - 1, int(q * len(times)))]

    return {"scene": scene_name, "size": size, "pairs": pairs, "field_mb": field.nbytes / 1e6, "record_s": record_s,
            "p50_s": pick(derived, 0.5), "p95_s": pick(derived, 0.95), "max_s": max(derived),
            "solved_p50_s": pick(solved, 0.5), "solved_p95_s": pick(solved, 0.95),
            "p50_speedup": pick(solved, 0.5) / pick(derived, 0.5), "bit_identical": same}


#: How the farm writes a job's frames: (key, environment).
FARM_MODES = (
    ("files_on_request", {}),
    ("exr_on_request", {"ARGAND_FILES_ON_REQUEST": "false"}),
    ("exr_written", {"ARGAND_FILES_ON_REQUEST": "false", "ARGAND_EXR_ON_REQUEST": "false"}),
)
FARM_MODE_LABELS = {
    "files_on_request": "every file on its first request (default)",
    "exr_on_request": "PNG, thumbnail, GIF by the assembler; EXR on request",
    "exr_written": "every file by the assembler",
}


def bench_farm_frames(size: int, frames: int, rounds: int) -> dict:
    """The farm (`argand serve --workers 2`): a job of `frames` frames of the
    Bicube against a 1-frame job, submit to done (the server's clock), the
    jobs interleaved on one farm, medians; for each way the farm writes the
    frames' files (FARM_MODES: every file on request, the default; the EXR
    only; none)."""
    import tempfile

    from argand.bench.farm import LocalFarm

    out: dict = {"size": size, "frames": frames, "rounds": rounds}
    for mode, env in FARM_MODES:
        with tempfile.TemporaryDirectory(prefix="argand-bench-bands-") as tmp, \
                LocalFarm(Path(tmp) / "farm", 2, env) as farm:
            one, many = [], []
            for _ in range(rounds):
                body = {"scene": "bicube", "width": size, "height": size}
                one.append(farm.run_job({**body, "deltas": [0]})["wall_s"])
                many.append(farm.run_job({**body, "deltas": {"start": 0, "stop": "pi/9", "count": frames}})["wall_s"])
            one.sort()
            many.sort()
            out[mode] = {"one_frame_s": one[len(one) // 2], "job_s": many[len(many) // 2],
                         "over_one": many[len(many) // 2] / one[len(one) // 2]}
    return out


def bench_bands(out_dir: Path = Path("docs/bench"), smoke: bool = False,
                progress: Callable[[str], None] = lambda m: None) -> dict:
    out_dir.mkdir(parents=True, exist_ok=True)
    size, frames, rounds = (64, 6, 1) if smoke else (512, 24, 3)
    report: dict = {"machine": machine_info(), "smoke": smoke, "render": []}
    for name in SCENES[:2] if smoke else SCENES:
        progress(f"bands: {name} {size}x{size}, {frames} bands together and one by one")
        report["render"].append(bench_render_together(name, size, frames, rounds))
    progress("bands: argand render, a sweep and an atlas against one frame (whole process)")
    report["cli"] = bench_cli(size, frames, 3 if smoke else 12, 48 if smoke else 256, 1 if smoke else 3)
    progress("bands: argand render of one frame, the whole process's CPU")
    report["cli_process"] = bench_cli_process(size, CLI_PROCESS_SCENES[:1] if smoke else CLI_PROCESS_SCENES,
                                              1 if smoke else 5)
    progress("bands: the band route's work over random pairs")
    report["band_route"] = [bench_band_route(name, size, 4 if smoke else 40)
                            for name in ("bicube", "whitney", "chmutov-octic")]
    progress(f"bands: the farm, a {frames}-frame job against a 1-frame job")
    report["farm"] = bench_farm_frames(size, frames, 1 if smoke else 5)
    (out_dir / "bands.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "bands.md").write_text("\n".join(markdown(report)) + "\n")
    chart(report, out_dir / "bands.png")
    return report


def markdown(report: dict, image: str = "bands.png") -> list[str]:
    m = report["machine"]
    cli = report["cli"]
    lines = ["## Bands: a job's frames share their rays and roots", "",
             "`argand bench bands`. " +
             f"{m['processor']}, {m['cpu_count']} cores, load average {m['load_average_1_5_15_min'][0]:.1f} at the start, "
             f"{m['date']}." + (" **Smoke run: tiny sizes.**" if report["smoke"] else ""), "",
             "Frames rendered together (`render_bands`: each tile's primary roots solved once, then each band "
             "decided, escalated and shaded on its own) against the same frames one by one, CPU time on one "
             "thread (best of the rounds); every channel of every frame compared:", "",
             "| scene | size | bands | together | one by one | speed-up | together / one frame | same bits |",
             "|---|---:|---:|---:|---:|---:|---:|:---:|"]
    for r in report["render"]:
        lines.append(f"| {r['scene']} | {r['size']}² | {r['frames']} | {r['together_cpu_s']:.3f} s | "
                     f"{r['alone_cpu_s']:.3f} s | {r['speedup']:.2f}× | {r['together_over_one_frame']:.1f}× | "
                     f"{'yes' if r['bit_identical'] else '**no**'} |")
    lines += ["", "`argand render` on one thread (`--workers 1`), whole process, every file written (median wall time):", "",
              "| run | wall | CPU | over one frame |", "|---|---:|---:|---:|",
              f"| one frame, {cli['size']}² | {cli['one_frame']['wall_s']:.2f} s | {cli['one_frame']['cpu_s']:.2f} s | 1 |",
              f"| δ sweep of {cli['frames']}, {cli['size']}² | {cli['sweep']['wall_s']:.2f} s | {cli['sweep']['cpu_s']:.2f} s "
              f"| {cli['sweep_over_one']:.1f}× |",
              f"| one frame, {cli['atlas_size']}² | {cli['one_frame_atlas_size']['wall_s']:.2f} s | "
              f"{cli['one_frame_atlas_size']['cpu_s']:.2f} s | 1 |",
              f"| atlas of {cli['atlas']} ({cli['atlas_frames']} frames), {cli['atlas_size']}² | {cli['atlas_run']['wall_s']:.2f} s "
              f"| {cli['atlas_run']['cpu_s']:.2f} s | {cli['atlas_over_one']:.1f}× |", ""]
    process = report.get("cli_process")
    if process:  # (absent from a report made before it was measured)
        figures = process["cli_process_cpu_s"]
        lines += [f"One frame as a user runs it, `argand render SCENE --size {process['size']}x{process['size']}` (every "
                  f"core, every file written): the whole process's CPU, user + sys of every thread "
                  f"(cli_process_cpu_s, median of {process['runs']}): "
                  + ", ".join(f"{scene} {cpu:.2f} s" for scene, cpu in figures.items()) + ". (How it came down, "
                  "round by round, and where the rest goes: docs/performance.md, \"One frame as a whole process\".)",
                  ""]
    lines += [
              "The band route's work per request (the band on every core, then its PNG), random pairs, decided "
              "from the job's root field against solved from scratch (same pairs, interleaved; every channel "
              "compared):", "",
              "| scene | size | field | pairs | from the field p50 / p95 | solved p50 / p95 | speed-up (p50) | same bits |",
              "|---|---:|---:|---:|---:|---:|---:|:---:|"]
    for r in report["band_route"]:
        if "solved_p50_s" not in r:  # (a report from before the root field: the band solved per request)
            lines.append(f"| {r['scene']} | {r['size']}² | none | {r['pairs']} | — | "
                         f"{1000 * r['p50_s']:.0f} / {1000 * r['p95_s']:.0f} ms | — | — |")
            continue
        lines.append(f"| {r['scene']} | {r['size']}² | {r['field_mb']:.1f} MB | {r['pairs']} | "
                     f"{1000 * r['p50_s']:.0f} / {1000 * r['p95_s']:.0f} ms | "
                     f"{1000 * r['solved_p50_s']:.0f} / {1000 * r['solved_p95_s']:.0f} ms | {r['p50_speedup']:.2f}× | "
                     f"{'yes' if r['bit_identical'] else '**no**'} |")
    farm = report.get("farm")
    if farm:
        lines += ["", f"The farm (`argand serve --workers 2`), a {farm['frames']}-frame job of the Bicube at "
                  f"{farm['size']}² against a 1-frame job, submit to done (median of {farm['rounds']}):", "",
                  "| frames' files | 1-frame job | " + f"{farm['frames']}-frame job | over one |", "|---|---:|---:|---:|"]
        for mode, label in FARM_MODE_LABELS.items():
            r = farm.get(mode)
            if r is None:  # (a report of an earlier version)
                continue
            lines.append(f"| {label} | {r['one_frame_s']:.2f} s | {r['job_s']:.2f} s | {r['over_one']:.1f}× |")
    lines += ["", f"![bands: together against one by one]({image})"]
    return lines


def chart(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    names = [r["scene"] for r in report["render"]]
    x = range(len(names))
    ax.bar([i - 0.2 for i in x], [r["alone_cpu_s"] for r in report["render"]], 0.4, label="one by one")
    ax.bar([i + 0.2 for i in x], [r["together_cpu_s"] for r in report["render"]], 0.4, label="together (roots solved once)")
    ax.set_xticks(list(x), names)
    r0 = report["render"][0]
    ax.set_ylabel(f"CPU s, {r0['frames']} bands at {r0['size']}²")
    ax.set_title("A δ sweep's frames: rendered together against one by one (same bits)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
