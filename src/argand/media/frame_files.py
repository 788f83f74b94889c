"""Frame files through OpenImageIO: EXR with every AOV, a PNG preview and
the frame's figures as JSON. (Animations: argand.media.gif.)"""

from __future__ import annotations

import json
from pathlib import Path
import numpy as np

from argand.media.atomic import atomic_path, write_atomic
from argand.render.frames import INTERLEAVED_CHANNELS, FrameResult, interleave

EXR_CHANNELS = INTERLEAVED_CHANNELS


def _oiio():
    import OpenImageIO as oiio

    return oiio


def _srgb_lut(n: int = 65536) -> np.ndarray:
    """8-bit sRGB of the linear values k / (n - 1), by the exact formula."""
    v = np.linspace(0.0, 1.0, n)
    srgb = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)
    return (srgb * 255.0 + 0.5).astype(np.uint8)


_SRGB_LUT = _srgb_lut()


def to_srgb8(rgba: np.ndarray) -> np.ndarray:
    """Linear RGB -> 8-bit sRGB (the PNG preview; alpha dropped: misses show
    the scene's background). Through a 65536-entry table: the linear value
    is rounded to 1/65535 first, which moves a pixel by one 8-bit step only
    where the exact value lies within 0.03 steps of a rounding boundary, and
    is 4 times faster than the formula per pixel."""
    rgb = np.clip(rgba[..., :3], 0.0, 1.0)
    idx = (rgb * 65535.0 + 0.5).astype(np.uint16)
    return _SRGB_LUT[idx]


def exr_pixels(result: FrameResult) -> np.ndarray:
    """(h, w, len(EXR_CHANNELS)) float32 in the order of EXR_CHANNELS."""
    return interleave(result.rgba, result.aovs)


#: EXR compressions offered (lossless ones), and the default: "zip" keeps
#: files about 3.6 times smaller than "none" for about twice the encoding
#: time, and every OpenEXR reader opens it (docs/bench/farm.md).
EXR_COMPRESSIONS = ("none", "rle", "zip", "zips", "piz")
EXR_COMPRESSION = "zip"
#: Zstandard: about half the size and, at level 1 ("zstd:1"), about half the
#: encoding time of "zip" for Argand's frames, but only OpenEXR 3.5 (2025)
#: and later can read it, so it is offered, not the default.
EXR_ZSTD_OPENEXR = (3, 5)
#: Compression levels that ``name:level`` accepts.
_EXR_LEVELS = {"zip": range(1, 10), "zips": range(1, 10), "zstd": range(1, 23)}
#: PNG previews: zlib level 1 (level 6 makes files 1.5 times smaller and
#: takes 2.6 times longer) and the "sub" filter alone: libpng's adaptive
#: choice among all five filters takes twice as long for files within a few
#: percent of the same size (filter "none" is faster still, but shaded and
#: hue-coloured frames grow by up to 40%).
PNG_LEVEL = 1
PNG_FILTER_SUB = 16  # PNG_FILTER_SUB in png.h, OpenImageIO's "png:filter"


def openexr_version() -> tuple[int, ...]:
    """The OpenEXR version inside OpenImageIO, e.g. (3, 5, 2); () if unknown."""
    import re

    m = re.search(r"openexr:OpenEXR (\d+)\.(\d+)(?:\.(\d+))?", _oiio().get_string_attribute("library_list"))
    return tuple(int(g) for g in m.groups() if g is not None) if m else ()


def exr_compressions() -> tuple[str, ...]:
    """The compressions this installation writes: EXR_COMPRESSIONS, and
    "zstd" where OpenImageIO's OpenEXR has it (an older one would silently
    write "zip" instead)."""
    return EXR_COMPRESSIONS + (("zstd",) if openexr_version() >= EXR_ZSTD_OPENEXR else ())


def check_exr_compression(value: str) -> str:
    """``value`` ("zip", "zstd:1", ...) if this installation writes it, else
    a ValueError that names what it accepts."""
    name, sep, level = value.partition(":")
    offered = exr_compressions()
    if name not in offered:
        why = ""
        if name == "zstd":  # a real compression this installation's OpenEXR lacks
            why = (f" (zstd needs OpenEXR {'.'.join(map(str, EXR_ZSTD_OPENEXR))} in OpenImageIO; "
                   f"this one has {'.'.join(map(str, openexr_version())) or 'an unknown version'})")
        raise ValueError(f"EXR compression must be one of {', '.join(offered)}, got {value!r}{why}")
    if sep:
        levels = _EXR_LEVELS.get(name)
        if levels is None:
            raise ValueError(f"EXR compression {name!r} takes no level, got {value!r}")
        if not (level.isdigit() and int(level) in levels):
            raise ValueError(f"EXR compression level of {name!r} must be {levels.start}..{levels.stop - 1}, got {value!r}")
    return value


