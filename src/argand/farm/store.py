"""The frame store: a folder (the data folder's store/, shared by every
process of the farm), laid out by argand.farm.layout. Every write goes
through :meth:`FrameStore.write_atomic` (a temporary name, then a rename:
readers see a whole file or none); the EXR and PNG writers of
argand.media.frame_files rename the same way.

Tiles are stored raw, several to a file (a "chunk": a short JSON header,
then the arrays' bytes): a tile is written once and read once, so neither
compression nor zip containers pay for themselves, and a chunk is one open,
one write and one rename.
"""

from __future__ import annotations

import errno
import json
import math
import os
import shutil
import time
import struct
from pathlib import Path

import numpy as np

from argand.farm.layout import JobLayout, is_window_chunk
from argand.media.atomic import is_temporary, write_atomic

#: A temporary frame file this old (seconds) at the job's end is a killed
#: writer's (clean_finished_job).
STALE_TEMPORARY_S = 5.0

_MAGIC = b"ARGT1\n"

#: Window chunks kept read per process (FrameStore._read_window): a frame's
#: tiles come from as many windows as its runs were committed in (each of
#: some kilobytes: the tiles' figures).
WINDOW_CACHE = 256


def pack_buffers(arrays: dict[str, np.ndarray]) -> list:
    """dict of arrays -> the buffers of the file (magic, header length, JSON
    header, the arrays' bytes), without copying the arrays."""
    header, chunks, offset = [], [], 0
    for name, a in arrays.items():
        a = np.ascontiguousarray(a)
        header.append([name, a.dtype.str, list(a.shape), offset])
        chunks.append(memoryview(a).cast("B"))
        offset += a.nbytes
    head = json.dumps(header, separators=(",", ":")).encode()
    return [_MAGIC, struct.pack("<I", len(head)), head, *chunks]


#: A stacked window chunk's names: the (frame, tile) rows, and each of the
#: tiles' arrays stacked under _STACK + its name.
_STACK = "stack/"
_STACK_KEYS = "rows"  # (no "/": no tile's array name in either form)


def _stacked(tiles: dict[tuple[int, int], dict[str, np.ndarray]]) -> dict[str, np.ndarray] | None:
    """``tiles`` as stacked arrays (see FrameStore.write_window_chunk), or
    None where their arrays differ in names, shapes or types."""
    if not tiles:
        return None
    first = next(iter(tiles.values()))
    form = [(k, a.dtype, a.shape) for k, a in first.items()]
    for d in tiles.values():
        if len(d) != len(form) or any(k not in d or d[k].dtype != dt or d[k].shape != sh for k, dt, sh in form):
            return None
    out = {_STACK_KEYS: np.array(list(tiles), np.int64).reshape(len(tiles), 2)}
    for k, dt, sh in form:
        out[_STACK + k] = np.stack([d[k] for d in tiles.values()]) if sh else np.array([d[k] for d in tiles.values()], dt)
    return out


def pack_arrays(arrays: dict[str, np.ndarray]) -> bytes:
    return b"".join(pack_buffers(arrays))


def unpack_arrays(data: bytes) -> dict[str, np.ndarray]:
    if not data.startswith(_MAGIC):
        raise ValueError("not an Argand tile (bad magic)")
    (n,) = struct.unpack_from("<I", data, len(_MAGIC))
    start = len(_MAGIC) + 4
    header = json.loads(data[start:start + n])
    base = start + n
    out = {}
    for name, dtype, shape, offset in header:
        # (math.prod: numpy's prod of a short list costs some microseconds,
        # a chunk of figures holds thousands of small arrays.)
        out[name] = np.frombuffer(data, np.dtype(dtype), math.prod(shape), base + offset).reshape(shape)
    return out


#: A write that fails with one of these is the store's fault, not the
#: tile's: the job stops at once with the reason (retrying elsewhere would
#: fail the same way), and a retry takes it up once the store is fixed.
STORE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.EROFS, errno.EFBIG})


