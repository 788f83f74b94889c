"""The `argand` command line."""

from __future__ import annotations

import importlib
import math
import os
from pathlib import Path
from typing import Any, Callable, List, Optional

import typer

from argand.frames.defaults import DEFAULT_HEIGHT, DEFAULT_WIDTH

# Loading the CLI imports typer and nothing heavy: rich, numpy, the scene
# model (pydantic), OpenImageIO and the farm come when a command uses them
# (tests/test_startup.py keeps it so): `argand render` of one 512² frame
# is a process of about a third of a second of CPU, most of it imports
# (cli_process_cpu_s, docs/benchmarks.md). The names below stand for
# rich's and argand's until then.


class _Later:
    """A module, imported at its first attribute read; a rich Console
    (``console``: its options), made then."""

    def __init__(self, module: str, console: dict | None = None) -> None:
        self._module, self._console, self._made = module, console, None

    def made(self) -> Any:
        if self._made is None:
            made = importlib.import_module(self._module)
            self._made = made if self._console is None else made.Console(**self._console)
        return self._made

    def __getattr__(self, name: str) -> Any:
        return getattr(self.made(), name)


def _later(module: str, name: str) -> Callable[..., Any]:
    """``module.name`` (a function or a class), imported at its first call;
    a _Later given to it (``console=err``) is passed as what it stands for."""

    def call(*args: Any, **kwargs: Any) -> Any:
        args = tuple(a.made() if isinstance(a, _Later) else a for a in args)
        kwargs = {k: v.made() if isinstance(v, _Later) else v for k, v in kwargs.items()}
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    return call


def _plain_values_without_pydantic() -> None:
    """Typer (0.2x) turns each parameter's value into its type through a
    pydantic TypeAdapter built per parameter the first time a command runs:
    importing pydantic and building about twenty adapters is ~0.1 s of CPU
    for `argand render` of one frame, whose values are plain str, int,
    float, bool and Path. Here a value typer's adapter would only pass through
    (a str for a str, an int for an int within min/max, a finite float for a
    float, a Path, a plain decimal number for an int or float) is taken as the adapter
    would give it; anything else goes through typer's own adapter, so errors
    and unusual inputs read exactly as typer makes them
    (tests/test_startup.py compares the two). Left as typer has it when its
    internals are not the ones this was written against."""
    try:
        from pathlib import Path as PathType

        from typer import core as typer_core
        from typer._coercion import RuntimeParam, build_runtime_param
        from typer._param_types import coerce_cli_path
    except ImportError:  # another typer: its own coercion
        return
    import re  # (loaded by typer already)

    # int: digits without a leading zero; float: those, with decimals too
    plain_number = re.compile(r"(0|[1-9][0-9]{0,17})(\.[0-9]{1,17})?")
    parameter = getattr(typer_core, "_TyperParameter", None)
    original = getattr(parameter, "get_runtime_param", None)
    if original is None or getattr(original, "argand_plain", False):
        return

    class PlainParam(RuntimeParam):
        def _coerce_value(self, value: Any, param: Any, ctx: Any) -> Any:
            kind, info = self.annotation, self.parameter_info
            if kind is str and type(value) is str:
                return value
            if kind in (int, float) and type(value) is str and value.isascii() and plain_number.fullmatch(value) and (
                    kind is float or "." not in value):
                value = kind(value)
            if (kind is int and type(value) is int) or (kind is float and type(value) is float and math.isfinite(value)):
                if (info.min is None or value >= info.min) and (info.max is None or value <= info.max):
                    return value
            if kind is PathType and type(value) is str and value:
                value = PathType(value)
            if kind is PathType and isinstance(value, PathType):
                return coerce_cli_path(value, info, path_type=PathType, param=param, ctx=ctx)
            return build_runtime_param(param.type_descriptor)._coerce_value(value, param=param, ctx=ctx)

    def get_runtime_param(self: Any) -> Any:
        d = self.type_descriptor
        info = d.parameter_info
        if (self._runtime_param is None and d.annotation in (str, int, float, bool, PathType) and d.file_annotation is None
                and info.parser is None and not info.clamp and info.path_type is None and not self.multiple
                and self.nargs == 1):
            self._runtime_param = PlainParam(parameter_info=info, annotation=d.annotation)
        return original(self)

    get_runtime_param.argand_plain = True  # type: ignore[attr-defined]
    parameter.get_runtime_param = get_runtime_param


_plain_values_without_pydantic()

box = _Later("rich.box")
escape = _later("rich.markup", "escape")
Table = _later("rich.table", "Table")
Progress = _later("rich.progress", "Progress")
BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn = (
    _later("rich.progress", n) for n in ("BarColumn", "MofNCompleteColumn", "TextColumn", "TimeElapsedColumn",
                                         "TimeRemainingColumn"))
angle_text = _later("argand.frames.frame_set", "angle_text")

# Plain help (click's layout): an option that takes a value shows what it
# takes (WxH, ANGLE, DIR), a flag shows nothing, and no option its Python type.
app = typer.Typer(
    help="Argand: verified complex roots and renders of algebraic surfaces in complex space.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
)
bench_app = typer.Typer(help="Benchmarks against the alternatives; JSON and charts under docs/bench/.", no_args_is_help=True,
                        rich_markup_mode=None)
app.add_typer(bench_app, name="bench")

console = _Later("rich.console", console={})
err = _Later("rich.console", console={"stderr": True})


#: A render's progress bar appears once it has run this long (seconds;
#: ARGAND_PROGRESS_AFTER sets it): a bar for work that is over in a blink
#: only flickers, and rich's import alone is about 0.05 s of CPU, a seventh
#: of `argand render` of one 512² frame (cli_process_cpu_s, docs/benchmarks.md).
PROGRESS_AFTER_S = 0.5


