"""GIF animations without a serial encode at the end of a job: each frame is
encoded alone when it is assembled (a "fragment", ``encode_frame``), and the
animation is spliced from the fragments' bytes (``splice``: no pixel is
re-encoded). Also an animated WebP through Pillow. numpy and Pillow only."""

from __future__ import annotations

import io
import math
import struct
from typing import Sequence

import numpy as np
from PIL import Image, features

#: Quantization: a median-cut palette of a strided sample (at most
#: SAMPLE x SAMPLE pixels), then every pixel mapped to it with Floyd-Steinberg
#: dithering. Without dithering smooth shading shows bands of flat colour;
#: Pillow's FASTOCTREE is faster (~3.5 ms at 512x512) but bands badly, and a
#: full median cut takes ~25-100 ms. Images of at most 256 colours are exact.
SAMPLE = 32


def _check_rgb(rgb: np.ndarray, what: str = "frame") -> None:
    if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8:
        raise ValueError(f"{what}: expected a uint8 numpy array, got {getattr(rgb, 'dtype', type(rgb).__name__)}")
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[0] == 0 or rgb.shape[1] == 0:
        raise ValueError(f"{what}: expected shape (h, w, 3) with h, w > 0, got {rgb.shape}")


def _rgb24(rgb: np.ndarray) -> np.ndarray:
    c = rgb.astype(np.uint32)
    return (c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]


def encode_frame(rgb: np.ndarray) -> bytes:
    """(h, w, 3) uint8 -> a complete single-frame GIF (a fragment for
    ``splice``), at most 256 colours (exact when the image has no more)."""
    _check_rgb(rgb)
    rgb = np.ascontiguousarray(rgb)
    image = Image.fromarray(rgb)
    colours = image.getcolors(256)  # None (quickly) when there are more
    if colours is not None:
        palette = np.array([c for _, c in colours], np.uint8)
        lut = np.zeros(1 << 24, np.uint8)  # 24-bit colour -> palette index
        lut[_rgb24(palette)] = np.arange(len(palette))
        image = Image.frombytes("P", image.size, lut[_rgb24(rgb)].tobytes())
        image.putpalette(palette.tobytes())
    else:
        step = -(-max(rgb.shape[:2]) // SAMPLE)
        palette = Image.fromarray(np.ascontiguousarray(rgb[::step, ::step])).quantize(256, Image.Quantize.MEDIANCUT)
        image = image.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG)
    out = io.BytesIO()
    image.save(out, "GIF")
    return out.getvalue()


def _sub_blocks(data: bytes, i: int) -> int:
    """The offset just past the data sub-blocks starting at ``i``."""
    while (n := data[i]) != 0:
        i += n + 1
    return i + 1


def _parse(data: bytes) -> tuple[int, int, list[tuple[bytes, bytes, bytes]]]:
    """A GIF -> (width, height, [(image descriptor, colour table, LZW data)])
    with each image's colour table (its own or the global one) and the
    descriptor's packed field saying so. Extensions are dropped."""
    if data[:6] not in (b"GIF87a", b"GIF89a"):
        raise ValueError("not a GIF (no GIF87a/GIF89a header)")
    width, height, packed = struct.unpack_from("<HHB", data, 6)
    i, table = 13, b""
    if packed & 0x80:
        table = data[i:i + 3 * (2 << (packed & 7))]
        i += len(table)
    images = []
    while True:
        kind = data[i]
        if kind == 0x3B:
            return width, height, images
        if kind == 0x21:  # extension: label, then sub-blocks
            i = _sub_blocks(data, i + 2)
        elif kind == 0x2C:
            left, top, w, h, flags = struct.unpack_from("<HHHHB", data, i + 1)
            i += 10
            if flags & 0x80:
                own = data[i:i + 3 * (2 << (flags & 7))]
                i += len(own)
            elif table:  # global table -> local: flag, sort bit, size bits
                own, flags = table, (flags & 0x40) | 0x80 | ((packed & 0x08) << 2) | (packed & 7)
            else:
                raise ValueError("an image has no colour table")
            if left + w > width or top + h > height:
                raise ValueError(f"an image of {w}x{h} at ({left}, {top}) is outside the {width}x{height} screen")
            end = _sub_blocks(data, i + 1)
            images.append((struct.pack("<BHHHHB", 0x2C, left, top, w, h, flags), own, data[i:end]))
            i = end
        else:
            raise ValueError(f"unexpected block 0x{kind:02X} at byte {i}")


def splice(fragments: Sequence[bytes], fps: float = 8.0, loop: int = 0) -> bytes:
    """Fragments from ``encode_frame`` (all the same size) -> an animated
    GIF89a, one frame per fragment, each with its own palette as a local
    colour table; ``loop`` 0 loops forever. Raises ValueError naming the
    fragment that is not a one-image GIF or differs in size."""
    if len(fragments) == 0:
        raise ValueError("no fragments to splice (empty list)")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps}")
    delay = round(100 / fps)
    if not 0 <= delay <= 0xFFFF or not 0 <= loop <= 0xFFFF:
        raise ValueError(f"delay {delay} (from fps {fps}) and loop {loop} must be within 0..65535")
    parts, size = [], None
    for k, fragment in enumerate(fragments):
        try:
            width, height, images = _parse(bytes(fragment))
        except (ValueError, IndexError, struct.error) as e:
            reason = "truncated" if not isinstance(e, ValueError) else str(e)
            raise ValueError(f"fragment {k} is not a valid GIF: {reason}") from None
        if len(images) != 1:
            raise ValueError(f"fragment {k} has {len(images)} images, expected one")
        if size is None:
            size = (width, height)
        elif (width, height) != size:
            raise ValueError(f"fragment {k} is {width}x{height}, fragment 0 is {size[0]}x{size[1]}")
        # graphic control extension: disposal 1 (do not dispose), no transparency
        parts.append(struct.pack("<BBBBHBB", 0x21, 0xF9, 4, 1 << 2, delay, 0, 0))
        parts.extend(images[0])
    head = b"GIF89a" + struct.pack("<HHBBB", *size, 0, 0, 0)
    netscape = b"\x21\xFF\x0BNETSCAPE2.0" + struct.pack("<BBHB", 3, 1, loop, 0)
    return b"".join([head, netscape, *parts, b"\x3B"])


def encode_animation_webp(frames: Sequence[np.ndarray], fps: float = 8.0) -> bytes | None:
    """(h, w, 3) uint8 frames -> a looping, lossy (quality 80) animated WebP,
    or None when this Pillow has no WebP support."""
    if not features.check("webp"):
        return None
    if len(frames) == 0:
        raise ValueError("no frames to encode (empty list)")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps}")
    for k, frame in enumerate(frames):
        _check_rgb(frame, f"frame {k}")
        if frame.shape != frames[0].shape:
            raise ValueError(f"frame {k} is {frame.shape}, frame 0 is {frames[0].shape}")
    images = [Image.fromarray(np.ascontiguousarray(f), "RGB") for f in frames]
    out = io.BytesIO()
    images[0].save(out, "WEBP", save_all=True, append_images=images[1:], duration=round(1000 / fps),
                   loop=0, lossless=False, quality=80, method=0)
    return out.getvalue()