def is_store_error(exc: BaseException) -> bool:
    """A failed write to the store: a full disk or quota, a folder or file
    system that refuses writes, a file size limit; or an image writer's
    refusal (argand.media.frame_files raises OSError("cannot write ...") with
    OpenImageIO's message, without an errno)."""
    if not isinstance(exc, OSError):
        return False
    return exc.errno in STORE_ERRNOS or (exc.errno is None and str(exc).startswith("cannot write"))


class FrameStore:
    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._windows: dict[tuple[str, str], tuple] = {}  # (_read_window)

    def job(self, job_id: str) -> JobLayout:
        return JobLayout(self.root, job_id)

    def write_atomic(self, path: Path, data) -> None:
        """Writes ``data`` (bytes, or a list of buffers written in order) to
        ``path``: readers see the whole file or none (argand.media.atomic;
        a folder removed under the writer, a job deleted or a frame done,
        is made again)."""
        write_atomic(path, data)

    def prepare(self, path: Path) -> Path:
        """``path``, its folder made if missing: for OpenImageIO's EXR and PNG
        writers (argand.media.frame_files), which write a temporary file and rename it."""
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def write_chunk(self, job_id: str, frame: int, name: str, tiles: dict[int, dict[str, np.ndarray]]) -> None:
        """Several tiles of a frame in one file (one write and one rename for
        all the tiles a worker finished between two commits)."""
        arrays = {f"{t}/{k}": a for t, d in tiles.items() for k, a in d.items()}
        self.write_atomic(self.job(job_id).chunk(frame, name), pack_buffers(arrays))

    def write_window_chunk(self, job_id: str, name: str, tiles: dict[tuple[int, int], dict[str, np.ndarray]]) -> None:
        """The tiles of several frames of a window, {(frame, tile): arrays},
        in one file (``name`` a window chunk's: layout.is_window_chunk);
        read_chunk gives each frame its own. Tiles whose arrays agree in
        names, shapes and types (a window's figures: every tile's meta and
        levels) are stacked, one array per name and a key array of
        (frame, tile) rows: a few buffers to write and read back, not two
        small arrays a tile."""
        if not is_window_chunk(name):
            raise ValueError(f"a window chunk's name starts with w-, not {name!r}")
        stacked = _stacked(tiles)
        if stacked is None:
            arrays = {f"{f}/{t}/{k}": a for (f, t), d in tiles.items() for k, a in d.items()}
            self.write_atomic(self.job(job_id).chunk(0, name), pack_buffers(arrays))
        else:
            self.write_window_stacked(job_id, name, stacked.pop(_STACK_KEYS),
                                      {k[len(_STACK):]: a for k, a in stacked.items()})

    def write_window_stacked(self, job_id: str, name: str, keys: np.ndarray, columns: dict[str, np.ndarray]) -> None:
        """A window chunk of like tiles given stacked already: ``keys`` their
        (frame, tile) rows (int64, n x 2), ``columns`` {array name: the
        tiles' arrays stacked in that order}: the file write_window_chunk
        writes for those tiles (a window's figures, made without a dict of
        arrays per tile)."""
        if not is_window_chunk(name):
            raise ValueError(f"a window chunk's name starts with w-, not {name!r}")
        if keys.dtype != np.int64 or keys.ndim != 2 or keys.shape[1] != 2 or \
                any(len(a) != len(keys) for a in columns.values()):
            raise ValueError("a stacked window needs (frame, tile) int64 rows and one row per tile in each column")
        arrays = {_STACK_KEYS: keys, **{_STACK + k: a for k, a in columns.items()}}
        self.write_atomic(self.job(job_id).chunk(0, name), pack_buffers(arrays))

    def read_chunk(self, job_id: str, frame: int, name: str) -> dict[int, dict[str, np.ndarray]]:
        """Frame ``frame``'s tiles in chunk ``name`` (its own, or its part of
        a window chunk): {tile: arrays}."""
        if is_window_chunk(name):
            rows, names, columns = self._read_window(job_id, name)
            return {t: {k: c[row] for k, c in zip(names, columns) if c[row] is not None}
                    for t, row in rows.get(frame, {}).items()}
        path = self.job(job_id).chunk(frame, name)
        out: dict[int, dict[str, np.ndarray]] = {}
        for key, a in unpack_arrays(path.read_bytes()).items():
            t, k = key.split("/", 1)
            out.setdefault(int(t), {})[k] = a
        return out

    def _read_window(self, job_id: str, name: str) -> tuple[dict[int, dict[int, int]], list[str], list[np.ndarray]]:
        """A window chunk as ({frame: {tile: row}}, names, stacked columns),
        read once for the frames an assembler finishes together (each of
        them reads every window that holds its tiles; a chunk's name is
        never written twice, so its content does not change while it
        exists). (A few objects per window, not a few per tile: a worker
        keeps WINDOW_CACHE of them, and its garbage collector walks them.)"""
        cached = self._windows.get((job_id, name))
        if cached is None:
            arrays = unpack_arrays(self.job(job_id).chunk(0, name).read_bytes())
            keys = arrays.pop(_STACK_KEYS, None)
            if keys is None:  # (a window of tiles that differ: stacked here)
                by_tile: dict[tuple[int, int], dict[str, np.ndarray]] = {}
                for key, a in arrays.items():
                    f, t, k = key.split("/", 2)
                    by_tile.setdefault((int(f), int(t)), {})[k] = a
                names = sorted({k for d in by_tile.values() for k in d})
                keys = np.array(list(by_tile), np.int64).reshape(len(by_tile), 2)
                columns = [[d.get(k) for d in by_tile.values()] for k in names]
            else:
                names = [k[len(_STACK):] for k in arrays]
                columns = list(arrays.values())
            rows: dict[int, dict[int, int]] = {}
            for row, (f, t) in enumerate(keys.tolist()):
                rows.setdefault(f, {})[t] = row
            if len(self._windows) >= WINDOW_CACHE:
                self._windows.pop(next(iter(self._windows)))
            cached = self._windows[(job_id, name)] = (rows, names, columns)
        return cached

    def discard_chunk(self, job_id: str, frame: int, name: str) -> None:
        """Removes a chunk that no tile row points at (its tiles went to
        another worker), and the folders it leaves empty: a frame assembled
        meanwhile, or a job deleted meanwhile, keeps no trace of it."""
        path = self.job(job_id).chunk(frame, name)
        path.unlink(missing_ok=True)
        for folder in (path.parent, path.parent.parent, self.job(job_id).folder):
            try:
                folder.rmdir()
            except OSError:  # not empty (or gone): what is left belongs to someone
                break

    def remove_tiles(self, job_id: str, frame: int) -> None:
        """Drops a frame's tiles once the frame is assembled (its EXR holds them)."""
        folder = self.job(job_id).tiles(frame)
        shutil.rmtree(folder, ignore_errors=True)

    def clean_finished_job(self, job_id: str) -> None:
        """Drops every frame's tile folder once the job's frames are all
        done: a chunk a stale worker wrote after its frame was assembled
        (its commit then lost, or never answered on a lossy link) goes too,
        and so does a frame file's temporary that a writer killed mid-write
        left on a filesystem without anonymous files (argand.media.atomic;
        one older than STALE_TEMPORARY_S: no frame file takes that long, so
        its writer is gone)."""
        shutil.rmtree(self.job(job_id).folder / "tiles", ignore_errors=True)
        now = time.time()
        try:
            entries = list(os.scandir(self.job(job_id).folder))
        except OSError:
            return
        for entry in entries:
            try:
                if is_temporary(entry.name) and now - entry.stat().st_mtime > STALE_TEMPORARY_S:
                    os.unlink(entry.path)
            except OSError:  # (gone meanwhile: renamed by its writer, or removed)
                continue

    def remove_job(self, job_id: str) -> None:
        folder = self.job(job_id).folder
        shutil.rmtree(folder, ignore_errors=True)


_stores: dict[Path, FrameStore] = {}


def store_for(settings) -> FrameStore:
    """The store of these settings (one object per process and folder)."""
    root = settings.store_path
    if root not in _stores:
        _stores[root] = FrameStore(root)
    return _stores[root]