def progress_after() -> float:
    """ARGAND_PROGRESS_AFTER in seconds (PROGRESS_AFTER_S when unset; "inf":
    never); anything else that is not a number >= 0 stops the command with
    an error that says so."""
    import math

    text = os.environ.get("ARGAND_PROGRESS_AFTER")
    if text is None or not text.strip():
        return PROGRESS_AFTER_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value >= 0:  # (NaN too)
        fail(f"ARGAND_PROGRESS_AFTER must be a number of seconds >= 0 (or inf: never), got {text!r}")
    return value


class _LaterProgress:
    """A rich Progress of one task that is made only once the work has
    taken longer than ``after`` seconds (its elapsed time counted from the
    start): ``update`` and ``advance`` as Progress's, on that task. Shown
    on stderr, closed with the block."""

    def __init__(self, description: str, total: int, unit: str, after: float | None = None) -> None:
        import time

        if after is None:
            after = progress_after()
        self._clock = time.monotonic
        self._start = self._clock()
        self._after, self._unit = after, unit
        self._state = {"description": description, "total": total, "completed": 0}
        self._bar: Any = None
        self._task: Any = None

    def __enter__(self) -> "_LaterProgress":
        self._show()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)

    def _show(self) -> None:
        if self._bar is not None or self._clock() - self._start < self._after:
            return
        bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                       TextColumn(self._unit), TimeElapsedColumn(), TimeRemainingColumn(), console=err)
        bar.__enter__()
        # (its clock starts now: the elapsed time shown is the bar's)
        self._task = bar.add_task(**self._state)
        self._bar = bar

    def update(self, description: str) -> None:
        self._state["description"] = description
        if self._bar is None:
            self._show()  # (made with the state: this description)
        else:
            self._bar.update(self._task, description=description)

    def advance(self, n: int = 1) -> None:
        self._state["completed"] += n
        if self._bar is None:
            self._show()
        elif n:
            self._bar.advance(self._task, n)


def fail(message: str, code: int = 2) -> None:
    err.print(f"[bold red]error:[/] {escape(message)}", soft_wrap=True)
    raise typer.Exit(code)


