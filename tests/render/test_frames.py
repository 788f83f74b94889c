"""The complex-space ray caster: invariants, the exact real silhouette of a
sphere, agreement with a slow independent reference (exact ray polynomial +
python-flint per pixel) on every preset, and the files a frame produces."""

from __future__ import annotations

import math
from fractions import Fraction

import flint
import numpy as np
import pytest

from argand.core import _core
from argand.render import FrameParams, render_frame
from argand.render.convert import to_core_scene
from argand.render.frames import plan
from argand.scene import load_scene, scene_from_dict
from argand.scene.presets import PAPER_PRESETS

DELTAS = [0.0, math.pi / 36, math.pi / 18, math.pi / 9]


@pytest.mark.parametrize("name", PAPER_PRESETS)
def test_growing_delta_never_shrinks_the_mask_nor_grows_the_modulus(name):
    scene = load_scene(name)
    frames = [render_frame(scene, FrameParams(delta=d, width=40, height=40), workers=1) for d in DELTAS]
    for a, b in zip(frames, frames[1:]):
        hit_a, hit_b = a.rgba[..., 3] > 0, b.rgba[..., 3] > 0
        assert np.all(hit_b[hit_a]), "a pixel lost its hit as delta grew"
        both = hit_a & hit_b
        assert np.all(b.aovs["Z"][both] <= a.aovs["Z"][both]), "the modulus grew as delta grew"


@pytest.mark.parametrize("name", ["bicube", "steiner", "whitney"])
def test_band_and_conjugate_symmetry(name):
    sigma, delta = math.pi / 36, math.pi / 18
    r = render_frame(load_scene(name), FrameParams(sigma=sigma, delta=delta, width=40, height=40), workers=1)
    cert = (r.aovs["status"] == 0) & (r.rgba[..., 3] > 0)
    assert cert.any()
    arg = np.abs(r.aovs["arg"][cert].astype(np.float64))
    assert np.all(arg >= sigma - 1e-6) and np.all(arg <= sigma + delta + 1e-6)
    # sigma > 0 excludes real roots: eligible roots come in conjugate pairs.
    assert np.all(r.aovs["count"][cert] % 2 == 0)


