"""A job's root field: the primary roots of every sample, solved once, from
which any band (σ, δ) of the same scene, camera and size is decided.

The field is what the batched kernel answered for each tile's rays, kept
per tile as the C++ renderer records it (core/include/argand/render.h,
RootField: a header naming the rays and the tile, then per run of samples
and per batched object the status, the proven discs with their counts and
the lane approximations a cluster's settling starts from). Replaying it
skips the root solve and nothing else: polynomials, clip tests, decisions,
the escalation ladder and shading run as without a field, so a frame
derived from the field is, to the bit, the frame rendered from scratch
with the same tiling (tests/render/test_field.py).

On disk (``RootField.save``): ``ARGAND-ROOT-FIELD 1`` and a JSON line
(fingerprint, size, tile, the tiles' rectangles, byte lengths and CRC-32s),
then the tiles' bytes in that order. A field read back whose bytes do not
match their checksums is refused: the bytes carry proofs, and a flipped
bit in a disc would be a false claim.
"""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from argand.core import _core
from argand.media.atomic import write_atomic

MAGIC = b"ARGAND-ROOT-FIELD 1\n"


@dataclass
class RootField:
    """The root field of a frame's tiling: ``tiles[(x0, y0, x1, y1)]`` holds a
    tile's recorded bytes; ``fingerprint`` names the rays
    (_core.rays_fingerprint of any band's plan)."""

    fingerprint: int
    width: int
    height: int
    tile: int
    tiles: dict[tuple[int, int, int, int], bytes] = field(default_factory=dict)

    @property
    def nbytes(self) -> int:
        return sum(len(b) for b in self.tiles.values())

    def covers(self, frame_plan, tile: int) -> bool:
        """True iff the field was recorded for these rays with this tiling."""
        return (self.tile == tile and int(_core.rays_fingerprint(frame_plan)) == self.fingerprint
                and len(self.tiles) == len(_tile_rects(self.width, self.height, tile)))

    def save(self, path: str | Path) -> Path:
        """Writes the field to ``path`` atomically (a temporary file renamed)."""
        path = Path(path)
        rects = sorted(self.tiles, key=lambda r: (r[1], r[0]))
        head = {"fingerprint": self.fingerprint, "width": self.width, "height": self.height, "tile": self.tile,
                "tiles": [[*r, len(self.tiles[r]), zlib.crc32(self.tiles[r])] for r in rects]}
        return write_atomic(path, [MAGIC, json.dumps(head).encode() + b"\n", *(self.tiles[r] for r in rects)])

    @classmethod
    def load(cls, path: str | Path) -> "RootField":
        """Reads a field save wrote; ValueError for anything else."""
        data = Path(path).read_bytes()
        if not data.startswith(MAGIC):
            raise ValueError(f"{path}: not an Argand root field")
        try:
            end = data.index(b"\n", len(MAGIC))
            head = json.loads(data[len(MAGIC):end])
            out = cls(int(head["fingerprint"]), int(head["width"]), int(head["height"]), int(head["tile"]))
            at = end + 1
            for x0, y0, x1, y1, n, crc in head["tiles"]:
                tape = data[at:at + n]
                if len(tape) != n or zlib.crc32(tape) != crc:
                    raise ValueError(f"tile ({x0}, {y0})-({x1}, {y1}) does not match its checksum")
                out.tiles[(x0, y0, x1, y1)] = tape
                at += n
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: a damaged root field ({exc})") from None
        if at != len(data):
            raise ValueError(f"{path}: the root field's tiles do not match its header")
        return out


def stored_tape(tape: bytes) -> bytes:
    """A tile's tape as the farm stores it: the bytes, then their CRC-32 (4 bytes, little-endian)."""
    return tape + zlib.crc32(tape).to_bytes(4, "little")


def tape_of_stored(data: bytes) -> bytes:
    """The tape of stored_tape's bytes; ValueError where the checksum does not match."""
    tape = data[:-4]
    if len(data) < 4 or zlib.crc32(tape).to_bytes(4, "little") != data[-4:]:
        raise ValueError("a stored root field tile does not match its checksum")
    return tape


def _tile_rects(width: int, height: int, tile: int) -> list:
    from argand.render.frames import tiles

    return tiles(width, height, tile)