def _one_blas_thread() -> None:
    """Before numpy is imported: OpenBLAS on one thread, unless the
    environment says otherwise. numpy's OpenBLAS starts a thread per core
    when it is loaded, each spinning about 0.1 s for work that roots, render
    and presets never give it (their matrices are at most 3x3): 0.07 s of
    CPU per extra core, for a command of about 0.5 s (docs/benchmarks.md).
    Called when this module is imported, since an option's callback (--tile's)
    may import numpy before a command's body runs."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


_one_blas_thread()


# ---------------------------------------------------------------------------
# argand roots
# ---------------------------------------------------------------------------


@app.command(context_settings={"ignore_unknown_options": True, "allow_interspersed_args": True})
def roots(
    coefficients: List[str] = typer.Argument(..., metavar="P0 P1 ... PN", help="p_0 p_1 ... p_n, lowest degree first (negative numbers are fine)."),
    method: str = typer.Option("auto", "--method", "-m", metavar="METHOD", help="auto | smith | paper | unverified"),
) -> None:
    """All complex roots of p(t) = p_0 + p_1 t + ... + p_n t^n, with proven enclosures."""
    _one_blas_thread()
    from argand.core import METHODS, find_roots

    if method not in METHODS:
        fail(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    values = []
    for i, text in enumerate(coefficients):
        try:
            v = float(text)
        except ValueError:
            fail(f"coefficient {i} ({text!r}) is not a number")
        if not math.isfinite(v):
            fail(f"coefficient {i} ({text!r}) must be finite")
        values.append(v)
    try:
        r = find_roots(values, method=method)
    except ValueError as exc:
        fail(str(exc))
    table = Table(title=f"roots of a degree-{len(values) - 1} polynomial ({method})", title_justify="left")
    table.add_column("center", no_wrap=True)
    for col in ("radius", "count", "verified", "real"):
        table.add_column(col, justify="right" if col in ("radius", "count") else "left")
    for i in range(len(r)):
        z = complex(r.center[i])
        table.add_row(
            f"{z.real:.16g} {'+' if z.imag >= 0 else '-'} {abs(z.imag):.16g}i",
            f"{float(r.radius[i]):.3g}",
            str(int(r.count[i])),
            "[green]yes[/]" if r.verified[i] else "[yellow]no[/]",
            "yes" if r.real[i] else "",
        )
    console.print(table)
    levels = {0: "double", 1: "double-double", 2: "exact (python-flint)"}
    if len(r) == 0:
        verified_text = "no finite roots"
    elif r.all_verified:
        verified_text = "all verified"
    else:
        verified_text = f"{int(r.verified.sum())}/{len(r)} verified (unverified discs are estimates, not proofs)"
    console.print(
        f"degree {len(values) - 1}; roots at infinity {r.n_infinite}; "
        f"{verified_text}; "
        f"precision used: {levels.get(r.escalation, r.escalation)}"
    )


# ---------------------------------------------------------------------------
# argand render
# ---------------------------------------------------------------------------


def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        fail(f"--size must look like 512x512, got {text!r}")
    if not (1 <= w <= 8192 and 1 <= h <= 8192):
        fail(f"--size must be between 1x1 and 8192x8192, got {text!r}")
    return w, h


def _tile_option(value: int) -> int:
    """--tile, checked as the renderer checks it (argand.render.frames.check_tile)."""
    from argand.render.frames import check_tile

    try:
        return check_tile(value)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None


#: A frame's size when none is given (the farm's default too).
DEFAULT_SIZE = f"{DEFAULT_WIDTH}x{DEFAULT_HEIGHT}"

#: The EXR compressions (argand.media.frame_files.exr_compressions, which checks them).
EXR_COMPRESSION_HELP = "none, rle, zip, zips, piz, zstd (OpenEXR 3.5+ readers only); zip:N, zstd:N for a level."


@app.command()
def render(
    scene: str = typer.Argument(..., metavar="SCENE", help="A preset name (argand presets) or a scene file (.yaml/.json)."),
    sigma: Optional[str] = typer.Option(None, "--sigma", metavar="ANGLE", help="σ, the start of the argument band, one value (default 0; e.g. pi/36)."),
    sigmas: Optional[str] = typer.Option(None, "--sigmas", metavar="START:STOP:COUNT", help="A sweep of σ START:STOP:COUNT (e.g. 0:pi/2:12); "
                                         "with --deltas, a grid σ x δ."),
    delta: Optional[str] = typer.Option(None, "--delta", metavar="ANGLE", help="δ, the width of the band, one value (default 0; e.g. pi/9)."),
    deltas: Optional[str] = typer.Option(None, "--deltas", metavar="START:STOP:COUNT", help="A sweep of δ START:STOP:COUNT (e.g. 0:pi/9:24)."),
    atlas: Optional[int] = typer.Option(None, "--atlas", metavar="N", min=1, help="N: the whole space σ ≥ 0, σ + δ ≤ π "
                                        "on a triangular grid of N rows and columns (N(N+1)/2 frames), step π/N."),
    atlas_layout: str = typer.Option("uniform", "--atlas-layout", metavar="LAYOUT", help="uniform: cut [0, π] every "
                                     "π/N; roots: cut it where the scene's roots are (frames where the picture changes)."),
    size: str = typer.Option(DEFAULT_SIZE, "--size", metavar="WxH", help="WxH in pixels (the farm's default too)."),
    out: Path = typer.Option(Path("render"), "--out", metavar="DIR", help="Output folder: one run's files; "
                             "refused if it holds another run's (see --overwrite)."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Remove another run's files from --out first (frames, "
                                   "animations, atlas.png; nothing else)."),
    workers: int = typer.Option(0, "--workers", metavar="N", help="Threads (0: all cores)."),
    tile: int = typer.Option(64, "--tile", metavar="PIXELS", callback=_tile_option,
                             help="Tile size in pixels, a multiple of 8 (the frame's bits do not depend on it)."),
    method: str = typer.Option("auto", "--method", metavar="METHOD", help="Root method: auto | smith | paper | unverified."),
    hue: bool = typer.Option(False, "--hue", help="Colour complex roots by their argument."),
    samples: Optional[int] = typer.Option(
        None, "--samples", metavar="N", help="Samples per pixel, a square (1, 4, 9, ..., 64; default: the scene's, else 1): the "
        "colour is their mean, the status the worst of theirs (the certified_share AOV counts them)."),
    fps: float = typer.Option(8.0, "--fps", metavar="FPS", help="Frames per second of the animation."),
    root_field: Optional[Path] = typer.Option(
        None, "--root-field", metavar="FILE", help="Also write the run's root field (every sample's proven primary "
        "roots, per tile; argand.render.field) to FILE, for other tools and for deciding other bands."),
    exr_compression: str = typer.Option("zip", "--exr-compression", metavar="NAME[:LEVEL]",
                                        help=EXR_COMPRESSION_HELP),
    explain: Optional[str] = typer.Option(
        None, "--explain", metavar="X,Y[,SAMPLE]", help="X,Y (or X,Y,SAMPLE with --samples): print that pixel's (sample's) ray, ray "
        "polynomial with coefficient radii, discs, decisions, the exact tier's steps and status (first frame only), "
        "and render nothing."),
    exact_per_block: Optional[int] = typer.Option(
        None, "--exact-per-block", metavar="N", help="The exact tier: at most N rays of each 8x8 block of samples decided on the "
        "exact rational ray polynomial when the double-double tier leaves them unproven (0: off; default: the "
        "renderer's, argand.render.frames.EXACT_PIXELS_PER_BLOCK, 8)."),
    exact_bits: Optional[int] = typer.Option(
        None, "--exact-bits", metavar="BITS", help="The exact tier's highest precision in bits (default: EXACT_DEFAULT_BITS)."),
) -> None:
    """Render frames locally (no server): EXR with AOVs, PNG, JSON figures, animation.gif and .mp4,
    and atlas.png for a grid of (sigma, delta)."""
    _one_blas_thread()
    from argand.frames.defaults import MAX_FRAMES
    from argand.frames.frame_set import FrameSet
    from argand.media.frame_files import check_exr_compression
    from argand.render import FrameParams
    from argand.render.sweep import render_sweep
    from argand.scene import load_scene
    from argand.scene.presets import PRESETS, preset_scene

    try:
        # The API builds a job's frames the same way: the same pairs and the same refusals.
        # (Counted before anything is expanded: an atlas of 10^5 steps is 5e9 frames.)
        grid = FrameSet.from_axes(sigma=sigma, sigmas=sigmas, delta=delta, deltas=deltas, atlas=atlas,
                                  max_frames=MAX_FRAMES)
    except ValueError as exc:
        fail(str(exc))
    if atlas_layout not in ("uniform", "roots"):
        fail(f"--atlas-layout must be uniform or roots, got {atlas_layout!r}")
    if atlas_layout == "roots" and atlas is None:
        fail("--atlas-layout lays out an atlas: give it with --atlas N")
    try:
        check_exr_compression(exr_compression)
    except ValueError as exc:
        fail(f"--exr-compression: {exc}")
    width, height = _parse_size(size)
    try:
        # A preset without the pydantic models (the same typed scene: tests/test_startup.py).
        loaded = preset_scene(scene) if scene in PRESETS else load_scene(scene)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if atlas_layout == "roots":
        from argand.frames.frame_set import root_atlas_cuts
        from argand.render.convert import to_core_scene
        grid = FrameSet.from_axes(atlas=atlas, atlas_cuts=root_atlas_cuts(to_core_scene(loaded), width, height, atlas))
    exact = {}
    if exact_per_block is not None:
        exact["exact_pixels_per_block"] = exact_per_block
    if exact_bits is not None:
        exact["exact_max_bits"] = exact_bits
    try:
        engine = _engine_options()
        params = [FrameParams(sigma=p.sigma, delta=p.delta, width=width, height=height, method=method,
                              hue_by_argument=hue, samples=loaded.samples if samples is None else samples,
                              engine=engine, **exact)
                  for p in grid.points]
    except ValueError as exc:
        fail(f"--samples: {exc}" if "samples" in str(exc) else str(exc))
    if explain is not None:
        _explain(loaded, params[0], explain, tile)
        return
    if root_field is not None and not root_field.parent.is_dir():
        fail(f"--root-field {root_field}: the folder {root_field.parent} does not exist")
    _clear_out(out, overwrite)
    tiles_per_frame = math.ceil(width / tile) * math.ceil(height / tile)
    with _LaterProgress("rendering", tiles_per_frame * len(params), "tiles") as progress:
        try:
            summary = render_sweep(
                loaded, params, out, tile=tile, workers=workers or None, compression=exr_compression, fps=fps,
                on_frame=lambda i, p: progress.update(
                    f"frame {i + 1}/{len(params)} (σ = {angle_text(p.sigma)}, δ = {angle_text(p.delta)})"),
                on_tile=lambda t: progress.advance(), grid=grid, root_field=root_field)
        except ValueError as exc:
            fail(str(exc))
    # (Plain lines: rich's console is not loaded for them.)
    for f in summary:
        typer.echo(
            f"σ = {angle_text(f['sigma'])}, δ = {angle_text(f['delta'])}: {f['seconds'] * 1000:.0f} ms, "
            f"{f['ns_per_pixel']:.0f} ns/pixel, "
            f"certified {100 * f['certified_share']:.3f}%, escalated {100 * f['escalated_share']:.3f}%, "
            f"exact {f['exact_pixels']} (multiple roots proven {f['exact_multiple_roots']}, "
            f"over the work cap {f['exact_over_cap']})"
        )
    extras = (["animation.gif", "animation.mp4"] if len(params) > 1 else []) + (["atlas.png"] if grid.is_grid else [])
    typer.echo(f"wrote {len(params)} frame(s) to {out}/" + (f" and {', '.join(extras)}" if extras else ""))
    if root_field is not None:
        typer.echo(f"wrote the root field to {root_field} ({root_field.stat().st_size / 1e6:.1f} MB)")


#: The files a run writes into its --out folder (argand.render.sweep.render_sweep).
RUN_FILES = ("frame_[0-9][0-9][0-9][0-9].exr", "frame_[0-9][0-9][0-9][0-9].png", "frame_[0-9][0-9][0-9][0-9].json",
             "animation.gif", "animation.mp4", "atlas.png",
             # what a killed run's atomic writes left (argand.media.atomic.temporary_beside)
             "frame_[0-9][0-9][0-9][0-9].*.????????????.tmp.*", "animation.*.????????????.tmp.*",
             "atlas.png.????????????.tmp.png")


def _clear_out(out: Path, overwrite: bool) -> None:
    """A run's folder holds that run only: another run's files in ``out``
    are refused (a new run would mix with them, its frames beside stale
    ones), or removed first with ``overwrite``. Other files are left alone."""
    if out.exists() and not out.is_dir():
        fail(f"--out {out} is a file, not a folder")
    found = sorted({f for pattern in RUN_FILES for f in out.glob(pattern)}) if out.is_dir() else []
    if not found:
        return
    if not overwrite:
        frames = sum(1 for f in found if f.suffix == ".exr")
        others = [f.name for f in found if not f.name.startswith("frame_")]
        held = ", ".join([f"{frames} frame(s)"] * bool(frames) + others)
        fail(f"--out {out}/ holds another run ({held}): a new run would mix its frames with those. "
             f"Give another folder (--out {out}-2), or add --overwrite to remove that run's files first.")
    for f in found:
        f.unlink()


def _explain(scene, params, where: str, tile: int) -> None:
    from argand.render.explain import explain_pixel, format_explanation

    try:
        x, y, *rest = (int(v) for v in where.split(","))
        if len(rest) > 1:
            raise ValueError
    except ValueError:
        fail(f"--explain must look like X,Y (pixel column, row) or X,Y,SAMPLE, got {where!r}")
    sample = rest[0] if rest else 0
    try:
        e = explain_pixel(scene, params, x, y, tile=tile, sample=sample)
    except ValueError as exc:
        fail(str(exc))
    which = f"sample {sample} of {params.samples} of " if params.samples > 1 else ""
    console.print(f"{which}pixel ({x}, {y}) of {params.width}x{params.height}, sigma={params.sigma!r}, "
                  f"delta={params.delta!r}, method {params.method}, tile {tile}")
    for line in format_explanation(e):
        console.print(line, markup=False, highlight=False, soft_wrap=True)


@app.command()
def presets() -> None:
    """List the preset scenes."""
    _one_blas_thread()
    from argand.scene import load_scene
    from argand.scene.presets import PRESETS

    table = Table(title="presets")
    table.add_column("name")
    table.add_column("surfaces")
    for name in PRESETS:
        s = load_scene(name)
        table.add_row(name, "; ".join(o.surface for o in s.objects))
    console.print(table)


# ---------------------------------------------------------------------------
# argand bench
# ---------------------------------------------------------------------------


_BENCH_NAMES = {
    "argand-auto": "auto",
    "argand-smith": "smith",
    "argand-paper": "paper",
    "argand-unverified": "unverified",
    "argand-auto (scalar)": "auto (scalar)",
    "argand-smith (scalar)": "smith (scalar)",
    "argand-unverified (scalar)": "unverified (scalar)",
    "numpy-eigvals": "numpy eigvals",
    "flint-acb_poly.roots": "flint roots()",
    "flint-acb_poly.roots(tol=1e-14)": "flint roots(1e-14)",
    "mpmath-polyroots": "mpmath polyroots",
    "mpsolve": "MPSolve",
}


@bench_app.command("roots")
def bench_roots_cmd(
    count: int = typer.Option(20000, "--count", metavar="N", min=1, help="Polynomials per suite (alternatives run on subsets)."),
    seed: int = typer.Option(1, "--seed", metavar="N", help="Seed of the random polynomials."),
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR", help="Folder for roots.json, roots.md and roots.png."),
    smoke: bool = typer.Option(False, "--smoke", help="A tiny run (seconds) that keeps the benchmark alive in CI."),
) -> None:
    """Verified roots vs numpy, python-flint, mpmath and MPSolve: speed and accuracy on the same polynomials."""
    from argand.bench.roots import bench_roots

    with Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("steps"),
        TimeElapsedColumn(), console=err,
    ) as bar:
        task = bar.add_task("benchmarking roots", total=None)

        def progress(message: str, done: int, total: int) -> None:
            bar.update(task, description=message, completed=done, total=total)

        report = bench_roots(count=count, seed=seed, out_dir=out, smoke=smoke, progress=progress)
    for suite, data in report["suites"].items():
        table = Table(
            title=f"{suite} ({data['results']['argand-auto']['polynomials']} polynomials): ns per polynomial; "
            "accuracy against the exact roots",
            title_justify="left", box=box.SIMPLE_HEAD,
        )
        table.add_column("method", overflow="fold")
        table.add_column("kernel", no_wrap=True)
        for col in ("ns/poly", "÷auto", "rad/|z|", "med err", "max err", "proved"):
            table.add_column(col, justify="right", no_wrap=True)
        auto = data["results"]["argand-auto"]["ns_per_poly"]

        def sci(value) -> str:
            return f"{value:.1e}" if value is not None else ""

        for name, row in data["results"].items():
            table.add_row(
                _BENCH_NAMES.get(name, name),
                row.get("kernel", ""),
                f"{row['ns_per_poly']:.0f}",
                f"{row['ns_per_poly'] / auto:.1f}",
                sci(row.get("median_rel_radius")),
                sci(row.get("median_rel_error")),
                sci(row.get("max_rel_error")),
                f"{100 * row['fully_verified_share']:.1f}%" if "fully_verified_share" in row else "",
            )
        console.print(table)
    console.print("rad/|z|: median radius / |root|; med/max err: relative error of the centers; "
                  "proved: share of polynomials with every root proven; kernel: the batched kernel's "
                  f"instruction set ({report['batch_kernel']} on this CPU) or scalar", soft_wrap=True)
    for line in report["headline"]:
        console.print(f"  {line}", soft_wrap=True)
    mps = report["mpsolve"]
    if not mps["available"]:
        console.print(f"MPSolve: unavailable ({mps['note']})")
    console.print(f"wrote {out / 'roots.json'}, {out / 'roots.md'} and {out / 'roots.png'}")


@bench_app.command("render")
def bench_render_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR"),
    smoke: bool = typer.Option(False, "--smoke", help="Small sizes, for CI."),
    samples_only: bool = typer.Option(False, "--samples-only",
                                      help="Only the cost of antialiasing (1, 4, 16 samples per pixel)."),
    kernels_only: bool = typer.Option(False, "--kernels-only",
                                      help="Only the primary rays' root kernels, scalar against batched (CPU time); "
                                           "also updates render.json / render.md's kernel table."),
) -> None:
    """Every preset at 512x512 and 1024x1024 for delta in {0, pi/18, pi/9} on one core, and antialiasing's cost."""
    from argand.bench.render import bench_kernels_report, bench_render, bench_samples_report

    if kernels_only:
        with console.status("benchmarking the root kernels") as status:
            report = bench_kernels_report(out_dir=out, smoke=smoke, progress=lambda m: status.update(m))
        k = report["kernels"]
        table = Table(title=f"primary rays' root kernel, one core, CPU time (batched: {k['instruction_set']})",
                      title_justify="left")
        for col in ("scene", "size", "delta", "scalar ns/pixel", "batched ns/pixel", "speed-up", "same status"):
            table.add_column(col)
        for row in k["rows"]:
            table.add_row(row["scene"], f"{row['width']}x{row['height']}", f"{row['delta']:.4f}",
                          f"{row['scalar_ns_per_pixel']:.0f}", f"{row['batched_ns_per_pixel']:.0f}",
                          f"{row['speedup']:.2f}", "yes" if row["same_status"] and row["same_hit"] else "NO")
        console.print(table)
        console.print(f"wrote {out / 'render_kernels.json'}, {out / 'render_kernels.md'}")
        return
    with console.status("benchmarking render") as status:
        if samples_only:
            report = bench_samples_report(out_dir=out, smoke=smoke, progress=lambda m: status.update(m))
        else:
            report = bench_render(out_dir=out, smoke=smoke, progress=lambda m: status.update(m))
    table = Table(title="render, one core", title_justify="left")
    for col in ("scene", "size", "delta", "ms/frame", "ns/pixel", "certified", "unverified ms", "ratio"):
        table.add_column(col)
    for row in report.get("frames", []):
        table.add_row(
            row["scene"], f"{row['width']}x{row['height']}", f"{row['delta']:.4f}", f"{row['ms']:.0f}",
            f"{row['ns_per_pixel']:.0f}", f"{100 * row['certified_share']:.3f}%", f"{row['unverified_ms']:.0f}",
            f"{row['ms'] / row['unverified_ms']:.2f}",
        )
    console.print(table)
    table = Table(title="samples per pixel, one core", title_justify="left")
    for col in ("scene", "size", "delta", "samples", "ns/pixel", "ns/sample", "sample cost", "certified pixels"):
        table.add_column(col)
    for row in report["samples"]:
        table.add_row(row["scene"], f"{row['width']}x{row['height']}", f"{row['delta']:.4f}", str(row["samples"]),
                      f"{row['ns_per_pixel']:.0f}", f"{row['ns_per_sample']:.0f}", f"{row['sample_cost']:.2f}",
                      f"{100 * row['certified_share']:.3f}%")
    console.print(table)
    console.print(f"wrote {out / ('render_samples.json' if samples_only else 'render.json')}")


