"""The atlas laid out where the roots are (issue 24, item 5): cuts from the
histogram of the roots' arguments, checked against the definition computed
here independently; frames of the whole triangle; and on real scenes, more
frames that show something than the uniform atlas of the same size."""

from __future__ import annotations

import math

import numpy as np
import pytest

from argand.core import _core
from argand.frames.frame_set import ROOT_SHARE, FrameSet, atlas_cuts, atlas_grid, root_atlas_cuts
from argand.render import FrameParams
from argand.render.frames import render_bands
from argand.render.arguments import argument_histogram
from argand.render.convert import to_core_scene
from argand.scene import load_scene

PI = math.pi


def _mixed(theta: float, edges: np.ndarray, counts: np.ndarray, share: float) -> float:
    """The definition: (1 - share) θ/π + share R(θ), R the roots' share below θ,
    linear within each bin (by hand, bin by bin)."""
    total = counts.sum()
    below = 0.0
    for lo, hi, c in zip(edges[:-1], edges[1:], counts):
        if theta >= hi:
            below += c
        elif theta > lo:
            below += c * (theta - lo) / (hi - lo)
    return (1 - share) * theta / PI + share * below / total


def _histograms(rng, n: int):
    for _ in range(n):
        bins = int(rng.integers(1, 120))
        edges = np.linspace(0.0, PI, bins + 1)
        kind = rng.integers(0, 4)
        if kind == 0:  # roots everywhere
            counts = rng.integers(0, 50, bins).astype(float)
        elif kind == 1:  # one narrow crowd
            counts = np.zeros(bins)
            counts[rng.integers(0, bins)] = float(rng.integers(1, 10_000))
        elif kind == 2:  # a few bins
            counts = np.zeros(bins)
            counts[rng.choice(bins, size=min(bins, 3), replace=False)] = rng.integers(1, 500, min(bins, 3))
        else:  # heavy tails: most roots near 0 and near π
            counts = np.zeros(bins)
            counts[0], counts[-1] = rng.integers(100, 5000, 2)
            counts[bins // 2] = float(rng.integers(0, 5))
        yield edges, counts


@pytest.mark.parametrize("seed", range(4))
def test_cuts_meet_their_definition_and_increase_from_0_to_pi(seed):
    rng = np.random.default_rng(seed)
    for edges, counts in _histograms(rng, 100):
        steps = int(rng.integers(1, 30))
        cuts = atlas_cuts(edges, counts, steps)
        assert len(cuts) == steps + 1 and cuts[0] == 0.0 and cuts[-1] == PI
        assert all(a < b for a, b in zip(cuts, cuts[1:]))
        if counts.sum() == 0:
            assert cuts == pytest.approx(list(np.linspace(0, PI, steps + 1)), abs=1e-15)
            continue
        for k, c in enumerate(cuts):
            assert _mixed(c, edges, counts, ROOT_SHARE) == pytest.approx(k / steps, abs=1e-9), (k, steps)


def test_an_arc_holding_the_roots_gets_most_cuts():
    edges = np.linspace(0.0, PI, 91)
    counts = np.zeros(90)
    counts[30:45] = 100.0  # every root between π/3 and π/2
    for steps in (4, 8, 12, 30):
        cuts = np.array(atlas_cuts(edges, counts, steps))
        inside = np.sum((cuts > PI / 3) & (cuts < PI / 2))
        # The arc holds all roots and a sixth of [0, π]: about steps (0.75 + 0.25/6) cuts.
        assert inside >= math.floor(steps * (ROOT_SHARE + (1 - ROOT_SHARE) / 6)) - 1, (steps, cuts)


def test_real_roots_at_0_and_pi_take_no_cuts():
    """Roots proven real sit at arguments exactly 0 and π, where every atlas
    cuts: they leave the cuts uniform, where spreading them over their bin
    would crowd cuts into it."""
    edges = np.linspace(0.0, PI, 91)
    counts = np.zeros(90)
    counts[0], counts[-1] = 700.0, 20.0
    cuts = atlas_cuts(edges, counts, 6, at_zero=700, at_pi=20)
    assert cuts == pytest.approx(list(np.linspace(0, PI, 7)), abs=1e-15)
    assert atlas_cuts(edges, counts, 6)[1] < edges[1]  # (not left out: crowded into the first bin)


def test_bad_histograms_and_steps_are_refused():
    edges = np.linspace(0, PI, 5)
    for bad in (dict(edges=edges, counts=[1, 2, 3]), dict(edges=edges, counts=[1, -1, 0, 0]),
                dict(edges=edges[::-1], counts=[1, 1, 1, 1])):
        with pytest.raises(ValueError):
            atlas_cuts(bad["edges"], bad["counts"], 4)
    for steps in (0, -1, 2.5, True):
        with pytest.raises(ValueError):
            atlas_cuts(edges, [1, 1, 1, 1], steps)
    with pytest.raises(ValueError, match="cuts"):
        atlas_grid(3, [0.0, 1.0, 1.0, PI])
    with pytest.raises(ValueError, match="cuts"):
        atlas_grid(3, [0.0, 1.0, PI])
    with pytest.raises(ValueError, match="atlas"):
        FrameSet.from_axes(deltas=[0.1], atlas_cuts=[0.0, PI])


@pytest.mark.parametrize("steps", [1, 2, 5, 13])
def test_an_atlas_on_cuts_holds_every_band_between_two_cuts(steps):
    rng = np.random.default_rng(steps)
    inner = np.sort(rng.uniform(0, PI, steps - 1))
    cuts = [0.0, *inner.tolist(), PI]
    grid = atlas_grid(steps, cuts)
    assert len(grid) == steps * (steps + 1) // 2 and grid.sigmas == tuple(cuts[:-1])
    bands = set()
    for p in grid.points:
        end = cuts[p.sigma_index + p.delta_index + 1]
        assert p.sigma == cuts[p.sigma_index]
        assert abs(p.sigma + p.delta - end) <= 4 * math.ulp(PI)  # the band [c_i, c_{i+j+1}]
        assert _core.band_rule_holds(p.sigma, p.delta)
        bands.add((p.sigma_index, p.sigma_index + p.delta_index + 1))
    assert bands == {(i, k) for i in range(steps) for k in range(i + 1, steps + 1)}
    # The uniform atlas is the same rule on the uniform cuts.
    uniform = atlas_grid(steps)
    on_linspace = atlas_grid(steps, [float(v) for v in np.linspace(0, PI, steps + 1)])
    for a, b in zip(uniform.points, on_linspace.points):
        assert (a.sigma_index, a.delta_index, a.sigma) == (b.sigma_index, b.delta_index, b.sigma)
        assert abs(a.delta - b.delta) <= 4 * math.ulp(PI)


def _distinct_pictures(scene, grid: FrameSet, side: int) -> tuple[int, int]:
    params = [FrameParams(sigma=p.sigma, delta=p.delta, width=side, height=side) for p in grid.points]
    frames = render_bands(scene, params, workers=1)
    shown = [f for f in frames if np.any(np.isfinite(f.aovs["Z"]))]
    pictures = {np.isfinite(f.aovs["Z"]).tobytes() for f in frames}
    return len(shown), len(pictures)


@pytest.mark.parametrize("name", ["whitney", "steiner", "bicube"])
def test_the_roots_atlas_shows_more_than_the_uniform_one(name):
    """Whitney's umbrella's complex roots all lie at |arg| below about π/6,
    so most of the uniform atlas is empty; cut where the roots are, the same
    number of frames shows the surface more often and in more different
    pictures (which pixels hit)."""
    side, steps = 40, 6
    scene = load_scene(name)
    cuts = root_atlas_cuts(to_core_scene(scene), side, side, steps)
    shown_u, pictures_u = _distinct_pictures(scene, atlas_grid(steps), side)
    shown_r, pictures_r = _distinct_pictures(scene, atlas_grid(steps, cuts), side)
    assert shown_r >= shown_u and pictures_r > pictures_u, (shown_u, pictures_u, shown_r, pictures_r)


def test_the_histogram_counts_the_real_roots_at_0():
    h = argument_histogram(to_core_scene(load_scene("bicube")), 32, 32, grid=16)
    assert 0 < h["at_zero"] <= h["counts"][0] and h["at_pi"] <= h["counts"][-1]
    assert sum(h["counts"]) == h["roots"]
