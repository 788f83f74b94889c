"""(σ, δ) jobs: the grid of frames, the atlas over the whole
space σ ≥ 0, σ + δ ≤ π, the band rule's refusals, the preview order on a
grid, and the MP4 (decoded by PyAV, FFmpeg's own decoder)."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from argand.farm.planning import preview_order
from argand.render import BAND_RULE
from argand.frames.frame_set import BandRuleError, atlas_frames, atlas_grid, format_angle, frame_grid


def test_a_grid_is_every_pair_row_by_row():
    g = frame_grid([0.0, 0.5], [0.1, 0.2, 0.3])
    assert g.shape == (2, 3) and len(g) == 6 and g.is_grid
    assert [(p.sigma, p.delta) for p in g.points] == [(0.0, 0.1), (0.0, 0.2), (0.0, 0.3), (0.5, 0.1), (0.5, 0.2), (0.5, 0.3)]
    assert g.positions == [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]
    sweep = frame_grid([0.25], [0.0, 0.1])  # one sigma: a delta sweep, not a grid
    assert not sweep.is_grid and [p.delta_index for p in sweep.points] == [0, 1]


def test_pairs_outside_the_band_rule_are_named_with_the_rule():
    with pytest.raises(BandRuleError) as info:
        frame_grid([0.0, 2.0, 3.0], [0.5, 1.5])
    text = str(info.value)
    assert BAND_RULE in text and "3 of the 6 frames" in text
    for s, d in (("2", "1.5"), ("3", "0.5"), ("3", "1.5")):
        assert f"(σ = {s}, δ = {d})" in text
    assert "(σ = 0, δ = 0.5)" not in text and "(σ = 2, δ = 0.5)" not in text
    with pytest.raises(BandRuleError, match=r"^the frame breaks the band rule .*\(σ = -0.1, δ = 0\)"):
        frame_grid([-0.1], [0.0])
    # Angles as they were written: π fractions, not 17 digits.
    with pytest.raises(BandRuleError) as info:
        frame_grid([math.pi / 2], [2 * math.pi / 3])
    assert "(σ = π/2, δ = 2π/3)" in str(info.value) and "1.57" not in str(info.value)
    # π/3 and an ulp above 2π/3 read as π/3 + 2π/3, which keeps the rule: the message says why it breaks.
    with pytest.raises(BandRuleError) as info:
        frame_grid([math.pi / 3], [math.nextafter(2 * math.pi / 3, 4)])
    assert "(σ = π/3, δ = 2π/3) [σ + δ rounds above π in double precision" in str(info.value)
    with pytest.raises(BandRuleError, match=r"12 of the 12 frames .* and 7 more"):
        frame_grid([4.0, 5.0, 6.0], [0.0, 0.1, 0.2, 0.3])


def exact_sum_at_most_pi(s: float, d: float) -> bool:
    """sigma + delta <= pi decided on exact rationals (pi to 60 digits)."""
    import flint

    from tests.helpers.truth import Precision

    with Precision(200):
        exact = flint.arb(s) + flint.arb(d)  # arb(float) is exact; the sum too at 200 bits
        return bool(exact <= flint.arb.pi())  # pi's ball is far narrower than any gap here


@pytest.mark.parametrize("steps", [1, 2, 3, 5, 7, 12, 24, 36, 49])
def test_the_atlas_covers_the_triangle_and_keeps_the_rule(steps):
    g = atlas_grid(steps)
    assert len(g) == atlas_frames(steps) == steps * (steps + 1) // 2 and g.shape == (steps, steps)
    h = math.pi / steps
    assert g.sigmas[0] == 0.0 and g.deltas[-1] == math.pi
    for p in g.points:
        assert p.sigma_index + p.delta_index <= steps - 1
        assert p.sigma >= 0 and p.delta > 0
        # Independent truth: the exact sum is at most pi (not only C++'s test).
        assert exact_sum_at_most_pi(p.sigma, p.delta), (steps, p)
        assert abs(p.sigma - p.sigma_index * h) < 1e-12 and abs(p.delta - (p.delta_index + 1) * h) < 1e-12
        if p.sigma_index + p.delta_index < steps - 1:
            assert p.delta == g.deltas[p.delta_index]  # off the diagonal: the column's own value
        else:  # on it: at most a few ulps below
            assert 0 <= g.deltas[p.delta_index] - p.delta <= 4 * math.ulp(math.pi)
    rows = [sum(1 for p in g.points if p.sigma_index == i) for i in range(steps)]
    assert rows == list(range(steps, 0, -1))
    with pytest.raises(ValueError, match="steps >= 1"):
        atlas_grid(0)


def test_the_preview_order_on_a_grid_is_every_other_row_and_column_first():
    g = frame_grid([0.0, 0.1, 0.2, 0.3], [0.1, 0.2, 0.3, 0.4, 0.5])
    order = preview_order(len(g), positions=g.positions)
    assert sorted(order) == list(range(len(g)))
    first = order[: 3 * 2]  # rows 0, 2 by columns 0, 2, 4
    assert [g.positions[i] for i in first] == [(0, 0), (0, 2), (0, 4), (2, 0), (2, 2), (2, 4)]
    quarter = {g.positions[i] for i in order[:6]}
    assert all(r % 2 == 0 and c % 2 == 0 for r, c in quarter)
    # A sweep (one row or one column) keeps every fourth frame first.
    assert preview_order(9, positions=[(0, j) for j in range(9)]) == preview_order(9) == [0, 4, 8, 1, 5, 2, 6, 3, 7]
    assert preview_order(9, positions=[(i, 0) for i in range(9)]) == preview_order(9)
    a = atlas_grid(6)
    order = preview_order(len(a), positions=a.positions)
    assert sorted(order) == list(range(len(a)))


def test_a_grid_jobs_messages_go_out_in_its_preview_order():
    from argand.farm.planning import plan_runs, tile_rects

    for g in (frame_grid([0.0, 0.1, 0.2], [0.1, 0.2, 0.3, 0.4]), atlas_grid(5)):
        rects = tile_rects(64, 48, 16)
        by_frame = {f: list(range(len(rects))) for f in range(len(g))}
        runs = plan_runs(by_frame, len(g), rects, 64 * 48, 2, g.positions)
        assert list(dict.fromkeys(f for f, _ in runs)) == preview_order(len(g), positions=g.positions)
        assert sorted((f, t) for f, run in runs for t in run) == [(f, t) for f in range(len(g)) for t in range(len(rects))]


def test_angles_are_labelled_as_fractions_of_pi():
    assert [format_angle(v) for v in (0.0, math.pi, math.pi / 4, 2 * math.pi / 3, math.pi / 36, -math.pi / 9)] == \
        ["0", "π", "π/4", "2π/3", "π/36", "-π/9"]
    assert format_angle(0.3) == "0.300"
    assert format_angle(atlas_grid(7).points[6].delta) == "π"


@pytest.mark.parametrize("size", [(48, 40), (33, 21)])
def test_the_mp4_decodes_to_its_frames(size):
    import av

    from argand.media.video import encode_mp4

    w, h = size
    rng = np.random.default_rng(3)
    frames = []
    for k in range(7):  # smooth frames, each its own colour
        y, x = np.mgrid[0:h, 0:w]
        frames.append(np.stack([(x * 255 // w), (y * 255 // h), np.full_like(x, 30 * k)], -1).astype(np.uint8))
    frames[3] = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    data = encode_mp4(frames, fps=8.0)
    with av.open(io.BytesIO(data)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"
        assert float(stream.average_rate) == 8.0
        decoded = [f.to_ndarray(format="rgb24") for f in container.decode(stream)]
    even = (h + h % 2, w + w % 2)
    assert len(decoded) == 7 and all(d.shape == (*even, 3) for d in decoded)
    # Lossy, but each frame is its own: nearest to its source among all.
    for k, d in enumerate(decoded):
        err = [np.abs(d[:h, :w].astype(int) - f.astype(int)).mean() for f in frames]
        assert int(np.argmin(err)) == k and (k == 3 or err[k] < 4), (k, err)
    # The moov atom comes first (a browser plays while downloading).
    assert data.find(b"moov") < data.find(b"mdat")


def test_mp4_refuses_bad_input():
    from argand.media.video import encode_mp4

    with pytest.raises(ValueError, match="no frames"):
        encode_mp4([])
    with pytest.raises(ValueError, match="fps"):
        encode_mp4([np.zeros((4, 4, 3), np.uint8)], fps=0)
    with pytest.raises(ValueError, match="frame 1 is"):
        encode_mp4([np.zeros((4, 4, 3), np.uint8), np.zeros((4, 6, 3), np.uint8)])
    with pytest.raises(ValueError, match="frame 0: expected"):
        encode_mp4([np.zeros((4, 4), np.uint8)])