@bench_app.command("farm")
def bench_farm_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR"),
    smoke: bool = typer.Option(False, "--smoke", help="3 frames of 192x192, for CI."),
    exr_compression: str = typer.Option(None, "--exr-compression", metavar="NAME[:LEVEL]",
                                        help=f"The farms' EXR compression: {EXR_COMPRESSION_HELP} Default: the farm's."),
    repeat: int = typer.Option(None, "--repeat", metavar="N", help="Runs of each configuration (the median is kept); default 3, smoke 1."),
) -> None:
    """One job of 36 frames at 512x512 on 1 and 2 workers, tile sizes 32/64/128/frame."""
    from argand.bench.farm import bench_farm

    if repeat is not None and repeat < 1:
        fail(f"--repeat must be at least 1, got {repeat}")
    from argand.media.frame_files import check_exr_compression

    if exr_compression is not None:
        try:
            check_exr_compression(exr_compression)
        except ValueError as exc:
            fail(f"--exr-compression: {exc}")
    with console.status("benchmarking the farm") as status:
        report = bench_farm(out_dir=out, smoke=smoke, progress=lambda m: status.update(m), exr_compression=exr_compression,
                            repeat=repeat)
    table = Table(title=f"farm: {report['frames']} frames of {report['size']}x{report['size']}", title_justify="left")
    for col in ("workers", "tile", "seconds", "frames/s", "first frame s", "encoding", "dispatch", "overhead", "vs render"):
        table.add_column(col, justify="right")
    for r in report["runs"]:
        table.add_row(str(r["workers"]), str(r["tile"]), f"{r['wall_s']:.2f}", f"{r['fps']:.2f}",
                      f"{r['first_frame_s']:.2f}", f"{100 * r['encode_share']:.1f}%",
                      f"{100 * r['dispatch_share']:.1f}%", f"{100 * r['overhead_share']:.1f}%",
                      f"{100 * (r['vs_local'] - 1):+.1f}%")
    console.print(table)
    console.print("scaling 2 workers / 1 worker: " + ", ".join(f"tile {k}: {v:.2f}x" for k, v in report["scaling_2_vs_1"].items()))
    console.print("argand render of the same frames: " + ", ".join(
        f"{r['threads']} thread(s) {r['wall_s']:.2f} s" for r in report["local"]))
    console.print("shares are of the render time; encoding: the frames' files, as a local render writes them; "
                  "dispatch: what the farm adds; vs render: a farm's time over argand render on as many threads")
    console.print(f"wrote {out / 'farm.json'}, {out / 'farm.md'} and {out / 'farm.png'}")


