"""Where every file of a job lives in the frame store: one class, used by
the writer of tiles, the assembler and the API.

    store/jobs/<job>/frame_NNNN.exr|.png|.json   the assembled frame
    store/jobs/<job>/thumb_NNNN.png              its thumbnail
    store/jobs/<job>/<channel>_NNNN.png          a false-colour channel (made on request)
    store/jobs/<job>/gif/NNNN.gif                the frame's GIF fragment
    store/jobs/<job>/animation.gif|.webp|.mp4    the animation (WebP, MP4: made on request)
    store/jobs/<job>/atlas.png                   a grid's frames as a labelled contact sheet (on request)
    store/jobs/<job>/tiles/NNNN/<name>.chunk     tiles of an unassembled frame
    store/jobs/<job>/tiles/window/<name>.chunk   the figures of a window's frames' tiles (files on request)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from argand.media.frame_files import FRAME_FILES, frame_file_name

ANIMATIONS = ("gif", "webp", "mp4")


@dataclass(frozen=True)
class JobLayout:
    store: Path
    job_id: str

    @property
    def folder(self) -> Path:
        return self.store / "jobs" / self.job_id

    def frame(self, index: int, kind: str) -> Path:
        """The frame's EXR (all channels), PNG (beauty, sRGB) or JSON (figures)."""
        return self.folder / frame_file_name(index, kind)

    def thumbnail(self, index: int) -> Path:
        return self.folder / f"thumb_{index:04d}.png"

    def channel(self, name: str, index: int) -> Path:
        return self.folder / f"{name}_{index:04d}.png"

    def gif_fragment(self, index: int) -> Path:
        return self.folder / "gif" / f"{index:04d}.gif"

    def animation(self, kind: str) -> Path:
        if kind not in ANIMATIONS:
            raise ValueError(f"an animation is one of {', '.join(ANIMATIONS)}, not {kind!r}")
        return self.folder / f"animation.{kind}"

    def atlas(self) -> Path:
        return self.folder / "atlas.png"

    def field_tile(self, index: int) -> Path:
        """Tile ``index``'s root field (its recorded primary roots and a
        CRC-32, argand.render.field.stored_tape), written once by the first
        run that renders the tile, read by the band routes."""
        return self.folder / "field" / f"{index:04d}.tape"

    def tiles(self, index: int) -> Path:
        return self.folder / "tiles" / f"{index:04d}"

    def chunk(self, index: int, name: str) -> Path:
        """Where chunk ``name`` holding tiles of frame ``index`` lives: its
        frame's folder, or, for a window chunk (is_window_chunk), the
        window folder its frames share."""
        if is_window_chunk(name):
            return self.folder / "tiles" / "window" / f"{name}.chunk"
        return self.tiles(index) / f"{name}.chunk"


#: The prefix of a window chunk's name: one file for the tiles of every
#: frame of a window (a run's frames that share their rays) whose pixels
#: are not kept (files on request: the tiles' figures only), instead of a
#: file per frame. A window's commit is then one file, not one per frame
#: (24 in a 24-frame job: some 0.3 ms of a worker's time each on ext4).
WINDOW_PREFIX = "w-"


def is_window_chunk(name: str) -> bool:
    return name.startswith(WINDOW_PREFIX)
