"""`argand bench farm`: one job of 36 frames at 512x512 on 1 worker and on 2
workers in the same run, for tile sizes 32, 64, 128 and whole frames:
seconds, frames per second, scaling, time to the first frame, and where the
workers' time went besides rendering, as shares of the render time:

* encoding: writing the frame's files (EXR with every AOV, PNG, thumbnail,
  GIF fragment) -- the same work a local `argand render` does;
* dispatch: everything else the farm adds (messages, claims and
  completions, tile files, stitching, animation, idle workers).

The alternative runs in the same rounds: the same frames rendered and
written by `argand render` on this machine (``render_sweep``) on 1 and on 2
threads at the default tile size. A farm's time over it is what the farm
costs beyond the work itself.

Times come from the server's own clocks (job created -> finished, each
frame's finish), so the benchmark's polling does not blur them."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import httpx

from argand.bench import machine_info


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LocalFarm:
    """`argand serve` in a subprocess on a free loopback port."""

    def __init__(self, data: Path, workers: int, env: dict[str, str] | None = None) -> None:
        self.data, self.workers, self.port = data, workers, _free_port()
        self.extra_env = env or {}
        self.url = f"http://127.0.0.1:{self.port}"

    def __enter__(self) -> "LocalFarm":
        argand = str(Path(sys.executable).with_name("argand"))
        env = dict(os.environ)
        env.pop("ARGAND_REDIS_URL", None)
        env.update(self.extra_env)
        self.data.mkdir(parents=True, exist_ok=True)
        with open(self.data / "serve.log", "w") as log:
            self.proc = subprocess.Popen([argand, "serve", "--workers", str(self.workers), "--port", str(self.port),
                                          "--data", str(self.data)], env=env, stdout=log, stderr=subprocess.STDOUT,
                                         start_new_session=True)
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            try:
                if httpx.get(self.url + "/healthz", timeout=2).status_code == 200:
                    alive = [w for w in httpx.get(self.url + "/api/workers").json() if w["alive"]]
                    if len(alive) >= self.workers:
                        return self
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        raise RuntimeError(f"the farm did not start; see {self.data / 'serve.log'}")

    def __exit__(self, *exc) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)

    def run_job(self, body: dict) -> dict:
        job = httpx.post(self.url + "/api/jobs", json=body, timeout=120).json()
        while True:
            time.sleep(1.0)  # a light poll: the farm shares the machine, and the times are the server's
            view = httpx.get(self.url + f"/api/jobs/{job['id']}", timeout=60).json()
            if view["status"] in ("done", "failed", "canceled"):
                break
        figures = [f["figures"] or {} for f in view["frames"]]
        created = view["created"]
        return {
            "status": view["status"],
            "wall_s": view["finished"] - created if view["finished"] else float("nan"),
            "first_frame_s": min(f["finished"] for f in view["frames"] if f["finished"]) - created,
            "render_s": sum(f.get("seconds", 0.0) for f in figures),
            "assembly_s": sum(f.get("assembly_s", 0.0) for f in figures),
            "encode_s": sum(f.get("encode_s", 0.0) for f in figures),
        }


#: The job: SCENE, deltas from 0 to SWEEP_STOP (the same on the farms and in
#: the local baseline).
SCENE, SWEEP_STOP = "bicube", "pi/9"


def _median(runs: list[dict]) -> dict:
    """The run with the median wall time, and every run's wall time."""
    middle = sorted(runs, key=lambda r: r["wall_s"])[len(runs) // 2]
    return dict(middle, wall_s_all=[r["wall_s"] for r in runs])


def bench_farm(out_dir: Path = Path("docs/bench"), smoke: bool = False, progress: Callable[[str], None] = lambda m: None,
               exr_compression: str | None = None, repeat: int | None = None) -> dict:
    """Both farms run side by side (an idle farm costs nothing), and the
    measurements alternate between them, ``repeat`` times: a drift of the
    machine's speed then hits both alike. Each row is the repetition with
    the median wall time."""
    from argand.farm.settings import Settings

    env = {"ARGAND_EXR_COMPRESSION": exr_compression} if exr_compression else {}
    defaults = Settings()
    compression = exr_compression or defaults.exr_compression
    frames, size = (3, 192) if smoke else (36, 512)
    repeat = repeat or (1 if smoke else 3)
    tiles = (32, 64, 128, size)
    samples: dict[tuple[int, object], list[dict]] = {}
    local_samples: dict[int, list[dict]] = {}
    with tempfile.TemporaryDirectory(prefix="argand-bench-farm-") as tmp:
        progress("starting farms of 1 and 2 workers")
        with LocalFarm(Path(tmp) / "w1", 1, env) as one, LocalFarm(Path(tmp) / "w2", 2, env) as two:
            for rep in range(repeat):
                for threads in (1, 2):
                    progress(f"round {rep + 1}/{repeat}: argand render on {threads} thread(s): {frames} frames of {size}x{size}")
                    local_samples.setdefault(threads, []).append(
                        _local_render(Path(tmp) / f"local{threads}", frames, size, defaults.default_tile, threads, compression))
                for tile in tiles:
                    for workers, farm in ((1, one), (2, two)):
                        progress(f"round {rep + 1}/{repeat}: {workers} worker(s), tile {tile}: {frames} frames of {size}x{size}")
                        body = {"scene": SCENE, "deltas": {"start": 0, "stop": SWEEP_STOP, "count": frames},
                                "width": size, "height": size, "tile": tile}
                        r = farm.run_job(body)
                        busy = r["wall_s"] * workers  # worker-seconds
                        render = max(r["render_s"], 1e-9)
                        r.update(workers=workers, tile=tile if tile != size else "frame", frames=frames, size=size,
                                 fps=frames / r["wall_s"],
                                 # the overhead: every worker-second that is not rendering
                                 overhead_share=max(0.0, (busy - r["render_s"]) / render),
                                 encode_share=r["encode_s"] / render,
                                 dispatch_share=max(0.0, (busy - r["render_s"] - r["encode_s"]) / render))
                        samples.setdefault((workers, r["tile"]), []).append(r)
    rows = [_median(samples[key]) for key in sorted(samples, key=lambda k: (k[0], tiles.index(size if k[1] == "frame" else k[1])))]
    local = [_median(runs) for _, runs in sorted(local_samples.items())]
    local_s = {r["threads"]: r["wall_s"] for r in local}
    for r in rows:
        # > 1: the farm takes longer than argand render on as many threads
        r["vs_local"] = r["wall_s"] / local_s[r["workers"]]
    by = {(r["workers"], r["tile"]): r for r in rows}
    report = {
        "benchmark": "farm",
        "machine": machine_info(),
        "scene": SCENE,
        "frames": frames,
        "size": size,
        "runs": rows,
        "scaling_2_vs_1": {str(t): by[(1, t)]["wall_s"] / by[(2, t)]["wall_s"] for t in (32, 64, 128, "frame")},
        "local": local,
        "default_tile": defaults.default_tile,
        "exr_compression": compression,
        "repeat": repeat,
        "measures": {
            "wall_s": "server clock, job created -> job done (animation included); the median of `repeat` runs",
            "first_frame_s": "server clock, job created -> first frame done",
            "render_s": "sum over tiles of the C++ render time",
            "overhead_share": "(wall_s * workers - render_s) / render_s: all worker time that is not rendering",
            "encode_share": "encoding the frames' files (EXR, PNG, thumbnail, GIF fragment) / render_s",
            "dispatch_share": "the rest (messages, claims, tile files, stitching, animation, idle) / render_s",
            "local": "argand render of the same frames and files in one process (render_sweep), 1 and 2 threads, "
                     "default tile; the median of `repeat` runs",
            "vs_local": "wall_s / the local wall_s on as many threads (1 worker vs 1 thread, 2 vs 2): "
                        "above 1, the farm's cost beyond the work itself",
        },
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "farm.json").write_text(json.dumps(report, indent=2) + "\n")
    (out_dir / "farm.md").write_text(markdown(report))
    chart(report, out_dir / "farm.png")
    return report


def _local_render(out: Path, frames: int, size: int, tile: int, threads: int, compression: str) -> dict:
    """The alternative: `argand render` of the job's frames, in this process."""
    from argand.render import FrameParams, delta_sweep, parse_angle
    from argand.render.sweep import render_sweep
    from argand.scene import load_scene

    scene = load_scene(SCENE)
    params = [FrameParams(sigma=0.0, delta=d, width=size, height=size)
              for d in delta_sweep(0.0, parse_angle(SWEEP_STOP), frames)]
    start = time.perf_counter()
    # (No MP4: the farm makes it on request, not while the job runs.)
    figures = render_sweep(scene, params, out, tile=tile, workers=threads, compression=compression, mp4=False)
    wall = time.perf_counter() - start
    return {"threads": threads, "tile": tile, "wall_s": wall, "fps": frames / wall,
            "render_s": sum(f["seconds"] for f in figures)}


def markdown(report: dict) -> str:
    lines = [
        f"{report['frames']} frames of {report['size']}×{report['size']} ({report['scene']}), EXR compression "
        f"`{report['exr_compression']}`, median of {report['repeat']} alternating runs; shares are of the render time.",
        "",
        "| workers | tile | seconds | frames / s | first frame (s) | encoding | dispatch | overhead (all) | vs `argand render` |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in report["runs"]:
        lines.append(f"| {r['workers']} | {r['tile']} | {r['wall_s']:.2f} | {r['fps']:.2f} | {r['first_frame_s']:.2f} | "
                     f"{100 * r['encode_share']:.0f}% | {100 * r['dispatch_share']:.0f}% | {100 * r['overhead_share']:.0f}% | "
                     f"{100 * (r['vs_local'] - 1):+.0f}% |")
    lines += ["", "Scaling from 1 to 2 workers: " + ", ".join(
        f"tile {k}: {v:.2f}×" for k, v in report["scaling_2_vs_1"].items()) + ".", "",
        "The same frames and files by `argand render` in one process (tile "
        f"{report['local'][0]['tile']}): " + ", ".join(
            f"{r['threads']} thread(s) {r['wall_s']:.2f} s ({r['fps']:.2f} frames / s)" for r in report["local"])
        + "; the last column is a farm's time over it on as many workers as threads.", ""]
    return "\n".join(lines)


def chart(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = ["32", "64", "128", "frame"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    xs = list(range(len(labels)))
    for workers, color in ((1, "C1"), (2, "C0")):
        runs = {str(r["tile"]): r for r in report["runs"] if r["workers"] == workers}
        offset = -0.2 if workers == 1 else 0.2
        pos = [x + offset for x in xs]
        a.bar(pos, [runs[l]["fps"] for l in labels], width=0.4, color=color, label=f"{workers} worker(s)")
        local = next(r for r in report["local"] if r["threads"] == workers)
        a.axhline(local["fps"], color=color, lw=1, ls="--", label=f"argand render, {workers} thread(s)")
        enc = [100 * runs[l]["encode_share"] for l in labels]
        disp = [100 * runs[l]["dispatch_share"] for l in labels]
        b.bar(pos, enc, width=0.4, color=color, alpha=0.45, label=f"{workers} worker(s): encoding the files (% of render time)")
        b.bar(pos, disp, width=0.4, bottom=enc, color=color, label=f"{workers} worker(s): dispatch and the rest")
        b.plot(pos, [100 * (runs[l]["vs_local"] - 1) for l in labels], "D", color="k" if workers == 1 else "0.45",
               ms=5, label=f"{workers} worker(s): time over argand render, {workers} thread(s) (% of its time)")
    b.axhline(10, color="k", lw=0.8, ls="--", label="10% (the overhead target)")
    b.axhline(0, color="k", lw=0.5)
    for ax, title, ylabel in ((a, "throughput", "frames per second"),
                              (b, "worker time besides rendering; the farm over argand render", "%")):
        ax.set_xticks(xs, labels)
        ax.set_xlabel("tile size (pixels)")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.legend(fontsize=7, loc="lower right" if ax is a else "center right")
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"argand bench farm — {report['frames']} frames of {report['size']}x{report['size']} ({report['scene']})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