@bench_app.command("load")
def bench_load_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR", help="Folder for load.json, load.md and load.png."),
    url: Optional[str] = typer.Option(None, "--url", metavar="URL", help="An existing farm (default: start argand serve --workers 2 "
                                      "on a free loopback port with its own data folder)."),
    smoke: bool = typer.Option(False, "--smoke", help="Seconds, not minutes: keeps the harness alive in CI."),
    users: Optional[str] = typer.Option(None, "--users", metavar="N,N,...", help="The ramp's steps, e.g. 1,5,10,20,40,60."),
    step_s: Optional[float] = typer.Option(None, "--step-s", metavar="SECONDS", help="Seconds per ramp step (default 20, smoke 4)."),
    steady_s: Optional[float] = typer.Option(None, "--steady-s", metavar="SECONDS", help="Seconds of the steady phase (default 90, smoke 6)."),
    steady_users: Optional[int] = typer.Option(None, "--steady-users", metavar="N", help="Users in the steady phase "
                                               "(default: the sustainable level the ramp found)."),
    profile: bool = typer.Option(False, "--profile", help="Sample the API with py-spy during the steady phase."),
    probes: Optional[bool] = typer.Option(None, "--probes/--no-probes", help="After the drain, time the list and "
                                          "status requests under conditions that isolate the causes (default: on, "
                                          "off with --smoke)."),
    seed: int = typer.Option(1, "--seed", metavar="N", help="Seed of the users' choices."),
) -> None:
    """Simulated users (Locust) against a two-worker farm: ramp, steady, drain; latency per endpoint, lost jobs, throughput."""
    from argand.bench.load import bench_load

    ramp = None
    if users is not None:
        try:
            ramp = tuple(int(u) for u in users.split(","))
        except ValueError:
            fail(f"--users must be user counts separated by commas (e.g. 1,5,10), got {users!r}")
        if not ramp or min(ramp) < 1:
            fail(f"--users: every step needs at least 1 user, got {users!r}")
    for name, value in (("--step-s", step_s), ("--steady-s", steady_s)):
        if value is not None and value <= 2:
            fail(f"{name} must be above 2 seconds (a step's first 2 s are left out), got {value}")
    if steady_users is not None and steady_users < 1:
        fail(f"--steady-users must be at least 1, got {steady_users}")
    with console.status("load test") as status:
        report = bench_load(out_dir=out, url=url, smoke=smoke, ramp_users=ramp, step_s=step_s, steady_s=steady_s,
                            steady_users=steady_users, seed=seed, profile=profile, probes=probes,
                            progress=lambda m: status.update(m))
    from argand.bench.load_report import markdown

    console.print(markdown(report), soft_wrap=True, markup=False, highlight=False)
    console.print(f"wrote {out / 'load.json'}, {out / 'load.md'} and {out / 'load.png'}")


