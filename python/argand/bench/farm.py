"""`argand bench farm`: one job of 36 frames at 512x512 on 1 worker and on 2
workers in the same run, for tile sizes 32, 64, 128 and whole frames:
seconds, frames per second, scaling, time to the first frame, and the
dispatch + assembly overhead as a share of render time."""

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

    def __init__(self, data: Path, workers: int) -> None:
        self.data, self.workers, self.port = data, workers, _free_port()
        self.url = f"http://127.0.0.1:{self.port}"

    def __enter__(self) -> "LocalFarm":
        argand = str(Path(sys.executable).with_name("argand"))
        env = dict(os.environ)
        env.pop("ARGAND_REDIS_URL", None)
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
        t0 = time.perf_counter()
        job = httpx.post(self.url + "/api/jobs", json=body, timeout=120).json()
        first = None
        while True:
            view = httpx.get(self.url + f"/api/jobs/{job['id']}", timeout=60).json()
            if first is None and any(f["status"] == "done" for f in view["frames"]):
                first = time.perf_counter() - t0
            if view["status"] in ("done", "failed", "canceled"):
                break
            time.sleep(0.25)  # a light poll: the farm shares the machine
        wall = time.perf_counter() - t0
        render = sum((f["figures"] or {}).get("seconds", 0.0) for f in view["frames"])
        return {"status": view["status"], "wall_s": wall, "first_frame_s": first or wall, "render_s": render}


def bench_farm(out_dir: Path = Path("docs/bench"), smoke: bool = False, progress: Callable[[str], None] = lambda m: None) -> dict:
    frames, size = (3, 192) if smoke else (36, 512)
    tiles = (32, 64, 128, size)
    rows = []
    with tempfile.TemporaryDirectory(prefix="argand-bench-farm-") as tmp:
        for workers in (1, 2):
            progress(f"starting a farm with {workers} worker(s)")
            with LocalFarm(Path(tmp) / f"w{workers}", workers) as farm:
                for tile in tiles:
                    progress(f"{workers} worker(s), tile {tile}: {frames} frames of {size}x{size}")
                    body = {"scene": "bicube", "deltas": {"start": 0, "stop": "pi/9", "count": frames},
                            "width": size, "height": size, "tile": tile}
                    r = farm.run_job(body)
                    r.update(workers=workers, tile=tile if tile != size else "frame", frames=frames, size=size,
                             fps=frames / r["wall_s"],
                             overhead_share=max(0.0, (r["wall_s"] * workers - r["render_s"]) / max(r["render_s"], 1e-9)))
                    rows.append(r)
    by = {(r["workers"], r["tile"]): r for r in rows}
    report = {
        "benchmark": "farm",
        "machine": machine_info(),
        "scene": "bicube",
        "frames": frames,
        "size": size,
        "runs": rows,
        "scaling_2_vs_1": {str(t): by[(1, t)]["wall_s"] / by[(2, t)]["wall_s"] for t in (32, 64, 128, "frame")},
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "farm.json").write_text(json.dumps(report, indent=2) + "\n")
    chart(report, out_dir / "farm.png")
    return report


def chart(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = ["32", "64", "128", "frame"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for workers, color in ((1, "C1"), (2, "C0")):
        runs = {str(r["tile"]): r for r in report["runs"] if r["workers"] == workers}
        xs = range(len(labels))
        offset = -0.2 if workers == 1 else 0.2
        a.bar([x + offset for x in xs], [runs[l]["fps"] for l in labels], width=0.4, color=color, label=f"{workers} worker(s)")
        b.bar([x + offset for x in xs], [100 * runs[l]["overhead_share"] for l in labels], width=0.4, color=color,
              label=f"{workers} worker(s)")
    for ax, title, ylabel in ((a, "throughput", "frames per second"), (b, "dispatch + assembly overhead", "% of render time")):
        ax.set_xticks(range(len(labels)), labels)
        ax.set_xlabel("tile size (pixels)")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.legend()
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"argand bench farm — {report['frames']} frames of {report['size']}x{report['size']} (Bicube)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
