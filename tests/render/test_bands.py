"""Frames rendered together (render_bands: each tile's primary roots solved
once for every band) against the same frames rendered alone (render_frame):
every channel of every pixel must be the same bits, whatever the scene
(every preset, random surfaces of degree 2 to 12, real and complex
objects, reflecting ones), the bands (σ > 0 included, both ends of the
band rule), the kernel, the number of samples, the tile size and the
number of threads. The exact pixel truth then checks certified decisions
of bands rendered together."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.frames import (AOV_CHANNELS, DOUBLE_DOUBLE_LEVEL, REBASED_LEVEL, delta_sweep, plan, render_bands,
                                  render_frames)
from argand.render.options import EngineOptions
from argand.scene import load_scene, scene_from_dict
from argand.scene.presets import PRESETS
from tests.helpers.pixel_truth import check_frame, sample_pixels
from tests.helpers.random_surfaces import FAMILIES, random_scene

#: (σ, δ): the real surface, thin and wide bands, σ > 0, the whole upper half plane, π/2 bands.
BANDS = ((0.0, 0.0), (0.0, math.pi / 18), (0.0, math.pi / 9), (0.3, 0.5), (1.0, 0.2), (0.0, math.pi),
         (math.pi / 2, math.pi / 2), (2.5, 0.6), (math.pi, 0.0))


def assert_same_bits(a, b, what: str) -> None:
    assert a.rgba.tobytes() == b.rgba.tobytes(), f"{what}: rgba differs at {np.argwhere(a.rgba != b.rgba)[:5].tolist()}"
    for key in AOV_CHANNELS:
        x, y = np.asarray(a.aovs[key]), np.asarray(b.aovs[key])
        assert x.tobytes() == y.tobytes(), f"{what}: {key} differs at {np.argwhere(x != y)[:5].tolist()}"
    assert a.escalations == b.escalations and a.root_calls == b.root_calls, what
    assert a.figures["status_shares"] == b.figures["status_shares"], what
    assert a.figures["escalation_levels"] == b.figures["escalation_levels"], what


def compare(scene, params: list[FrameParams], tile: int = 16, workers: int = 1) -> list:
    together = render_bands(scene, params, tile=tile, workers=workers)
    assert len(together) == len(params)
    for p, frame in zip(params, together):
        assert frame.params == p
        alone = render_frame(scene, p, tile=tile, workers=workers)
        assert_same_bits(frame, alone, f"sigma={p.sigma} delta={p.delta}")
    return together


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_together_equals_alone(name):
    scene = load_scene(name)
    compare(scene, [FrameParams(sigma=s, delta=d, width=37, height=29, samples=scene.samples) for s, d in BANDS])


@pytest.mark.parametrize("kernel", ["scalar", "auto"])
@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("degree", [2, 3, 4, 5, 8, 12])
def test_random_surfaces_together_equal_alone(family, degree, kernel):
    scene = random_scene(family, degree, seed=degree * 7 + 1)
    params = [FrameParams(sigma=s, delta=d, width=23, height=19, engine=EngineOptions(kernel=kernel))
              for s, d in BANDS[:6]]
    compare(scene, params, tile=8)


@pytest.mark.parametrize("tile, workers, samples", [(8, 1, 1), (32, 2, 1), (64, 2, 4), (16, 1, 9)])
def test_tiles_threads_and_samples(tile, workers, samples):
    scene = load_scene("steiner")
    params = [FrameParams(sigma=s, delta=d, width=41, height=33, samples=samples) for s, d in BANDS[:5]]
    compare(scene, params, tile=tile, workers=workers)


def test_reflecting_and_real_objects_trace_their_bounces_per_band():
    """A real mirror beside a complex surface: a bounce's decisions depend
    on the band, so its colour is traced per band (not shared)."""
    scene = scene_from_dict({
        "objects": [
            {"surface": "x^2 + y^2 + z^2 - 1", "space": "real",
             "material": {"reflectivity": 0.6, "color": [0.8, 0.8, 0.9]}, "transform": {"translate": [1.3, 0, 0]}},
            {"surface": "x^2 - y^2*z", "clip_radius": 1.2, "transform": {"translate": [-1.0, 0, 0]}},
        ],
        "camera": {"position": [0.0, 1.0, 6.0], "look_at": [0.0, 0.0, 0.0]},
    })
    frames = compare(scene, [FrameParams(sigma=s, delta=d, width=40, height=30) for s, d in BANDS])
    assert len({f.rgba.tobytes() for f in frames}) > 2  # the bands do show different pictures


def test_a_samples_ladder_answers_are_shared_by_its_bands_and_change_no_bit():
    """The ladder's answers for a sample (merged discs settled, the ray's
    double-double polynomial, discs shrunk, clusters re-isolated:
    LadderMemo) are kept for the sample's other bands. On the Endrass octic, where pixels climb to
    that rung in many bands of a δ sweep, each band rendered with the others
    is the band alone to the bit, in either order of the bands (whichever
    band asks first computes), and the bands do climb at the same pixels
    (the shared answers are used, not only kept)."""
    scene = load_scene("endrass-octic")
    params = [FrameParams(sigma=0.0, delta=d, width=96, height=80) for d in np.linspace(0.0, math.pi / 9, 8)]
    frames = compare(scene, params, tile=32)
    compare(scene, params[::-1], tile=32)
    # (The rebased ray or the double-double ray: the ladder's answers a
    # LadderMemo shares between bands.)
    climbed = np.stack([np.isin(np.asarray(f.aovs["escalation"]), (REBASED_LEVEL, DOUBLE_DOUBLE_LEVEL)) for f in frames])
    assert int((climbed.sum(axis=0) >= 2).sum()) >= 20, int(climbed.sum())


def test_the_order_of_the_bands_does_not_matter():
    scene = load_scene("whitney")
    params = [FrameParams(sigma=s, delta=d, width=33, height=21) for s, d in BANDS]
    forward = render_bands(scene, params, tile=16, workers=1)
    backward = render_bands(scene, params[::-1], tile=16, workers=1)[::-1]
    for a, b in zip(forward, backward):
        assert_same_bits(a, b, f"sigma={a.params.sigma} delta={a.params.delta}")


def test_frames_that_differ_in_more_than_the_band_are_refused():
    scene = load_scene("bicube")
    with pytest.raises(ValueError, match="sigma and delta only"):
        render_bands(scene, [FrameParams(width=8, height=8), FrameParams(width=9, height=8)])
    a = plan(to_core_scene(scene), FrameParams(width=8, height=8))
    b = plan(to_core_scene(load_scene("whitney")), FrameParams(width=8, height=8))
    planes = [(np.empty((8, 8, 4), np.float32),) + tuple(np.empty((8, 8), t) for t in
              (np.float32, np.float32, np.float32, np.float32, np.int32, np.uint8, np.uint8, np.float32))
              for _ in range(2)]
    with pytest.raises(ValueError, match="does not share plan 0's scene"):
        _core.render_tile_bands([a, b], 0, 0, 8, 8, planes)
    with pytest.raises(ValueError, match="outs\\[1\\].Z"):
        bad = [planes[0], (planes[1][0], np.empty((8, 8), np.float64)) + planes[1][2:]]
        _core.render_tile_bands([a, a], 0, 0, 8, 8, bad)
    with pytest.raises(ValueError, match="outs\\[0\\].status: .*as wide as rgba"):
        narrow = planes[0][:6] + (np.empty((8, 12), np.uint8),) + planes[0][7:]
        _core.render_tile_bands([a], 0, 0, 8, 8, [narrow])
    with pytest.raises(ValueError, match="is not inside the 8x8 frame"):
        _core.render_tile_bands([a], 0, 0, 9, 8, [planes[0]])


def test_render_frames_groups_what_it_can_and_keeps_the_order():
    scene = load_scene("bicube")
    params = [FrameParams(delta=d, width=16, height=16) for d in (0.0, 0.2, 0.4)] + \
             [FrameParams(delta=0.1, width=20, height=12)] + [FrameParams(delta=d, width=16, height=16) for d in (0.3, 0.5)]
    frames = list(render_frames(scene, params, tile=8, workers=1, bands_at_once=2))
    assert [f.params for f in frames] == params
    for p, f in zip(params, frames):
        assert_same_bits(f, render_frame(scene, p, tile=8, workers=1), str(p))


@pytest.mark.parametrize("name", ["whitney", "steiner", "bicube"])
def test_certified_pixels_of_bands_rendered_together_are_right(name):
    """The exact truth on the certified pixels of bands rendered together,
    bands that were not the first of their group included."""
    scene = load_scene(name)
    params = [FrameParams(sigma=s, delta=d, width=48, height=48) for s, d in BANDS[:6]]
    checked = 0
    for p, frame in zip(params, render_bands(scene, params, tile=16, workers=1)):
        check = check_frame(scene, p, frame, sample_pixels(48, 48, 60, seed=3))
        assert check.wrong == 0, (p.sigma, p.delta, check.disagreements[:3])
        checked += check.certified
    assert checked > 200


def figures_without_pixels_are_the_rendered_ones(scene, samples: int, bands, size=(40, 24)) -> None:
    from argand.render.frames import INTERLEAVED_CHANNELS, render_tile_bands_into, tiles

    width, height = size
    params = [FrameParams(sigma=s, delta=d, width=width, height=height, samples=samples) for s, d in bands]
    plans = [plan(scene, p) for p in params]
    counted = 0
    for r in tiles(width, height, 16):
        shape = (r.y1 - r.y0, r.x1 - r.x0, len(INTERLEAVED_CHANNELS))
        full = render_tile_bands_into(plans, r, [(np.empty(shape, np.float32), 0, 0) for _ in plans])
        only = render_tile_bands_into(plans, r, [None] * len(plans))
        mixed = render_tile_bands_into(plans, r, [None if b % 2 else (np.empty(shape, np.float32), 0, 0)
                                                  for b in range(len(plans))])
        alone = [render_tile_bands_into([p], r, [None])[0] for p in plans]
        for a, b, c, d in zip(full, only, mixed, alone):
            for x in (b, c, d):
                assert x[:2] == a[:2] and x[2].tolist() == a[2].tolist() and x[3].tolist() == a[3].tolist(), r
            counted += int(a[2][:4].sum())
    assert counted == width * height * len(plans)


@pytest.mark.parametrize("name", sorted(PRESETS))
@pytest.mark.parametrize("samples", [1, 4])
def test_a_bands_figures_without_its_pixels_are_the_rendered_ones(name, samples):
    """A band given no planes (render_tile_bands_into's None: the farm's
    frames whose files are made on request) is counted, not written: its
    escalations, root calls, pixels per status, hits and pixels per ladder
    level are the ones the band gets with its pixels, whether the other
    bands of the tile keep theirs or not, and alone. (Such bands of a
    one-object scene decide from the sample's roots filled once:
    Tracer::decide_counted.)"""
    figures_without_pixels_are_the_rendered_ones(to_core_scene(load_scene(name)), samples, BANDS[:5])


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("degree", [2, 4, 5, 8, 12])
def test_a_bands_figures_without_its_pixels_on_random_surfaces(family, degree):
    """The same on random surfaces of degree 2 to 12 (clusters, the ladder
    and the exact tier among their pixels), every band of BANDS."""
    scene = to_core_scene(random_scene(family, degree, seed=degree * 31 + 7))
    figures_without_pixels_are_the_rendered_ones(scene, 1, BANDS, size=(32, 24))


#: Sweeps of close bands: most bands of a sample share every disc's band
#: verdicts with the band before (a root's argument crosses one band's edge,
#: not every band's), and four discs' verdicts are then taken from the
#: sample's memo (ClassifyMemo::band) instead of being made again.
CLOSE_SWEEPS = (
    [(0.0, d) for d in delta_sweep(0.0, math.pi / 9, 24)],
    [(0.05 * k, 0.25) for k in range(20)],
    [(0.3, d) for d in delta_sweep(0.0, 0.8, 16)],
    [(s, d) for s in (0.0, 0.2, 0.7, 1.5) for d in (0.0, 0.1, 0.3, 0.9)],
)


@pytest.mark.parametrize("kernel", ["scalar", "auto"])
@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("sweep", range(len(CLOSE_SWEEPS)))
def test_close_bands_of_quartics_together_equal_alone(family, sweep, kernel):
    """Quartic rays (four discs, the memo's case) in sweeps of close bands:
    every band rendered together is the lone frame's bits, and its figures
    without pixels are the rendered ones, on random surfaces of each family
    (three seeds) and two tile sizes."""
    for seed in range(3):
        scene = random_scene(family, 4, seed=100 * sweep + seed)
        params = [FrameParams(sigma=s, delta=d, width=29, height=23, engine=EngineOptions(kernel=kernel))
                  for s, d in CLOSE_SWEEPS[sweep]]
        compare(scene, params, tile=8 if seed % 2 else 16)
        figures_without_pixels_are_the_rendered_ones(to_core_scene(scene), 1, CLOSE_SWEEPS[sweep], size=(32, 24))


#: Bands from the real surface up through thin ones (10^-12 to 0.3): their
#: edges cross the discs of nearly real roots (tangent rays, silhouettes),
#: whose band tests then need the reference, which reads the band itself.
THIN_BANDS = sorted([(0.0, 0.0)] + [(0.0, m * 10.0 ** e) for e in range(-12, 0) for m in (1, 3)], key=lambda b: b[1])


@pytest.mark.parametrize("family", FAMILIES)
def test_bands_whose_edges_graze_the_roots_share_no_unproven_choice(family):
    """A band takes another band's choice only where its discs' verdicts
    settled it without the reference test: the counted figures of bands
    whose edges lie on the roots' own arguments (1e-7 either side of the
    chosen roots', and THIN_BANDS) are the rendered ones, band by band, on
    random quartics of each family and on the Bicube's silhouette."""
    scene = random_scene(family, 4, seed=41)
    wide = render_frame(scene, FrameParams(sigma=0.0, delta=math.pi, width=32, height=24), tile=16, workers=1)
    args = np.asarray(wide.aovs["arg"], np.float64)
    picked = np.unique(np.abs(args[np.isfinite(args) & (np.abs(args) > 1e-3) & (np.abs(args) < 3.0)]))
    assert picked.size >= 4, "the frame shows too few complex roots to graze"
    bands = sorted({(0.0, float(a) + k * 2e-8) for a in picked[:: max(1, picked.size // 4)][:4] for k in range(-2, 3)},
                   key=lambda b: b[1])
    figures_without_pixels_are_the_rendered_ones(to_core_scene(scene), 1, bands, size=(32, 24))
    for seed in range(3):
        figures_without_pixels_are_the_rendered_ones(to_core_scene(random_scene(family, 4, seed=seed)), 1, THIN_BANDS,
                                                     size=(48, 32))
    if family == FAMILIES[0]:
        figures_without_pixels_are_the_rendered_ones(to_core_scene(load_scene("bicube")), 1, THIN_BANDS, size=(96, 64))