@bench_app.command("stability")
def bench_stability_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR", help="Folder for stability.json, stability.md and stability.png."),
    smoke: bool = typer.Option(False, "--smoke", help="A small picture, for CI."),
) -> None:
    """The named stability suite: every method (argand's, numpy, python-flint, mpmath, MPSolve) on every case, classed."""
    from argand.bench.stability import bench_stability, markdown

    with console.status("stability suite") as status:
        report = bench_stability(out_dir=out, smoke=smoke, progress=lambda m: status.update(m))
    console.print(markdown(report), soft_wrap=True, markup=False, highlight=False)
    console.print(f"wrote {out / 'stability.json'}, {out / 'stability.md'} and {out / 'stability.png'}")


@bench_app.command("bands")
def bench_bands_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR"),
    smoke: bool = typer.Option(False, "--smoke", help="6 bands of 64x64, for CI."),
) -> None:
    """A job's frames sharing their roots: a sweep's bands rendered together against one by one, argand render's
    sweep and atlas against one frame, the band route's latency."""
    from argand.bench.bands import bench_bands

    with console.status("benchmarking bands") as status:
        report = bench_bands(out_dir=out, smoke=smoke, progress=lambda m: status.update(m))
    for r in report["render"]:
        console.print(f"{r['scene']} {r['size']}x{r['size']}, {r['frames']} bands: together {r['together_cpu_s']:.3f} s, "
                      f"one by one {r['alone_cpu_s']:.3f} s ({r['speedup']:.2f}x), same bits: {r['bit_identical']}")
    cli = report["cli"]
    console.print(f"argand render: sweep of {cli['frames']} {cli['sweep_over_one']:.1f}x one frame, "
                  f"atlas of {cli['atlas_frames']} {cli['atlas_over_one']:.1f}x one frame (whole process)")
    for r in report["band_route"]:
        console.print(f"band route {r['scene']} {r['size']}x{r['size']} from the root field: p50 "
                      f"{1000 * r['p50_s']:.0f} ms, p95 {1000 * r['p95_s']:.0f} ms (solved: p50 "
                      f"{1000 * r['solved_p50_s']:.0f} ms, {r['p50_speedup']:.2f}x; same bits: {r['bit_identical']})")
    farm = report["farm"]
    console.print(f"farm: {farm['frames']}-frame job {farm['files_on_request']['over_one']:.1f}x a 1-frame job "
                  f"(pictures by the assembler: {farm['exr_on_request']['over_one']:.1f}x; every file by the "
                  f"assembler: {farm['exr_written']['over_one']:.1f}x)")
    console.print(f"wrote {out / 'bands.json'}, {out / 'bands.md'} and {out / 'bands.png'}")