def write_exr(result: FrameResult, path: Path, pixels: np.ndarray | None = None,
              compression: str = EXR_COMPRESSION) -> None:
    """``pixels``: the (h, w, len(EXR_CHANNELS)) buffer when the caller assembled it already
    (else it is stacked from the result)."""
    oiio = _oiio()
    h, w = result.rgba.shape[:2]
    spec = oiio.ImageSpec(w, h, len(EXR_CHANNELS), "float")
    spec.channelnames = EXR_CHANNELS
    spec.alpha_channel = 3
    spec.z_channel = 4
    spec.attribute("compression", compression)
    # The frame's (sigma, delta), exactly the doubles rendered: as their
    # shortest round-trip text (float(text) gives them back), since a float
    # attribute is single precision and OpenImageIO's Python binding does
    # not write double attributes.
    for key, value in (("argand:sigma", result.params.sigma), ("argand:delta", result.params.delta)):
        spec.attribute(key, repr(float(value)))
    spec.attribute("argand:certified_share", float(result.certified_share))
    spec.attribute("argand:samples", int(result.params.samples))  # per pixel (the certified_share AOV counts them)
    for key, value in result.params.engine.metadata().items():  # how the engine computed the frame
        spec.attribute(key, value)
    _write(oiio, path, spec, exr_pixels(result) if pixels is None else pixels)


def write_png(pixels: np.ndarray, path: Path, level: int = PNG_LEVEL) -> None:
    oiio = _oiio()
    h, w = pixels.shape[:2]
    spec = oiio.ImageSpec(w, h, pixels.shape[2], "uint8")
    spec.attribute("png:compressionLevel", int(level))
    spec.attribute("png:filter", PNG_FILTER_SUB)
    _write(oiio, path, spec, pixels)


#: The last 12 bytes of every PNG: the IEND chunk (length 0, type, CRC).
PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"


def _write(oiio, path: Path, spec, pixels: np.ndarray) -> None:
    # Whole or not at all (argand.media.atomic): readers never see half a frame.
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(path.suffix.lstrip("."))  # (tmp may have no suffix: the format is path's)
        if out is None or not out.open(str(tmp), spec):
            raise OSError(f"cannot write {path}: {oiio.geterror()}")
        ok = out.write_image(pixels)
        out.close()
        if not ok:
            raise OSError(f"cannot write {path}: {out.geterror()}")
        if path.suffix.lower() == ".png":
            _check_png_end(tmp, path)


def _check_png_end(tmp: Path, path: Path) -> None:
    """OpenImageIO's PNG writer (libpng on stdio) reports no error when the
    disk fills under it, and leaves a cut file: one that does not end with
    its IEND chunk is refused here (ENOSPC where the disk has no room left,
    so the API answers 507), before the rename would publish it."""
    import errno
    import shutil

    with open(tmp, "rb") as f:
        f.seek(0, 2)
        size = f.tell()
        f.seek(max(0, size - len(PNG_END)))
        whole = f.read() == PNG_END
    if not whole:
        full = shutil.disk_usage(path.parent).free < (1 << 20)
        code = errno.ENOSPC if full else errno.EIO
        raise OSError(code, f"{path.name} was cut short while it was written ({size} bytes)", str(path))


#: A frame's files: every AOV (EXR), the picture (PNG, sRGB), its figures (JSON).
FRAME_FILES = ("exr", "png", "json")


def frame_file_name(index: int, kind: str) -> str:
    """frame_NNNN.exr|.png|.json: the names `argand render` and the farm's store give a frame's files."""
    if kind not in FRAME_FILES:
        raise ValueError(f"a frame file is one of {', '.join(FRAME_FILES)}, not {kind!r}")
    return f"frame_{index:04d}.{kind}"


def frame_json(result: FrameResult, index: int) -> bytes:
    """frame_NNNN.json: the frame's figures and its index."""
    return figures_json(result.figures, index)


def figures_json(figures: dict, index: int) -> bytes:
    """frame_NNNN.json of a frame with these figures (frame_figures) and index."""
    return (json.dumps(dict(figures, index=index), indent=2) + "\n").encode()


def write_frame(result: FrameResult, out_dir: Path, index: int, exr: np.ndarray | None = None,
                srgb8: np.ndarray | None = None, compression: str = EXR_COMPRESSION,
                with_exr: bool = True) -> dict[str, Path]:
    """Writes frame_NNNN.exr (unless not ``with_exr``: the farm writes it on
    its first request), .png and .json under out_dir, each whole or not at
    all: the one writer of a frame's files, for `argand render` and the
    farm's assembler alike, so their files are the same bytes. ``exr`` and
    ``srgb8``: buffers the caller made already."""
    paths = {kind: Path(out_dir) / frame_file_name(index, kind) for kind in FRAME_FILES}
    if with_exr:
        write_exr(result, paths["exr"], exr, compression)
    write_png(to_srgb8(result.rgba) if srgb8 is None else srgb8, paths["png"])
    write_atomic(paths["json"], frame_json(result, index))
    return paths


def read_band(path: Path) -> tuple[float, float]:
    """The (sigma, delta) an EXR written above was rendered at, exactly."""
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    spec = inp.spec()
    inp.close()
    return float(spec.get_string_attribute("argand:sigma")), float(spec.get_string_attribute("argand:delta"))


def read_exr(path: Path) -> tuple[list[str], np.ndarray]:
    """(channel names, (h, w, c) float32 pixels) of an EXR written above."""
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    names = list(inp.spec().channelnames)
    pixels = inp.read_image("float")
    inp.close()
    return names, pixels
