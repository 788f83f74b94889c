"""The Python side of the C++ core under AddressSanitizer and UBSan.

Run by ``make test-sanitize`` (not by pytest): the _core module built with
-fsanitize=address,undefined in build/sanitize is loaded in place of the
installed one, with libasan preloaded, and this script makes the calls the
farm makes (find_roots in every method, find_roots_batch, plan_frame and
render_tile of a preset and of a scene of 20 objects) and checks their answers
against tests/helpers/truth.py. Any sanitizer report aborts the process (exit != 0).

    LD_PRELOAD=$(g++ -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 \
        .venv/bin/python tests/sanitizer_smoke.py build/sanitize/core/_core.*.so
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root, for tests.helpers


def load_sanitized_core(path: str) -> None:
    """Registers the sanitized build as argand.core._core before argand.core
    imports it, so every call below goes through the instrumented code."""
    spec = importlib.util.spec_from_file_location("argand.core._core", path)
    assert spec is not None and spec.loader is not None, path
    module = importlib.util.module_from_spec(spec)
    sys.modules["argand.core._core"] = module
    spec.loader.exec_module(module)


def main(path: str) -> int:
    load_sanitized_core(path)
    import numpy as np

    from argand.core import _core, find_roots, find_roots_batch
    from argand.render import FrameParams, TileRect, render_tile
    from argand.scene import load_scene, scene_from_dict
    from tests.helpers.truth import check_roots

    assert Path(_core.__file__).resolve() == Path(path).resolve(), (_core.__file__, path)

    polynomials = [
        [-1.0, 1.0],
        [1.0, 0.0, 1.0],
        [-1.0, 3.0, -3.0, 1.0],  # (t - 1)^3
        [float(c) for c in np.poly(np.arange(1, 13))[::-1]],  # Wilkinson 12
        [5e-324, 0.0, 1.0],
        [1.0, 0.0, 5e-324],
        [1e308, -1e308, 1e308],
        [0.0, 0.0, 1.0, 1.0],
        [1.0, 2.0, 0.0, 0.0],
    ]
    problems = []
    for coeffs in polynomials:
        for method in ("auto", "smith", "paper", "unverified"):
            roots = find_roots(coeffs, method=method)
            if method != "unverified":
                problems += [f"{coeffs} {method}: {p}" for p in check_roots(coeffs, roots)]
    for bad in ([], [float("nan"), 1.0], [0.0, 0.0], [1.0] * 70):
        try:
            find_roots(bad)
        except ValueError:
            pass
        else:
            problems.append(f"{bad!r} was not refused")
    rng = np.random.default_rng(12)
    batch = rng.normal(size=(64, 9))
    result = find_roots_batch(batch)
    for r in range(len(batch)):
        problems += [f"batch row {r}: {p}" for p in check_roots(batch[r], result.row(r))]

    params = FrameParams(delta=np.pi / 9, width=24, height=16)
    tile = render_tile(load_scene("whitney"), params, TileRect(0, 0, 24, 16))
    hits = int(np.count_nonzero(tile.rgba[..., 3] > 0))
    if hits == 0:
        problems.append("whitney: the tile has no hit")
    # render_frame's path: tiles of 10 (partial ones at the edges) written
    # straight into the frame's arrays (render_tile_frame), the same pixels.
    from argand.render import render_frame

    frame = render_frame(load_scene("whitney"), params, tile=8, workers=2)
    if not np.array_equal(frame.rgba, tile.rgba) or any(
        not np.array_equal(frame.aovs[k], tile.aovs[k]) for k in tile.aovs
    ):
        problems.append("whitney: render_frame's tiles differ from the one-tile render")
    # Near-double roots (Endrass's 168 nodes): lanes whose Smith discs
    # overlap keep them merged, and the rows a pixel needs are solved again
    # (find_roots_soa's provisional rows, Tracer's settle); rays that miss
    # the clipping sphere skip their roots. The same decisions as the scalar
    # kernel, which takes none of those paths.
    from dataclasses import replace

    from argand.render.options import EngineOptions

    endrass = load_scene("endrass-octic")
    eparams = FrameParams(delta=0.0, width=32, height=32)
    batched = render_frame(endrass, eparams, workers=1)
    scalar = render_frame(endrass, replace(eparams, engine=EngineOptions(kernel="scalar")), workers=1)
    if not (np.array_equal(batched.aovs["status"], scalar.aovs["status"])
            and np.array_equal(batched.rgba[..., 3] > 0, scalar.rgba[..., 3] > 0)):
        problems.append("endrass: the batched kernel's decisions differ from the scalar kernel's")
    # (Both kernels climb to the rebased ray there: rebased_ray_polynomial's
    # running-error expansion and the shifted discs, under the sanitizers.)
    from argand.render.frames import REBASED_LEVEL

    for name, frame in (("batched", batched), ("scalar", scalar)):
        if not np.any(frame.aovs["escalation"] == REBASED_LEVEL):
            problems.append(f"endrass: the {name} kernel no longer reaches the rebased ray at 32x32")
    # The real-root path (Bernstein subdivision, its stack of subintervals,
    # Newton and the fallback to the batch): the complex path's decisions,
    # on a degree-8 preset and on views whose centre row grazes a double line.
    for name, scene in (("endrass", endrass), ("steiner", load_scene("steiner"))):
        for size in (32, 33):
            p = FrameParams(delta=0.0, width=size, height=size)
            complex_ = render_frame(scene, p, workers=1)
            real = render_frame(scene, replace(p, engine=EngineOptions(real=True)), workers=1)
            if not (np.array_equal(complex_.aovs["status"], real.aovs["status"])
                    and np.array_equal(complex_.rgba[..., 3] > 0, real.rgba[..., 3] > 0)):
                problems.append(f"{name} {size}: the real path's decisions differ from the complex path's")
    # Bands rendered together (render_tile_bands: one solve, a tracer per
    # band, staging tiles of their own): each band the frame rendered alone.
    from argand.render.frames import render_bands

    bands = [replace(params, sigma=s, delta=d) for s, d in ((0.0, 0.0), (0.0, np.pi / 9), (0.4, 1.1), (0.0, np.pi))]
    for together, band in zip(render_bands(load_scene("steiner"), bands, tile=8, workers=2), bands):
        alone = render_frame(load_scene("steiner"), band, tile=8, workers=1)
        if together.rgba.tobytes() != alone.rgba.tobytes() or any(
                np.asarray(together.aovs[k]).tobytes() != np.asarray(alone.aovs[k]).tobytes() for k in alone.aovs):
            problems.append(f"steiner sigma={band.sigma} delta={band.delta}: rendered together differs from alone")
    # The root field (record, replay for other bands, refusals of a cut
    # field) through the bindings: the same bits, no memory error.
    from argand.render.field import RootField

    field = RootField(0, 0, 0, 0)
    octic = load_scene("chmutov-octic")
    first = replace(params, sigma=0.0, delta=0.0)
    render_bands(octic, [first], tile=8, workers=2, record=field)
    for derived, band in zip(render_bands(octic, bands, tile=8, workers=2, field=field), bands):
        alone = render_frame(octic, band, tile=8, workers=1)
        if derived.rgba.tobytes() != alone.rgba.tobytes() or any(
                np.asarray(derived.aovs[k]).tobytes() != np.asarray(alone.aovs[k]).tobytes() for k in alone.aovs):
            problems.append(f"chmutov sigma={band.sigma} delta={band.delta}: derived from the field differs")
    # Bands counted, not written (the farm's frames whose files come on
    # request: the sample's roots filled once for them all): the figures of
    # the bands rendered with their pixels.
    from argand.render.convert import to_core_scene
    from argand.render.frames import INTERLEAVED_CHANNELS, plan, render_tile_bands_into, tiles

    def counted_differ(plans, what: str) -> None:
        for r in tiles(24, 16, 8):
            shape = (r.y1 - r.y0, r.x1 - r.x0, len(INTERLEAVED_CHANNELS))
            full = render_tile_bands_into(plans, r, [(np.empty(shape, np.float32), 0, 0) for _ in plans])
            counted = render_tile_bands_into(plans, r, [None] * len(plans))
            if any(a[:2] != b[:2] or a[2].tolist() != b[2].tolist() or a[3].tolist() != b[3].tolist()
                   for a, b in zip(full, counted)):
                problems.append(f"{what} tile {r}: the counted bands' figures differ from the written ones")

    counted_differ([plan(to_core_scene(octic), replace(band, width=24, height=16)) for band in bands], "chmutov")
    # The same for a quartic's close bands: four discs whose band verdicts
    # match the band before take its answer (ClassifyMemo::band,
    # decide_counted_run, Decider::decide_one_keyed).
    counted_differ([plan(to_core_scene(load_scene("bicube")), replace(params, sigma=0.0, delta=d, width=24, height=16))
                    for d in np.linspace(0.0, np.pi / 9, 12)], "bicube close")
    rect = next(iter(field.tiles))
    cut = RootField(field.fingerprint, field.width, field.height, field.tile, dict(field.tiles))
    cut.tiles[rect] = cut.tiles[rect][: len(cut.tiles[rect]) // 2]
    try:
        render_bands(octic, [bands[1]], tile=8, workers=1, field=cut)
        problems.append("a cut root field was read")
    except ValueError:
        pass
    # More objects than the renderer's old 16-entry stack array held (ASan
    # found the overflow with this scene): rendered in full, or refused with
    # a ValueError by a scene limit below 20; never a memory error.
    objects = [
        {"surface": "x^2 + y^2 + z^2 - 0.04", "transform": {"translate": [0.5 * (i % 5) - 1.0, 0.5 * (i // 5) - 1.0, 0.0]}}
        for i in range(MANY_OBJECTS)
    ]
    camera = {"position": [0, 0, 6], "look_at": [0, 0, 0], "up": [0, 1, 0]}
    try:
        many = scene_from_dict({"objects": objects, "camera": camera})
        tile = render_tile(many, FrameParams(delta=0.1, width=20, height=20), TileRect(0, 0, 20, 20))
        if not np.any(tile.rgba[..., 3] > 0):
            problems.append(f"{MANY_OBJECTS} spheres: the tile has no hit")
    except ValueError as exc:
        print(f"{MANY_OBJECTS} objects refused: {exc}")

    for p in problems:
        print("FAIL:", p)
    print(f"sanitizer smoke: {len(polynomials)} polynomials x 4 methods, a batch of {len(batch)}, "
          f"2 tiles, a frame of 6, Endrass's octic with both kernels, counted bands: {'ok' if not problems else f'{len(problems)} problems'}")
    return 1 if problems else 0

#: More objects than the renderer's per-ray stack array once held (16).
MANY_OBJECTS = 20

if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
