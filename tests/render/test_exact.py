"""The exact tier of the pixel ladder (levels 5-7, argand.render.exact).

Pixels that the double-double tier leaves unproven (status 1 clusters and
status 3 undecided pixels after level 4: rays grazing a silhouette to within an
ulp, rays at the singular lines of the paper's presets, roots on the
clipping sphere) go to the exact tier, which decides them on the exact
rational ray polynomial. Here: they come out certified, or status 1 with a
proven multiple root, or status 3 with the open comparison named, and no
certified pixel contradicts the independent truth (tests/helpers/pixel_truth.py);
the work caps hold (a pixel beyond the tile's budget stays unproven and is
counted); the farm's tiles and `argand render` give the same frame, bit
for bit, with the tier on; --explain prints its steps.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from tests.helpers.pixel_truth import check_frame, check_pixel, pixel_truth, rendered_pixel, scene_objects
from tests.helpers.random_surfaces import random_scene
from tests.farm.test_work import farm_parts, submit  # noqa: F401  (a fixture)
from tests.render.test_bands import assert_same_bits
from tests.render.test_truth import GRAZING, bisect_to_tangency, centre_truth, hit_miss_pair, with_look_at

from argand.render import FrameParams, TileRect, primary_ray, render_frame, render_tile
from argand.render.convert import to_core_scene
from argand.render.explain import explain_pixel
from argand.render.frames import (
    DOUBLE_DOUBLE_LEVEL,
    EXACT_LEVEL,
    EXACT_MULTIPLE_LEVEL,
    EXACT_OVER_CAP_LEVEL,
    LADDER_LEVEL_NAMES,
)
from argand.scene import load_scene, scene_from_dict

OFF = {"exact_pixels_per_block": 0}
EXACT, MULTIPLE, OVER_CAP = EXACT_LEVEL, EXACT_MULTIPLE_LEVEL, EXACT_OVER_CAP_LEVEL


def wrong(problems: list[str]) -> list[str]:
    return [p for p in problems if p.startswith("wrong: ")]


def test_ladder_levels_are_named():
    assert LADDER_LEVEL_NAMES[EXACT] == "exact"
    assert LADDER_LEVEL_NAMES[MULTIPLE] == "exact: multiple root proven"
    assert LADDER_LEVEL_NAMES[OVER_CAP] == "exact: over the work cap"


# ---------------------------------------------------------------------------
# Grazing rays that the ladder (rebased ray, double-double) leaves undecided
# ---------------------------------------------------------------------------

#: The grazing cases whose last look_ats include centre pixels undecided
#: (status 3) after level 4: a complex pair within 1e-8 of a band edge;
#: degree 4 to 8 (the two octics at delta = pi/18 beside test_render_truth's).
UNDECIDED_AT_LEVEL_3 = [g for g in GRAZING if g[0] in ("bicube-band", "dense-5", "dense-7", "product-6")] + [
    ("dense-8-band", lambda: random_scene("dense", 8, seed=4), math.pi / 18, [0.0, 0.0, 0.0], [0.0, 0.05, 0.05]),
    ("chmutov-octic-band", lambda: to_core_scene(load_scene("chmutov-octic")), math.pi / 18, [0.0, 0.0, 0.0],
     [0.0, 0.0, 0.06]),
]


@pytest.mark.parametrize("name, make_scene, delta, base, step", UNDECIDED_AT_LEVEL_3, ids=[g[0] for g in UNDECIDED_AT_LEVEL_3])
def test_grazing_pixels_undecided_at_level_3_are_decided_exactly(name, make_scene, delta, base, step):
    scene = make_scene()
    params = FrameParams(delta=delta, width=33, height=33)
    objects = scene_objects(scene)
    hit_at, miss_at = hit_miss_pair(scene, params, base, step, objects)
    look_ats = bisect_to_tangency(scene, params, hit_at, miss_at, objects)[-12:]
    rect = TileRect(16, 16, 17, 17)
    undecided_before = 0
    for look_at in look_ats:
        moved = with_look_at(scene, look_at)
        before = render_tile(moved, FrameParams(delta=delta, width=33, height=33, **OFF), rect)
        after = render_tile(moved, params, rect)
        truth = centre_truth(scene, params, look_at, objects)
        status_before = int(before.aovs["status"][0, 0])
        status, level = int(after.aovs["status"][0, 0]), int(after.aovs["escalation"][0, 0])
        assert not wrong(check_pixel(truth, *rendered_pixel(after, 0, 0))), (name, list(look_at))
        if status_before == 0:
            assert status == 0 and level <= DOUBLE_DOUBLE_LEVEL  # the exact tier only sees what the ladder left
            continue
        undecided_before += 1
        assert level in (EXACT, MULTIPLE), (name, list(look_at), level)
        # Simple roots apart by ~1e-8: the exact tier certifies the exact answer.
        assert status == 0 and truth.decision in ("hit", "miss"), (name, list(look_at), status)
    assert undecided_before >= 1, name


# ---------------------------------------------------------------------------
# Singular lines: a ray that meets a double line exactly, a ray inside the surface
# ---------------------------------------------------------------------------

#: (id, surface, clip, camera position, look_at): the centre ray of an odd
#: frame is exactly (-1, 0, 0), through a point of a double line.
EXACT_SINGULAR = [
    ("whitney-handle", "x^2*z + y^2", 2.0, [5.0, 0.0, -0.7], [0.0, 0.0, -0.7]),
    ("plucker-axis", "x^2*z - x*y + y^2*z", 2.0, [5.0, 0.0, 0.3], [0.0, 0.0, 0.3]),
    ("steiner-z-axis", "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2", 1.2, [5.0, 0.0, -0.3], [0.0, 0.0, -0.3]),
]


@pytest.mark.parametrize("name, text, clip, position, look_at", EXACT_SINGULAR, ids=[s[0] for s in EXACT_SINGULAR])
def test_a_ray_through_a_double_line_is_status_1_with_the_multiple_root_proven(name, text, clip, position, look_at):
    scene = scene_from_dict({"objects": [{"surface": text, "clip_radius": clip}],
                             "camera": {"position": position, "look_at": look_at}})
    size = 9
    origin, direction = primary_ray(scene, size, size, 4, 4)
    assert direction == (-1.0, 0.0, 0.0)
    truth = pixel_truth(to_core_scene(scene), 0.0, 0.0, origin, direction)
    assert truth.decision == "hit" and truth.root.multiplicity == 2
    before = render_frame(scene, FrameParams(width=size, height=size, **OFF), workers=1)
    assert before.aovs["status"][4, 4] == 1 and before.aovs["escalation"][4, 4] <= DOUBLE_DOUBLE_LEVEL
    result = render_frame(scene, FrameParams(width=size, height=size), workers=1)
    assert result.aovs["status"][4, 4] == 1 and result.aovs["escalation"][4, 4] == MULTIPLE
    assert result.rgba[4, 4, 3] == 1.0 and result.aovs["re"][4, 4] == np.float32(5.0) and result.aovs["im"][4, 4] == 0
    assert result.figures["exact_multiple_roots"] >= 1
    e = explain_pixel(scene, FrameParams(width=size, height=size), 4, 4)
    assert e["status"] == 1 and e["escalation"] == MULTIPLE and e["exact_ran"]
    assert "multiplicity 2" in e["reason"] and "gcd(p, p')" in e["reason"]
    # Every pixel of the frame: certified ones agree with the truth.
    check = check_frame(to_core_scene(scene), FrameParams(width=size, height=size), result,
                        [(x, y) for y in range(size) for x in range(size)])
    assert not [p for _x, _y, ps in check.disagreements for p in wrong(ps)]


def test_a_ray_inside_the_surface_is_status_1_proven():
    """Steiner's Roman surface contains the x axis: the ray along it has the
    ray polynomial 0."""
    scene = scene_from_dict({"objects": [{"surface": "x^2*y^2 + x^2*z^2 + x*y*z + y^2*z^2", "clip_radius": 1.2}],
                             "camera": {"position": [5.0, 0.0, 0.0], "look_at": [0.0, 0.0, 0.0]}})
    result = render_frame(scene, FrameParams(width=9, height=9), workers=1)
    assert result.aovs["status"][4, 4] == 1 and result.aovs["escalation"][4, 4] == MULTIPLE
    e = explain_pixel(scene, FrameParams(width=9, height=9), 4, 4)
    assert "identically zero" in e["reason"] and "lies in the surface" in e["reason"]


@pytest.mark.parametrize("name", ["whitney", "plucker", "steiner"])
def test_presets_at_an_odd_size_are_all_certified_with_the_exact_tier(name):
    """At an odd size the centre row's and column's rays pass within rounding
    of the presets' double lines: clusters the double-double tier keeps, simple
    roots ~1e-16 apart that the exact tier separates."""
    scene = load_scene(name)
    before = render_frame(scene, FrameParams(width=31, height=31, **OFF), workers=1)
    assert before.certified_share < 1.0
    params = FrameParams(width=31, height=31)
    result = render_frame(scene, params, workers=1)
    assert result.certified_share == 1.0
    levels = result.aovs["escalation"]
    exact = np.argwhere(levels == EXACT)
    assert len(exact) == result.figures["exact_pixels"] == 961 - before.status_counts[0]
    assert result.figures["exact_share"] == pytest.approx(len(exact) / 961)
    check = check_frame(to_core_scene(scene), params, result, [(int(x), int(y)) for y, x in exact])
    assert check.certified == len(exact)
    assert not [p for _x, _y, ps in check.disagreements for p in wrong(ps)]


# ---------------------------------------------------------------------------
# Roots on the clipping sphere, modulus ties, and the work caps
# ---------------------------------------------------------------------------


def sphere_on_its_clip():
    return scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1", "clip_radius": 1}],
                            "camera": {"position": [0.0, -4.0, 0.3], "look_at": [0.0, 0.0, 0.0]}})


def test_real_roots_exactly_on_the_clipping_sphere_are_decided_exactly():
    """The unit sphere clipped by the unit ball: every real root's point is on
    the sphere, which no disc decides; the exact tier proves it exactly
    (a root of gcd(f, |o' + t d'|^2 - 1)): inside the closed ball."""
    scene = sphere_on_its_clip()
    before = render_frame(scene, FrameParams(width=9, height=9, **OFF), workers=1)
    hits_before = int(np.count_nonzero(before.aovs["status"] == 3))
    assert hits_before > 4
    # (A budget of the whole 8x8 block: every ray here needs the tier.)
    result = render_frame(scene, FrameParams(width=9, height=9, exact_pixels_per_block=64), workers=1)
    assert result.certified_share == 1.0
    assert int(np.count_nonzero(result.aovs["escalation"] == EXACT)) == hits_before
    for y, x in np.argwhere(result.aovs["escalation"] == EXACT):
        assert result.rgba[y, x, 3] == 1.0
        origin, direction = primary_ray(scene, 9, 9, int(x), int(y))
        truth = pixel_truth(to_core_scene(scene), 0.0, 0.0, origin, direction)
        # The truth leaves a root on the sphere degenerate; its nearer real
        # root, checked here to be on the unit sphere, is the pixel's.
        assert truth.decision == "degenerate"
        near = min((r for r in truth.roots if r.real and r.ball.real > 0), key=lambda r: float(r.modulus.mid()))
        t = float(near.ball.real.mid())
        assert abs(sum((o + t * d) ** 2 for o, d in zip(origin, direction)) - 1.0) < 1e-12
        assert result.aovs["re"][y, x] == np.float32(t) and result.aovs["im"][y, x] == 0


def test_the_blocks_exact_budget_holds_and_the_pixels_beyond_it_are_counted():
    scene = sphere_on_its_clip()
    open_pixels = int(np.count_nonzero(render_frame(scene, FrameParams(width=9, height=9, **OFF),
                                                    workers=1).aovs["status"] == 3))
    result = render_frame(scene, FrameParams(width=9, height=9, exact_pixels_per_block=4), workers=1)
    levels, status = result.aovs["escalation"], result.aovs["status"]
    # The budget is per frame-aligned 8x8 block: the 9x9 frame has four.
    want = sum(min(4, int(np.count_nonzero(before[y:y + 8, x:x + 8] == 3)))
               for before in [render_frame(scene, FrameParams(width=9, height=9, **OFF), workers=1).aovs["status"]]
               for y in (0, 8) for x in (0, 8))
    assert np.count_nonzero(levels == EXACT) == want == result.figures["exact_pixels"]
    assert np.count_nonzero(levels == OVER_CAP) == open_pixels - want == result.figures["exact_over_cap"]
    assert np.all(status[levels == OVER_CAP] == 3) and np.all(status[levels == EXACT] == 0)
    # Each block spends its own budget, whatever the tiling, the threads or
    # the kernel: a frame whose every hit needs the tier is the same bits
    # from tiles of 8, 16, 24, 32 and 64 (the budget was per tile once, and
    # such frames differed with the tile size).
    size = dict(width=45, height=37)
    frames = [render_frame(scene, FrameParams(**size, exact_pixels_per_block=2), tile=t, workers=w)
              for t, w in ((8, 1), (16, 2), (24, 1), (32, 2), (64, 1))]
    for other in frames[1:]:
        assert_same_bits(other, frames[0], "tiles")
    levels = frames[0].aovs["escalation"]
    per_block = [int(np.count_nonzero(levels[y:y + 8, x:x + 8] == EXACT)) for y in range(0, 37, 8) for x in range(0, 45, 8)]
    assert max(per_block) == 2 and sum(per_block) > 2 and np.count_nonzero(levels == OVER_CAP) > 0
    # Off: nothing reaches the tier.
    off = render_frame(scene, FrameParams(width=9, height=9, **OFF), workers=1)
    assert off.figures["exact_pixels"] == 0 and off.figures["exact_over_cap"] == 0


def test_a_modulus_tie_between_two_objects_stays_undecided_at_the_precision_cap():
    """The same sphere twice: every hit has two equal roots of different
    objects, a true tie no precision separates. Status 3, the reason names it
    and the cap, at the frame's exact_max_bits."""
    scene = scene_from_dict({"objects": [{"surface": "x^2 + y^2 + z^2 - 1"}] * 2,
                             "camera": {"position": [0.0, -4.0, 0.3], "look_at": [0.0, 0.0, 0.0]}})
    params = FrameParams(width=9, height=9, exact_max_bits=256, exact_pixels_per_block=64)
    result = render_frame(scene, params, workers=1)
    hits = result.rgba[..., 3] > 0
    assert hits.any()
    assert np.all(result.aovs["status"][hits] == 3) and np.all(result.aovs["escalation"][hits] == EXACT)
    assert np.all(result.aovs["status"][~hits] == 0)
    e = explain_pixel(scene, params, 4, 4)
    assert e["status"] == 3 and "modulus tie" in e["reason"] and "256 bits (the cap)" in e["reason"]
    truth = pixel_truth(to_core_scene(scene), 0.0, 0.0, *primary_ray(scene, 9, 9, 4, 4))
    assert truth.decision == "degenerate"