@bench_app.command("peers")
def bench_peers_cmd(
    out: Path = typer.Option(Path("docs/bench"), "--out", metavar="DIR", help="Folder for peers.json, peers.md, "
                             "peers.png and peers_side.png."),
    smoke: bool = typer.Option(False, "--smoke", help="2 surfaces at 96x96 and 2 centre-row views at 95x95, 1 run."),
    runs: Optional[int] = typer.Option(None, "--runs", min=1, help="Interleaved rounds per timing (default 3, smoke 1)."),
) -> None:
    """surf and POV-Ray against Argand on the same rays (real surface, one core): CPU time and wrong pixels by the
    exact truth."""
    from argand.bench.peers import PEER_LABELS, PEERS, bench_peers

    with console.status("benchmarking peers") as status:
        report = bench_peers(out_dir=out, smoke=smoke, runs=runs, progress=lambda m: status.update(m))
    for name in ("surf", "povray"):
        if not report["available"][name]:
            console.print(f"{name}: unavailable (binary not found)")
    for key, entry in report["totals"].items():
        console.print(f"{key}: Argand {entry['argand']['cpu_s']:.2f} s, {entry['argand']['wrong']} wrong; "
                      + "; ".join(f"{PEER_LABELS[p]} {entry[p]['cpu_s']:.2f} s ({entry[p]['over_argand']:.2f}x), "
                                  f"{entry[p]['wrong']} wrong" for p in PEERS if p in entry))
    console.print(f"wrote {out / 'peers.json'}, {out / 'peers.md'}, {out / 'peers.png'} and {out / 'peers_side.png'}")


@bench_app.command("all")
def bench_all_cmd(
    out: Path = typer.Option(None, "--out", metavar="DIR", help="Folder for every section's files (default docs/bench, "
                             "smoke build/bench-smoke)."),
    page: Path = typer.Option(None, "--page", metavar="FILE", help="The report (default docs/benchmarks.md, smoke "
                              "build/bench-smoke/benchmarks.md)."),
    smoke: bool = typer.Option(False, "--smoke", help="Every section at its smoke size (minutes): keeps them alive in CI."),
    reuse: Optional[str] = typer.Option(None, "--reuse", metavar="SECTIONS", help="Sections taken from their last JSON instead of run "
                                        "again, e.g. farm,render (of: roots, stability, render, farm, load)."),
) -> None:
    """Every benchmark, then docs/benchmarks.md: machine and versions, roots, stability, render, farm, load."""
    from argand.bench.report import SECTIONS, bench_all

    default_out = Path("build/bench-smoke") if smoke else Path("docs/bench")
    out = out or default_out
    page = page or (out / "benchmarks.md" if smoke else Path("docs/benchmarks.md"))
    chosen = tuple(s.strip() for s in reuse.split(",") if s.strip()) if reuse else ()
    bad = [s for s in chosen if s not in SECTIONS]
    if bad:
        fail(f"--reuse: unknown section(s) {', '.join(bad)}; sections: {', '.join(SECTIONS)}")
    with console.status("benchmarks") as status:
        try:
            bench_all(out_dir=out, page=page, smoke=smoke, reuse=chosen, progress=lambda m: status.update(m))
        except FileNotFoundError as exc:
            fail(str(exc))
    console.print(f"wrote {page} (sections' files in {out}/)")


