"""The root field (argand.render.field): the primary roots a render solved,
recorded per tile, then replayed for other bands instead of solved again.
A frame derived from the field must be, in every channel of every pixel,
the frame rendered from scratch, for bands that were not rendered when the
field was recorded (σ > 0 included); a field of other rays, another tiling,
cut short or damaged must be refused, never read; and the exact pixel
truth checks certified decisions made from a field."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.field import RootField
from argand.render.frames import AOV_DTYPES, AOV_CHANNELS, plan, render_bands
from argand.render.options import EngineOptions
from argand.scene import load_scene
from argand.scene.presets import PRESETS
from tests.helpers.pixel_truth import check_frame, sample_pixels
from tests.helpers.random_surfaces import FAMILIES, random_scene
from tests.render.test_bands import BANDS, assert_same_bits


def recorded(scene, params: FrameParams, tile: int, workers: int = 1) -> RootField:
    field = RootField(0, 0, 0, 0)
    frame = render_bands(scene, [params], tile=tile, workers=workers, record=field)[0]
    # Recording changes nothing of the frame it renders.
    assert_same_bits(frame, render_frame(scene, params, tile=tile, workers=workers), "recording")
    assert field.covers(plan(to_core_scene(scene), params), tile)
    return field


def derived_equal_scratch(scene, field: RootField, params: list[FrameParams], tile: int, workers: int = 1) -> list:
    derived = render_bands(scene, params, tile=tile, workers=workers, field=field)
    for p, frame in zip(params, derived):
        assert_same_bits(frame, render_frame(scene, p, tile=tile, workers=workers), f"σ={p.sigma} δ={p.delta}")
    return derived


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_any_band_from_one_field(name):
    scene = load_scene(name)
    size = dict(width=37, height=29, samples=scene.samples)
    # Recorded for one band, replayed for every other (the first one included).
    field = recorded(scene, FrameParams(sigma=0.0, delta=math.pi / 9, **size), tile=16)
    derived_equal_scratch(scene, field, [FrameParams(sigma=s, delta=d, **size) for s, d in BANDS], tile=16)


@pytest.mark.parametrize("kernel", ["scalar", "auto"])
@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("degree", [2, 4, 7, 12])
def test_random_surfaces_and_random_bands(family, degree, kernel):
    rng = random.Random(degree * 31 + len(family))
    scene = random_scene(family, degree, seed=degree * 5 + 3)
    engine = EngineOptions(kernel=kernel)
    first = FrameParams(sigma=rng.uniform(0, 1), delta=rng.uniform(0, 1), width=27, height=21, engine=engine)
    field = recorded(scene, first, tile=8)
    bands = []
    for _ in range(5):
        s = rng.uniform(0, math.pi)
        bands.append(FrameParams(sigma=s, delta=rng.uniform(0, math.pi - s), width=27, height=21, engine=engine))
    derived_equal_scratch(scene, field, bands, tile=8)


@pytest.mark.parametrize("tile, workers, samples", [(8, 2, 1), (64, 2, 4), (16, 1, 9)])
def test_tiles_threads_and_samples(tile, workers, samples):
    scene = load_scene("chmutov-octic")
    size = dict(width=41, height=33, samples=samples)
    field = recorded(scene, FrameParams(**size), tile=tile, workers=workers)
    derived_equal_scratch(scene, field, [FrameParams(sigma=s, delta=d, **size) for s, d in BANDS[1:6]], tile=tile,
                          workers=workers)


def test_a_field_survives_a_file_and_damage_is_refused(tmp_path):
    scene = load_scene("steiner")
    p = FrameParams(sigma=0.2, delta=0.5, width=40, height=24)
    field = recorded(scene, p, tile=16)
    back = RootField.load(field.save(tmp_path / "steiner.arf"))
    assert back.tiles == field.tiles and back.fingerprint == field.fingerprint
    derived_equal_scratch(scene, back, [FrameParams(sigma=1.0, delta=0.9, width=40, height=24)], tile=16)
    data = bytearray((tmp_path / "steiner.arf").read_bytes())
    for at in (len(data) - 3, len(data) // 2, len(data) - len(field.tiles[(0, 0, 16, 16)]) // 2):
        bad = bytearray(data)
        bad[at] ^= 0x10
        (tmp_path / "bad.arf").write_bytes(bytes(bad))
        with pytest.raises(ValueError, match="checksum|damaged"):
            RootField.load(tmp_path / "bad.arf")
    (tmp_path / "short.arf").write_bytes(bytes(data[:-10]))
    with pytest.raises(ValueError):
        RootField.load(tmp_path / "short.arf")
    (tmp_path / "other.arf").write_bytes(b"P6 not a field")
    with pytest.raises(ValueError, match="not an Argand root field"):
        RootField.load(tmp_path / "other.arf")


def _planes(w: int, h: int) -> tuple:
    return (np.empty((h, w, 4), np.float32),) + tuple(np.empty((h, w), AOV_DTYPES[n]) for n in AOV_CHANNELS)


def test_the_core_refuses_a_field_of_other_rays_another_tile_or_a_cut_one():
    bicube = to_core_scene(load_scene("bicube"))
    p = plan(bicube, FrameParams(width=32, height=32))
    _, tape = _core.render_tile_bands([p], 0, 0, 16, 16, [_planes(32, 32)], record=True)
    assert isinstance(tape, bytes) and len(tape) > 32
    other_scene = plan(to_core_scene(load_scene("whitney")), FrameParams(width=32, height=32))
    other_size = plan(bicube, FrameParams(width=32, height=31))
    other_kernel = plan(bicube, FrameParams(width=32, height=32, engine=EngineOptions(kernel="scalar")))
    for q in (other_scene, other_size, other_kernel):
        assert _core.rays_fingerprint(q) != _core.rays_fingerprint(p)
        with pytest.raises(ValueError, match="another tile, scene, camera"):
            _core.render_tile_bands([q], 0, 0, 16, 16, [_planes(32, 32)], field=tape)
    # Only σ and δ may differ: the same fingerprint.
    assert _core.rays_fingerprint(plan(bicube, FrameParams(sigma=1.0, delta=0.3, width=32, height=32))) == \
        _core.rays_fingerprint(p)
    with pytest.raises(ValueError, match="another tile"):
        _core.render_tile_bands([p], 16, 0, 32, 16, [_planes(32, 32)], field=tape)
    for cut in (len(tape) - 1, len(tape) // 2, 40):
        with pytest.raises(ValueError, match="root field"):
            _core.render_tile_bands([p], 0, 0, 16, 16, [_planes(32, 32)], field=tape[:cut])
    with pytest.raises(ValueError, match="more than the tile"):
        _core.render_tile_bands([p], 0, 0, 16, 16, [_planes(32, 32)], field=tape + b"\0")
    with pytest.raises(ValueError, match="not both"):
        _core.render_tile_bands([p], 0, 0, 16, 16, [_planes(32, 32)], field=tape, record=True)
    with pytest.raises(ValueError, match="other rays or another tile size"):
        render_bands(load_scene("bicube"), [FrameParams(width=32, height=32)], tile=8,
                     field=RootField(_core.rays_fingerprint(p), 32, 32, 16, {(0, 0, 16, 16): tape}))


@pytest.mark.parametrize("name", ["whitney", "steiner", "chmutov-octic"])
def test_certified_decisions_from_a_field_are_right(name):
    """The exact truth on certified pixels of bands decided from a field
    recorded for another band."""
    scene = load_scene(name)
    field = recorded(scene, FrameParams(sigma=0.0, delta=0.0, width=48, height=48), tile=16)
    checked = 0
    params = [FrameParams(sigma=s, delta=d, width=48, height=48) for s, d in BANDS[1:6]]
    for p, frame in zip(params, render_bands(scene, params, tile=16, workers=1, field=field)):
        check = check_frame(scene, p, frame, sample_pixels(48, 48, 50, seed=11))
        assert check.wrong == 0, (p.sigma, p.delta, check.disagreements[:3])
        checked += check.certified
    assert checked > 150