def test_delta_zero_is_exactly_the_real_surface_of_a_sphere():
    scene = scene_from_dict(
        {"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}], "camera": {"position": [0.3, -4.0, 0.7], "look_at": [0, 0, 0]}}
    )
    w = h = 64
    result = render_frame(scene, FrameParams(delta=0.0, width=w, height=h), workers=1)
    fp = plan(to_core_scene(scene), FrameParams(width=w, height=h))
    mismatches = 0
    for y in range(h):
        for x in range(w):
            eye, d = _core.primary_ray(fp, x, y)
            o = np.array(eye)
            # Distance from the centre to the ray's line, squared: hit iff < 1.
            b = float(np.dot(o, d))
            dist2 = float(np.dot(o, o) - b * b)
            if abs(dist2 - 1.0) < 1e-9:
                continue  # tangent to within rounding: either answer is honest
            expected = dist2 < 1.0 and b < 0
            mismatches += expected != bool(result.rgba[y, x, 3] > 0)
    assert mismatches == 0
    assert result.certified_share > 0.99


# ---------------------------------------------------------------------------
# The slow reference
# ---------------------------------------------------------------------------


def exact_ray_polynomial(terms: dict, o, d) -> list[Fraction]:
    """F(o + t d) with exact rational arithmetic on the double inputs."""
    o = [Fraction(v) for v in o]
    d = [Fraction(v) for v in d]
    n = max(sum(m) for m in terms)
    out = [Fraction(0)] * (n + 1)

    def power(axis: int, e: int) -> list[Fraction]:
        p = [Fraction(1)]
        for _ in range(e):
            q = [Fraction(0)] * (len(p) + 1)
            for k, c in enumerate(p):
                q[k] += c * o[axis]
                q[k + 1] += c * d[axis]
            p = q
        return p

    for (i, j, k), c in terms.items():
        px, py, pz = power(0, i), power(1, j), power(2, k)
        for a, ca in enumerate(px):
            for b, cb in enumerate(py):
                for g, cg in enumerate(pz):
                    out[a + b + g] += c * ca * cb * cg
    return out


def reference_pixel(scene, eye, d, sigma, delta):
    """(hit, chosen root, clear) from the exact truth; clear = no root of any
    object within 1e-7 of a decision boundary (band edge, clip sphere, tie)."""
    candidates, clear = [], True
    from argand.render.convert import object_transform

    for obj in scene.objects:
        linear, translate = object_transform(obj.transform)
        L = np.array(linear).reshape(3, 3)
        oo = L @ (np.array(eye) - np.array(translate))
        od = L @ np.array(d)
        coeffs = exact_ray_polynomial(obj.polynomial.terms, oo, od)
        while coeffs and coeffs[-1] == 0:
            coeffs.pop()
        if len(coeffs) < 2:
            continue
        flint.ctx.prec = 128
        roots = flint.fmpq_poly([flint.fmpq(c.numerator, c.denominator) for c in coeffs]).complex_roots()
        flint.ctx.prec = 53
        for ball, _mult in roots:
            t = complex(float(ball.real.mid()), float(ball.imag.mid()))
            mod = abs(t)
            if mod < 1e-9:
                continue
            if obj.clip_radius is not None:
                p = oo + mod * od
                r2 = float(np.dot(p, p))
                if abs(r2 - obj.clip_radius**2) < 1e-6 * obj.clip_radius**2:
                    clear = False
                if r2 > obj.clip_radius**2:
                    continue
            theta = abs(math.atan2(t.imag, t.real))
            is_real = ball.imag.is_exact() and ball.imag.is_zero()
            if obj.space == "real":
                if is_real and t.real > 0:
                    candidates.append(t)
                continue
            if is_real:
                theta = 0.0 if t.real > 0 else math.pi
            elif min(abs(theta - sigma), abs(theta - sigma - delta)) < 1e-7:
                clear = False
            if sigma <= theta <= sigma + delta:
                candidates.append(t)
    if not candidates:
        return False, None, clear
    candidates.sort(key=abs)
    best = candidates[0]
    others = [c for c in candidates[1:] if abs(c - best.conjugate()) > 1e-9 * abs(best)]
    if others and abs(others[0]) - abs(best) < 1e-7 * abs(best):
        clear = False
    return True, best, clear


@pytest.mark.parametrize("name", PAPER_PRESETS)
@pytest.mark.parametrize("delta", [0.0, math.pi / 18])
def test_agrees_with_the_slow_reference(name, delta):
    scene = load_scene(name)
    w = h = 12
    params = FrameParams(delta=delta, width=w, height=h)
    result = render_frame(scene, params, workers=1)
    fp = plan(to_core_scene(scene), params)
    clear_pixels = certified_clear = 0
    for y in range(h):
        for x in range(w):
            eye, d = _core.primary_ray(fp, x, y)
            hit, best, clear = reference_pixel(scene, eye, d, 0.0, delta)
            status = int(result.aovs["status"][y, x])
            got_hit = bool(result.rgba[y, x, 3] > 0)
            if clear:
                clear_pixels += 1
                certified_clear += status == 0
            if status == 0 or clear:
                assert got_hit == hit, (x, y, status, best)
                if hit:
                    got = complex(float(result.aovs["re"][y, x]), float(result.aovs["im"][y, x]))
                    assert min(abs(got - best), abs(got - best.conjugate())) <= 1e-5 * (1 + abs(best)), (x, y, got, best)
    assert clear_pixels > 0
    assert certified_clear >= 0.99 * clear_pixels


def test_srgb_table_matches_the_formula_but_at_rounding_boundaries():
    """to_srgb8 goes through a 65536-entry table; against the exact sRGB
    formula in float64 it may differ by one 8-bit step, and only where the
    exact value lies within 0.03 steps of a rounding boundary."""
    from argand.media.frame_files import to_srgb8

    rng = np.random.default_rng(11)
    v = np.concatenate([rng.random(1_000_000), rng.random(100_000) * 0.01, [0.0, 1.0, 0.0031308]]).astype(np.float32)
    rgba = np.zeros((v.size, 1, 4), np.float32)
    rgba[:, 0, :3] = v[:, None]
    got = to_srgb8(rgba)[:, 0, 0].astype(int)
    x = v.astype(np.float64)
    exact = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055) * 255.0 + 0.5
    want = np.floor(exact).astype(int)
    diff = got - want
    assert np.abs(diff).max() <= 1
    off = diff != 0
    assert np.all(np.abs(exact[off] - np.round(exact[off])) < 0.03)
    assert off.mean() < 0.01
    # Out-of-range light is clipped, as before.
    assert list(to_srgb8(np.array([[[-1.0, 2.0, 0.5, 1.0]]], np.float32))[0, 0]) == [0, 255, 188]