# ---------------------------------------------------------------------------
# The farm
# ---------------------------------------------------------------------------


def _farm_settings(data: Optional[Path], host: Optional[str], port: Optional[int], forwarded: Optional[str] = None):
    from argand.farm.settings import Settings

    overrides = {"engine": _engine_options()}
    if data is not None:
        overrides["data_dir"] = data
    if host is not None:
        overrides["host"] = host
    if port is not None:
        overrides["port"] = port
    if forwarded is not None:
        overrides["forwarded_allow_ips"] = forwarded
    from pydantic import ValidationError

    try:
        return Settings(**overrides)
    except ValidationError as exc:  # a setting from the environment or an option, named, with what is allowed
        fail("; ".join(f"ARGAND_{'_'.join(map(str, e['loc'])).upper()}: {e['msg'].removeprefix('Value error, ')}"
                       for e in exc.errors()))


def _engine_options():
    """The engine's modes from ARGAND_KERNEL, ARGAND_CULL, ARGAND_REAL, ARGAND_DECIDE and
    ARGAND_SHADE (argand.render.options), refused here, before any work, if wrong."""
    from argand.render.options import engine_options_from_environment

    try:
        return engine_options_from_environment()
    except ValueError as exc:
        fail(str(exc))


FORWARDED_HELP = ("Reverse proxies whose X-Forwarded-For is believed (addresses or networks, comma separated, "
                  "or *; ARGAND_FORWARDED_ALLOW_IPS). Default: none, a client is the address that connected.")


@app.command()
def serve(
    workers: int = typer.Option(2, "--workers", metavar="N", min=0, help="Celery worker processes to start."),
    host: Optional[str] = typer.Option(None, "--host", metavar="HOST", help="Default 127.0.0.1 (ARGAND_HOST)."),
    port: Optional[int] = typer.Option(None, "--port", metavar="PORT", help="Default 8000 (ARGAND_PORT)."),
    data: Optional[Path] = typer.Option(None, "--data", metavar="DIR", help="Data folder (default ./argand-data, ARGAND_DATA_DIR)."),
    forwarded_allow_ips: Optional[str] = typer.Option(None, "--forwarded-allow-ips", metavar="ADDRESSES", help=FORWARDED_HELP),
) -> None:
    """The render farm: Redis (embedded unless ARGAND_REDIS_URL), the API and N workers. Ctrl-C or SIGTERM stops it."""
    from argand.serve.ports import PortTaken
    from argand.serve.supervisor import FarmLocked
    from argand.serve.supervisor import serve as run

    settings = _farm_settings(data, host, port, forwarded_allow_ips)
    _refuse_exposure(settings)
    try:
        # A line each, as written (a URL or an error is never wrapped or read as markup).
        run(settings, workers, announce=lambda m: console.print(m, markup=False, highlight=False, soft_wrap=True))
    except (FarmLocked, PortTaken) as exc:
        fail(str(exc))


def _refuse_exposure(settings) -> None:
    try:
        settings.token()  # a token file that is unreadable or blank stops the start, on loopback too
        problem = settings.exposure_problem()
    except ValueError as exc:
        fail(str(exc))
    if problem:
        fail(problem)


@app.command()
def worker(
    name: Optional[str] = typer.Option(None, "--name", metavar="NAME", help="Worker name (default worker-PID@host); each process adds a boot id "
                                       "of its own (w1@host runs as w1+1a2b3c4d@host)."),
    data: Optional[Path] = typer.Option(None, "--data", metavar="DIR", help="Data folder shared with the API (ARGAND_DATA_DIR)."),
) -> None:
    """One worker that joins an existing Redis + database + store (ARGAND_REDIS_URL, ARGAND_DATABASE_URL)."""
    import os

    from argand.worker.app import run_worker

    settings = _farm_settings(data, None, None)
    if settings.redis_url is None:
        fail("set ARGAND_REDIS_URL to the farm's Redis (a worker does not start its own broker)")
    run_worker(settings, name or f"worker-{os.getpid()}@{os.uname().nodename}")


@app.command()
def api(
    host: Optional[str] = typer.Option(None, "--host", metavar="HOST", help="Address to listen on: default 127.0.0.1 "
                                       "(ARGAND_HOST); another needs a token (see docs/farm.md)."),
    port: Optional[int] = typer.Option(None, "--port", metavar="PORT", help="Port to listen on: default 8000 (ARGAND_PORT)."),
    data: Optional[Path] = typer.Option(None, "--data", metavar="DIR", help="Data folder with the database and frame "
                                        "store (default ./argand-data, ARGAND_DATA_DIR); shared with the workers."),
    forwarded_allow_ips: Optional[str] = typer.Option(None, "--forwarded-allow-ips", metavar="ADDRESSES", help=FORWARDED_HELP),
) -> None:
    """The API alone (ARGAND_REDIS_URL and ARGAND_DATABASE_URL point at the farm); upgrades the database's schema first."""
    import uvicorn

    from argand.api.app import create_app, uvicorn_options
    from argand.farm.database import upgrade

    settings = _farm_settings(data, host, port, forwarded_allow_ips)
    if settings.redis_url is None:
        fail("set ARGAND_REDIS_URL to the farm's Redis (argand api does not start its own broker; argand serve does)")
    _refuse_exposure(settings)
    from argand.serve.ports import PortTaken, listen_on

    try:
        listening = listen_on(settings.host, settings.port)
    except PortTaken as exc:
        fail(str(exc).replace("argand serve --port", "argand api --port"))
    upgrade(settings.sqlalchemy_url)
    console.print(f"Argand API on http://{settings.host}:{settings.port}/", markup=False, highlight=False, soft_wrap=True)
    uvicorn.Server(uvicorn.Config(create_app(settings), **uvicorn_options(settings))).run(sockets=[listening])


def main() -> None:  # pragma: no cover
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
