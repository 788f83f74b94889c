"""GIF fragments and their splice, checked against independent decoders
(Pillow and OpenImageIO), and the animated WebP."""

from __future__ import annotations

import io

import numpy as np
import OpenImageIO as oiio
import pytest
from PIL import Image, ImageFilter, ImageSequence, features

from argand.media import gif

H, W = 96, 128


def gradient(h: int = H, w: int = W) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x * 255 // (w - 1), y * 255 // (h - 1), np.full_like(x, 128)], axis=-1).astype(np.uint8)


def shaded_disc(h: int = H, w: int = W, colour=(230, 120, 60)) -> np.ndarray:
    """A lit sphere on black (one hue, smooth shading)."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    r = 0.4 * min(h, w)
    nx, ny = (x - w / 2) / r, (y - h / 2) / r
    inside = nx**2 + ny**2 < 1
    nz = np.sqrt(np.clip(1 - nx**2 - ny**2, 0, 1))
    light = np.clip(-0.4 * nx - 0.5 * ny + 0.77 * nz, 0, 1)
    out = np.zeros((h, w, 3), np.uint8)
    out[inside] = (np.outer(0.15 + 0.85 * light[inside], colour) + 0.5).astype(np.uint8)
    return out


def noise(h: int = H, w: int = W) -> np.ndarray:
    return np.random.default_rng(7).integers(0, 256, (h, w, 3), dtype=np.uint8)


def flat(h: int = H, w: int = W, colour=(12, 200, 77)) -> np.ndarray:
    return np.broadcast_to(np.array(colour, np.uint8), (h, w, 3))  # not contiguous on purpose


def decode(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


IMAGES = [gradient(), shaded_disc(), noise(), flat(), gradient()[::-1, ::-1]]


@pytest.mark.parametrize("fps, loop", [(8.0, 0), (25.0, 3)])
def test_splice_decodes_frame_by_frame(tmp_path, fps, loop):
    fragments = [gif.encode_frame(img) for img in IMAGES]
    expected = [decode(f) for f in fragments]
    data = gif.splice(fragments, fps=fps, loop=loop)
    assert data[:6] == b"GIF89a" and data[-1] == 0x3B and not data[10] & 0x80  # no global table

    with Image.open(io.BytesIO(data)) as im:
        assert im.info["loop"] == loop
        frames, durations, disposals = [], [], []
        for frame in ImageSequence.Iterator(im):
            assert "transparency" not in frame.info
            frames.append(np.asarray(frame.convert("RGB")))
            durations.append(frame.info["duration"])
            disposals.append(frame.disposal_method)
    assert len(frames) == len(IMAGES)
    assert disposals == [1] * len(IMAGES)  # do not dispose
    assert durations == [round(100 / fps) * 10] * len(IMAGES)
    for k, (got, want) in enumerate(zip(frames, expected)):
        assert np.array_equal(got, want), f"Pillow frame {k}"

    path = tmp_path / "anim.gif"
    path.write_bytes(data)
    inp = oiio.ImageInput.open(str(path))
    assert inp, oiio.geterror()
    try:
        n = 0
        while inp.seek_subimage(n, 0):
            spec = inp.spec()
            assert (spec.width, spec.height) == (W, H)
            pixels = inp.read_image("uint8")
            assert pixels is not None, inp.geterror()
            assert np.array_equal(pixels[..., :3], expected[n]), f"OpenImageIO frame {n}"
            n += 1
    finally:
        inp.close()
    assert n == len(IMAGES)


def test_fragment_is_a_single_frame_gif_with_at_most_256_colours():
    data = gif.encode_frame(noise())
    with Image.open(io.BytesIO(data)) as im:
        assert im.format == "GIF" and im.mode == "P" and im.size == (W, H) and getattr(im, "n_frames", 1) == 1
        assert len(im.getcolors(256)) <= 256


def lit_wall(h: int = H, w: int = W) -> np.ndarray:
    """A ramp between two colours, lit from below (~24,000 colours)."""
    y, x = np.mgrid[0:h, 0:w, 0:1][:2]
    y, x = y / (h - 1), x / (w - 1)
    return (((1 - x) * [30, 60, 200] + x * [250, 180, 40]) * (0.6 + 0.4 * y) + 0.5).astype(np.uint8)


def channel_error(a: np.ndarray, b: np.ndarray, radius: int = 0) -> np.ndarray:
    """Mean absolute error per channel, after a box blur of ``radius``."""
    if radius:
        a, b = (np.asarray(Image.fromarray(np.ascontiguousarray(x)).filter(ImageFilter.BoxBlur(radius))) for x in (a, b))
    return np.abs(a.astype(int) - b.astype(int)).mean(axis=(0, 1))


def test_quantization_error_is_small_on_smooth_images():
    disc = shaded_disc(256, 256)
    assert channel_error(decode(gif.encode_frame(disc)), disc).max() < 3
    # Dithered: pixel by pixel the error is a few levels (no 256-colour
    # palette gets under ~4 on a full red-green gradient), but seen at a
    # 5x5 pixel scale, as an eye sees it, there are no bands.
    for img in (gradient(256, 256), lit_wall(256, 256)):
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20_000
        got = decode(gif.encode_frame(img))
        assert channel_error(got, img).max() < 8
        assert channel_error(got, img, radius=2).max() < 1.5


@pytest.mark.parametrize("colours", [1, 2, 200, 256])
def test_images_of_at_most_256_colours_round_trip_exactly(colours):
    palette = np.random.default_rng(colours).integers(0, 256, (colours, 3), dtype=np.uint8)
    img = palette[np.random.default_rng(4).integers(0, colours, (H, W))]
    assert len(np.unique(img.reshape(-1, 3), axis=0)) == colours
    assert np.array_equal(decode(gif.encode_frame(img)), img)
    assert np.array_equal(decode(gif.encode_frame(flat())), flat())


@pytest.mark.parametrize("bad, message", [
    (np.zeros((H, W, 3), np.float32), "uint8"),
    (np.zeros((H, W), np.uint8), "shape"),
    (np.zeros((H, W, 4), np.uint8), "shape"),
    (np.zeros((0, W, 3), np.uint8), "shape"),
    ([[[0, 0, 0]]], "uint8"),
])
def test_encode_frame_rejects_bad_input(bad, message):
    with pytest.raises(ValueError, match=message):
        gif.encode_frame(bad)


def test_splice_rejects_bad_fragments():
    good = gif.encode_frame(gradient())
    with pytest.raises(ValueError, match="empty"):
        gif.splice([])
    with pytest.raises(ValueError, match=r"fragment 1 is 64x64, fragment 0 is 128x96"):
        gif.splice([good, gif.encode_frame(gradient(64, 64))])
    with pytest.raises(ValueError, match=r"fragment 2 is not a valid GIF: not a GIF"):
        gif.splice([good, good, b"\x89PNG\r\n\x1a\n" + bytes(40)])
    with pytest.raises(ValueError, match=r"fragment 0 is not a valid GIF"):
        gif.splice([b""])
    with pytest.raises(ValueError, match=r"fragment 1 is not a valid GIF: truncated"):
        gif.splice([good, good[: len(good) // 2]])
    with pytest.raises(ValueError, match="fps"):
        gif.splice([good], fps=0)


def test_webp_animation():
    frames = IMAGES[:4]
    data = gif.encode_animation_webp(frames, fps=10)
    if not features.check("webp"):
        assert data is None
        return
    assert data is not None
    with Image.open(io.BytesIO(data)) as im:
        assert im.format == "WEBP" and im.n_frames == len(frames) and im.size == (W, H)
        assert im.info.get("loop") == 0
        decoded = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
    assert len(decoded) == len(frames)
    # lossy, but recognisably the same pictures (the smooth ones closely)
    assert np.abs(decoded[0].astype(int) - frames[0]).mean() < 6
    assert np.abs(decoded[3].astype(int) - frames[3]).mean() < 3
    with pytest.raises(ValueError, match="frame 1"):
        gif.encode_animation_webp([gradient(), gradient(64, 64)])