def test_render_tile_into_writes_in_place_or_refuses():
    """The farm's path writes into the caller's buffer; an array it would
    have to convert (a copy, then thrown away) or a tile outside the frame
    is refused, not silently dropped."""
    from argand.render.convert import to_core_scene
    from argand.render.frames import INTERLEAVED_CHANNELS, TileRect, plan, render_tile_into

    params = FrameParams(delta=0.2, width=40, height=30)
    fplan = plan(to_core_scene(load_scene("steiner")), params)
    out = np.full((30, 40, len(INTERLEAVED_CHANNELS)), -7.0, np.float32)
    esc, calls, stats = render_tile_into(fplan, TileRect(8, 4, 24, 20), out, 8, 4)
    assert stats.sum() - stats[4] == 16 * 16 and calls > 0 and esc >= 0
    assert (out[:4] == -7).all() and (out[20:] == -7).all() and (out[4:20, :8] == -7).all()
    assert (out[4:20, 8:24, 3] >= 0).all() and not (out[4:20, 8:24] == -7).any()
    for bad in (out.astype(np.float64), np.asfortranarray(out), out[:, ::2]):
        with pytest.raises(TypeError):
            render_tile_into(fplan, TileRect(0, 0, 8, 8), bad)
    with pytest.raises(ValueError, match="not inside"):
        render_tile_into(fplan, TileRect(32, 0, 48, 8), out)
    with pytest.raises(ValueError, match="does not fit"):
        render_tile_into(fplan, TileRect(0, 0, 16, 16), out, 30, 20)


def test_render_tile_frame_writes_the_tiles_pixels_into_the_frame_or_refuses():
    """render_frame's path (_core.render_tile_frame) writes exactly the
    tile's pixels of the frame's arrays, the values render_tile returns,
    and touches nothing else; arrays of the wrong shape, dtype or layout,
    and tiles outside the frame, are refused."""
    from argand.render.frames import AOV_CHANNELS, TileRect, plan, render_tile_planned

    params = FrameParams(delta=0.2, width=40, height=30, samples=4)
    fplan = plan(to_core_scene(load_scene("steiner")), params)
    planes = [np.full((30, 40, 4), -7.0, np.float32)] + [
        np.full((30, 40), 7, dt)
        for dt in (np.float32, np.float32, np.float32, np.float32, np.int32, np.uint8, np.uint8, np.float32)
    ]
    esc, calls, by_status, hits, by_level = _core.render_tile_frame(fplan, 8, 4, 35, 21, *planes)
    tile = render_tile_planned(fplan, TileRect(8, 4, 35, 21))
    assert calls == tile.root_calls and esc == tile.escalations
    # The figures it counted as it wrote are those of the tile's AOVs.
    assert list(by_status) == np.bincount(tile.aovs["status"].ravel(), minlength=4).tolist()
    assert list(by_level) == np.bincount(tile.aovs["escalation"].ravel(), minlength=8).tolist()
    assert hits == int((tile.rgba[..., 3] > 0).sum()) and 0 < hits < tile.rgba[..., 3].size
    for name, plane, want in zip(("rgba",) + AOV_CHANNELS, planes, [tile.rgba] + [tile.aovs[n] for n in AOV_CHANNELS]):
        assert np.array_equal(plane[4:21, 8:35], want, equal_nan=True), name
        rest = plane.copy()
        rest[4:21, 8:35] = plane.flat[0]
        assert (rest == plane.flat[0]).all(), name
    with pytest.raises(TypeError):
        _core.render_tile_frame(fplan, 0, 0, 8, 8, planes[0].astype(np.float64), *planes[1:])
    with pytest.raises(TypeError):
        _core.render_tile_frame(fplan, 0, 0, 8, 8, *planes[:5], planes[5].astype(np.int64), *planes[6:])
    with pytest.raises(TypeError):  # (a view, not C-contiguous)
        _core.render_tile_frame(fplan, 0, 0, 8, 8, planes[0][:, :20], *planes[1:])
    with pytest.raises(ValueError, match="must be a C-contiguous"):
        _core.render_tile_frame(fplan, 0, 0, 8, 8, np.ascontiguousarray(planes[0][:, :20]), *planes[1:])
    with pytest.raises(ValueError, match="not inside"):
        _core.render_tile_frame(fplan, 32, 0, 48, 8, *planes)