def test_exact_tier_limits_are_checked():
    with pytest.raises(ValueError, match="exact_pixels_per_block"):
        FrameParams(exact_pixels_per_block=-1)
    with pytest.raises(ValueError, match="exact_max_bits"):
        FrameParams(exact_max_bits=32)


# ---------------------------------------------------------------------------
# --explain, the CLI and the farm
# ---------------------------------------------------------------------------


def test_cli_explain_prints_the_exact_tiers_steps(tmp_path):
    spec = tmp_path / "whitney-handle.yaml"
    spec.write_text("objects:\n  - surface: \"x^2*z + y^2\"\n    clip_radius: 2\n"
                    "camera:\n  position: [5, 0, -0.7]\n  look_at: [0, 0, -0.7]\n")
    r = subprocess.run([sys.executable, "-m", "argand.cli", "render", str(spec), "--size", "9x9", "--explain", "4,4"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "exact tier" in out and "squarefree factors: degree 1 with multiplicity 2" in out
    assert "64 bits:" in out and f"ladder level {MULTIPLE} (exact: multiple root proven)" in out
    off = subprocess.run([sys.executable, "-m", "argand.cli", "render", str(spec), "--size", "9x9", "--explain", "4,4",
                          "--exact-per-block", "0"], capture_output=True, text=True)
    assert off.returncode == 0 and "exact tier" not in off.stdout


def test_the_farm_and_argand_render_give_the_same_frame_with_the_exact_tier(farm_parts, tmp_path):
    from argand.farm import tile_work
    from argand.media.frame_files import read_exr

    settings, _ = farm_parts
    job_id = submit(settings, "steiner", [0.0], 31, 31, 16)
    assert tile_work.run_tiles(settings, job_id, 0, list(range(4)), "w-test") == "rendered"
    names, farm_px = read_exr(settings.data_path / "store" / "jobs" / job_id / "frame_0000.exr")
    out = tmp_path / "cli"
    r = subprocess.run([sys.executable, "-m", "argand.cli", "render", "steiner", "--size", "31x31", "--tile", "16",
                        "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    cli_names, cli_px = read_exr(out / "frame_0000.exr")
    assert cli_names == names
    assert np.array_equal(farm_px.view(np.uint32), cli_px.view(np.uint32))
    esc = farm_px[..., names.index("escalation")]
    assert np.count_nonzero(esc == EXACT) > 0
    assert np.all(farm_px[..., names.index("status")] == 0)


def test_the_exact_tiers_work_on_a_ray_is_shared_by_the_bands_and_changes_no_answer():
    """A ray the exact tier solved (its exact polynomials, squarefree factors
    and root balls: argand.render.exact's ray cache) serves the other bands
    of the same frames: every band's frame with the cache filled by the
    others is the frame the band gets on an empty cache, to the bit, and
    the bands do send the same pixels to the tier (Whitney's umbrella at an
    odd size, whose centre row meets the double line)."""
    from argand.render import exact
    from argand.render.frames import render_bands
    from tests.render.test_bands import assert_same_bits

    scene = load_scene("whitney")
    params = [FrameParams(sigma=s, delta=d, width=63, height=63) for s, d in
              ((0.0, 0.0), (0.0, math.pi / 18), (0.0, math.pi / 9), (0.3, 0.5), (0.0, math.pi))]
    exact._rays.clear()
    together = render_bands(scene, params, tile=32, workers=1)
    assert len(exact._rays) > 0
    for p, frame in zip(params, together):
        exact._rays.clear()
        alone = render_frame(scene, p, tile=32, workers=1)
        assert_same_bits(frame, alone, f"sigma={p.sigma} delta={p.delta}")
    tier = np.stack([np.asarray(f.aovs["escalation"]) >= EXACT for f in together])
    assert int((tier.sum(axis=0) >= 2).sum()) >= 5, int(tier.sum())


def test_a_cached_ray_answers_as_a_fresh_one_for_any_band(monkeypatch):
    """decide_pixel on a ray whose work another band's call cached answers
    exactly what it answers on an empty cache (its explanation included),
    for every pair of bands, on the rays a sweep of Whitney's umbrella at an
    odd size sends to the exact tier."""
    from argand.render import exact, frames
    from argand.render.frames import render_bands

    calls: list[tuple[dict, dict]] = []

    def spy(frame, query):
        calls.append((frame, dict(query)))
        return exact.decide_pixel(frame, query)

    monkeypatch.setattr(frames, "decide_pixel", spy)
    bands = [(0.0, 0.0), (0.0, 0.3), (0.2, 0.9), (1.0, 1.5)]
    render_bands(load_scene("whitney"), [FrameParams(sigma=s, delta=d, width=63, height=63) for s, d in bands],
                 tile=32, workers=1)
    by_band = {}
    for frame, _query in calls:
        by_band.setdefault((frame["sigma"], frame["delta"]), {k: v for k, v in frame.items() if not k.startswith("_")})
    rays = {}
    for _frame, query in calls:
        rays.setdefault((tuple(query["origin"]), tuple(query["direction"])), query)
    assert len(by_band) >= 2 and len(rays) >= 8, (len(by_band), len(rays))
    queries = list(rays.values())
    for k, query in enumerate(queries[:8]):
        query = dict(query, explain=k % 2 == 0)
        others = [queries[(k + 1) % len(queries)], queries[(k + 5) % len(queries)]]
        for a in by_band.values():
            exact._rays.clear()
            fresh = exact.decide_pixel(dict(a), query)
            for b in by_band.values():
                exact._rays.clear()
                for other in others:  # (other rays from the same eye first,
                    exact.decide_pixel(dict(b), other)
                exact.decide_pixel(dict(b), query)  # then this one, by another band)
                assert exact.decide_pixel(dict(a), query) == fresh, (a["sigma"], a["delta"], b["sigma"], b["delta"])
