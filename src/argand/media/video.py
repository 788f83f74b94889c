"""The animation as MP4: H.264 in yuv420p (what every browser plays),
through PyAV, whose wheels ship FFmpeg with libx264.

yuv420p halves the chroma in both directions, so H.264 wants even sides: an
odd frame gets one more row or column, a copy of its last (the picture is
not scaled)."""

from __future__ import annotations

import math
import tempfile
from fractions import Fraction
from pathlib import Path
from typing import Sequence

import numpy as np

#: x264's constant rate factor: 18 is visually lossless for these frames
#: (smooth shading, sharp silhouettes); the default preset.
CRF = 18
CODEC = "libx264"
PIXEL_FORMAT = "yuv420p"


def even_frame(rgb: np.ndarray) -> np.ndarray:
    """(h, w, 3) uint8 -> the same with even sides (the last row or column repeated)."""
    h, w = rgb.shape[:2]
    return np.pad(rgb, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") if (h % 2 or w % 2) else rgb


class Mp4Encoder:
    """Frames in, one at a time, an MP4 out (H.264, yuv420p, ``fps`` frames
    per second, moov atom first so a browser plays it while it downloads):
    nothing but the encoder's own look-ahead is kept in memory. ``target``:
    a file path (moving the moov atom first reopens the file by name, so not
    a file object). Use as a context manager, or
    call close(); ValueError for a bad fps or a frame of another shape or
    type than the first."""

    def __init__(self, target, fps: float = 8.0) -> None:
        import av

        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps}")
        self._av, self.fps, self.frames = av, fps, 0
        self.container = av.open(str(target), mode="w", format="mp4", options={"movflags": "+faststart"})
        self.stream = None
        self.shape: tuple[int, ...] | None = None

    def add(self, rgb: np.ndarray) -> None:
        k = self.frames
        if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"frame {k}: expected a (h, w, 3) uint8 array, got {getattr(rgb, 'shape', None)} "
                             f"{getattr(rgb, 'dtype', type(rgb).__name__)}")
        if self.stream is None:
            self.shape = rgb.shape
            h, w = even_frame(rgb).shape[:2]
            self.stream = self.container.add_stream(CODEC, rate=Fraction(self.fps).limit_denominator(1000))
            self.stream.width, self.stream.height, self.stream.pix_fmt = w, h, PIXEL_FORMAT
            self.stream.options = {"crf": str(CRF)}
        elif rgb.shape != self.shape:
            raise ValueError(f"frame {k} is {rgb.shape}, frame 0 is {self.shape}")
        picture = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(even_frame(rgb)), format="rgb24")
        self.container.mux(self.stream.encode(picture))
        self.frames += 1

    def close(self) -> None:
        if self.container is None:
            return
        try:
            if self.stream is None:
                raise ValueError("no frames to encode (empty list)")
            self.container.mux(self.stream.encode(None))
        finally:
            self.container.close()
            self.container = None

    def __enter__(self) -> "Mp4Encoder":
        return self

    def __exit__(self, kind, value, tb) -> None:
        if kind is None:
            self.close()
        elif self.container is not None:
            self.container.close()
            self.container = None


def encode_mp4(frames: Sequence[np.ndarray], fps: float = 8.0) -> bytes:
    """(h, w, 3) uint8 frames, all the same size -> the MP4's bytes (see Mp4Encoder)."""
    if len(frames) == 0:
        raise ValueError("no frames to encode (empty list)")
    with tempfile.TemporaryDirectory(prefix="argand-mp4-") as folder:
        path = Path(folder) / "animation.mp4"
        with Mp4Encoder(path, fps) as encoder:
            for frame in frames:
                encoder.add(frame)
        return path.read_bytes()