def test_every_offered_exr_compression_writes_what_it_says_and_loses_nothing(tmp_path):
    """Each compression this installation offers is really used (OpenImageIO
    silently writes zip for a name its OpenEXR lacks) and the frame reads
    back bit for bit, every AOV by name; the PNG preview reads back exactly."""
    import OpenImageIO as oiio

    from argand.media.frame_files import EXR_CHANNELS, exr_compressions, exr_pixels, read_exr, to_srgb8, write_exr, write_png

    result = render_frame(load_scene("plucker"), FrameParams(delta=math.pi / 9, width=48, height=40), tile=16, workers=1)
    want = exr_pixels(result)
    offered = exr_compressions()
    assert {"none", "zip", "piz"} <= set(offered)
    for compression in offered + tuple(c + ":1" for c in offered if c in ("zip", "zstd")):
        path = tmp_path / f"{compression.replace(':', '_')}.exr"
        write_exr(result, path, compression=compression)
        inp = oiio.ImageInput.open(str(path))
        written = inp.spec().get_string_attribute("compression")
        inp.close()
        assert written == compression.partition(":")[0], (compression, written)
        names, got = read_exr(path)
        got = got[..., [names.index(n) for n in EXR_CHANNELS]]
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32)), compression
    srgb = to_srgb8(result.rgba)
    write_png(srgb, tmp_path / "p.png")
    assert np.array_equal(oiio.ImageBuf(str(tmp_path / "p.png")).get_pixels(oiio.UINT8), srgb)


def test_exr_compression_names_and_levels_are_checked():
    from argand.media.frame_files import check_exr_compression, exr_compressions, openexr_version

    assert check_exr_compression("zip") == "zip" and check_exr_compression("zip:9") == "zip:9"
    for bad, says in (("lzma", "must be one of"), ("zip:0", "1..9"), ("zip:x", "1..9"), ("piz:3", "takes no level"),
                      ("", "must be one of")):
        with pytest.raises(ValueError, match=says):
            check_exr_compression(bad)
    from pydantic import ValidationError

    from argand.farm.settings import Settings

    with pytest.raises(ValidationError, match="1..9"):
        Settings(exr_compression="zip:0")
    assert Settings(exr_compression="zip:1").exr_compression == "zip:1"
    if openexr_version() >= (3, 5):
        assert "zstd" in exr_compressions() and check_exr_compression("zstd:22") == "zstd:22"
        with pytest.raises(ValueError, match="1..22"):
            check_exr_compression("zstd:23")
    else:
        with pytest.raises(ValueError, match="needs OpenEXR 3.5"):
            check_exr_compression("zstd")


def test_render_sweep_writes_each_frame_as_rendered_and_restores_oiio_threads(tmp_path):
    """argand render's loop: every frame's EXR holds exactly what
    render_frame gives for it, the animation has one image per frame, and
    OpenImageIO encodes on the threads asked for, then gets its own
    settings back."""
    import OpenImageIO as oiio

    from argand.media.frame_files import EXR_CHANNELS, exr_pixels, read_exr
    from argand.render.sweep import render_sweep

    scene = load_scene("steiner")
    params = [FrameParams(delta=d, width=40, height=32) for d in (0.0, math.pi / 9, math.pi / 4)]
    before = {k: oiio.get_int_attribute(k) for k in ("threads", "exr_threads")}
    seen = []
    figures = render_sweep(scene, params, tmp_path, tile=16, workers=1,
                           on_frame=lambda i, p: seen.append((i, p.delta, oiio.get_int_attribute("threads"))))
    assert seen == [(i, p.delta, 1) for i, p in enumerate(params)]
    assert {k: oiio.get_int_attribute(k) for k in before} == before
    assert [f["delta"] for f in figures] == [p.delta for p in params]
    for i, p in enumerate(params):
        names, got = read_exr(tmp_path / f"frame_{i:04d}.exr")
        want = exr_pixels(render_frame(scene, p, tile=16, workers=1))
        assert np.array_equal(got[..., [names.index(n) for n in EXR_CHANNELS]].view(np.uint32), want.view(np.uint32))
        assert (tmp_path / f"frame_{i:04d}.png").exists() and (tmp_path / f"frame_{i:04d}.json").exists()
    inp = oiio.ImageInput.open(str(tmp_path / "animation.gif"))
    count = 0
    while inp.seek_subimage(count, 0):
        count += 1
    inp.close()
    assert count == len(params)


