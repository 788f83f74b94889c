"""False-colour PNGs of a frame's channels, for the web front end: made from
the frame's EXR on first request, then kept beside it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from argand.render.frames import STATUS_NAMES
from argand.media.frame_files import read_exr, write_png

#: The pictures of a frame the front end shows: channel -> the EXR channel
#: it is drawn from (beauty is the frame's PNG itself).
PREVIEW_CHANNELS = {"beauty": None, "modulus": "Z", "argument": "arg", "status": "status",
                    "certified_share": "certified_share"}

#: The status channel's colour of each pixel status (argand.render's
#: STATUS_NAMES): certified, cluster, unverified, undecided.
STATUS_COLOURS = {"certified": (46, 160, 67), "cluster": (230, 180, 30), "unverified": (215, 60, 50),
                  "undecided": (120, 90, 200)}
_STATUS_RGB = np.array([STATUS_COLOURS[STATUS_NAMES[code]] for code in sorted(STATUS_NAMES)], dtype=np.uint8)
BACKGROUND = (24, 24, 24)
#: A pixel that hit nothing and is certified so (the empty background).
EMPTY = (24, 24, 28)


def _ramp(v: np.ndarray, hit: np.ndarray, channel: str) -> np.ndarray:
    """0..1 along the blue -> green -> red ramp: |arg| / pi, or the modulus
    between its 2nd and 98th percentile over the hit pixels."""
    if channel == "argument":
        t = np.abs(v) / np.pi
    elif channel == "certified_share":
        t = 1.0 - v  # all samples certified: blue; none: red
    else:
        finite = hit & np.isfinite(v)
        lo, hi = (np.percentile(v[finite], [2, 98]) if finite.any() else (0.0, 1.0))
        t = np.clip((v - lo) / max(hi - lo, 1e-12), 0, 1)
    return np.nan_to_num(t)


def channel_png(exr: Path, channel: str, out: Path) -> None:
    """A false-colour PNG of one channel of a frame."""
    if PREVIEW_CHANNELS.get(channel) is None:
        raise ValueError(f"a channel preview is one of {', '.join(c for c, v in PREVIEW_CHANNELS.items() if v)}")
    names, px = read_exr(exr)
    hit = px[..., names.index("A")] > 0
    v = px[..., names.index(PREVIEW_CHANNELS[channel])]
    if channel == "status":
        st = v.astype(int).clip(0, len(STATUS_NAMES) - 1)
        rgb = _STATUS_RGB[st]
        rgb[~hit & (st == 0)] = EMPTY
    else:
        t = _ramp(v, hit, channel)
        ramp = np.stack([t, 1 - np.abs(2 * t - 1), 1 - t], axis=-1)
        rgb = np.where(hit[..., None], (40 + 215 * ramp).astype(np.uint8), np.array(BACKGROUND, np.uint8))
    write_png(np.ascontiguousarray(rgb.astype(np.uint8)), out)