def test_the_renderers_limits_are_defined_once_in_cpp_and_enforced_everywhere():
    """The surface degree, the frame side and the object count are C++'s
    (render.h): plan_frame refuses past them, and the scene parser, the frame
    parameters and the farm's settings read the same numbers."""
    import copy

    import pydantic

    from argand.core import _core
    from argand.farm.settings import Settings
    from argand.render.convert import to_core_scene
    from argand.render.frames import MAX_FRAME_SIDE, MAX_OBJECTS
    from argand.scene import MAX_DEGREE, load_scene

    assert MAX_DEGREE == _core.MAX_SURFACE_DEGREE and MAX_FRAME_SIDE == _core.MAX_FRAME_SIDE
    assert MAX_OBJECTS == _core.MAX_OBJECTS
    core_scene = to_core_scene(load_scene("bicube"))
    _core.plan_frame(core_scene, 0.0, 0.0, MAX_FRAME_SIDE, 1)
    with pytest.raises(ValueError, match=f"between 1x1 and {MAX_FRAME_SIDE}x{MAX_FRAME_SIDE}"):
        _core.plan_frame(core_scene, 0.0, 0.0, MAX_FRAME_SIDE + 1, 1)
    with pytest.raises(ValueError, match=f"{MAX_FRAME_SIDE}x{MAX_FRAME_SIDE}"):
        FrameParams(width=1, height=MAX_FRAME_SIDE + 1)
    too_high = copy.deepcopy(core_scene)
    with pytest.raises(ValueError, match=f"SurfaceSpec.degree must be in 1..{MAX_DEGREE}"):
        too_high.objects[0].degree = MAX_DEGREE + 1
    with pytest.raises(ValueError, match=rf"SurfaceSpec.terms\[0\].ex must be in 0..{MAX_DEGREE}"):
        too_high.objects[0].terms = [(MAX_DEGREE + 1, 0, 0, 1.0), (0, 0, 0, -1.0)]
    too_high.objects[0].terms = [(MAX_DEGREE, 1, 0, 1.0), (0, 0, 0, -1.0)]  # degree 13 > the object's degree
    with pytest.raises(ValueError, match="object 0: a term exceeds the declared degree"):
        _core.plan_frame(too_high, 0.0, 0.0, 8, 8)
    with pytest.raises(pydantic.ValidationError):
        Settings(max_width=MAX_FRAME_SIDE + 1)


def test_the_aovs_are_one_table_from_cpp_to_the_exr(tmp_path):
    """render.h's kAovs (_core.AOVS) names every AOV once: the planes a tile
    binding returns have its names and dtypes, a frame's planes and the
    EXR's channels follow it, in its order after R, G, B, A."""
    from argand.core import _core
    from argand.media.frame_files import read_exr, write_exr
    from argand.render.frames import AOV_CHANNELS, INTERLEAVED_CHANNELS, TileRect, plan, render_frame
    from argand.render.convert import to_core_scene
    from argand.scene import load_scene

    assert INTERLEAVED_CHANNELS == ("R", "G", "B", "A") + tuple(n for n, _ in _core.AOVS) and AOV_CHANNELS
    scene = load_scene("steiner")
    fplan = plan(to_core_scene(scene), FrameParams(delta=0.3, width=20, height=12))
    tile = _core.render_tile(fplan, 0, 0, 20, 12)
    for name, dtype in _core.AOVS:
        assert tile[name].dtype == np.dtype(dtype) and tile[name].shape == (12, 20), name
    frame = render_frame(scene, FrameParams(delta=0.3, width=20, height=12), workers=1)
    assert [(n, frame.aovs[n].dtype.name) for n in frame.aovs] == list(_core.AOVS)
    write_exr(frame, tmp_path / "f.exr")
    names, pixels = read_exr(tmp_path / "f.exr")
    assert sorted(names) == sorted(INTERLEAVED_CHANNELS)  # (OpenEXR keeps channels in its own order)
    for name, _ in _core.AOVS:
        assert np.array_equal(pixels[..., names.index(name)], frame.aovs[name].astype(np.float32)), name
