"""The frame store: one small interface over fsspec (a folder by default; an
S3 bucket later by URL). Every write is atomic (temporary name + rename).

Tiles are stored raw, several to a file (a "chunk": a short JSON header,
then the arrays' bytes): a tile is written once and read once, so neither
compression nor zip containers pay for themselves, and on a local folder a
chunk is one open, one write and one rename.
"""

from __future__ import annotations

import json
import os
import struct
import uuid

import fsspec
import numpy as np

_MAGIC = b"ARGT1\n"


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
        dt = np.dtype(dtype)
        count = int(np.prod(shape))
        out[name] = np.frombuffer(data, dt, count, base + offset).reshape(shape)
    return out


class FrameStore:
    def __init__(self, root: str) -> None:
        self.fs, self.root = fsspec.core.url_to_fs(str(root))
        self.local = "file" in (self.fs.protocol if isinstance(self.fs.protocol, tuple) else (self.fs.protocol,))
        self._dirs: set[str] = set()
        self.fs.makedirs(self.root, exist_ok=True)

    def path(self, *parts: str) -> str:
        return "/".join([self.root.rstrip("/"), *parts])

    def job_dir(self, job_id: str) -> str:
        return self.path("jobs", job_id)

    def tile_dir(self, job_id: str, frame: int) -> str:
        return self.path("jobs", job_id, "tiles", f"{frame:04d}")

    def _makedirs(self, parent: str) -> None:
        if parent not in self._dirs:
            self.fs.makedirs(parent, exist_ok=True)
            self._dirs.add(parent)

    def write_bytes_atomic(self, key: str, data) -> None:
        """Writes ``data`` (bytes, or a list of buffers written in order)
        under ``key``: readers see the whole file or none."""
        parts = data if isinstance(data, list) else [data]
        parent = key.rsplit("/", 1)[0]
        self._makedirs(parent)
        tmp = f"{key}.{uuid.uuid4().hex}.tmp"
        if self.local:  # the same contract, without fsspec's per-call overhead
            try:
                fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileNotFoundError:  # the folder was removed under us (job deleted, or frame done)
                self._dirs.discard(parent)
                self.fs.makedirs(parent, exist_ok=True)
                fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            with os.fdopen(fd, "wb") as f:
                for part in parts:
                    f.write(part)
            os.replace(tmp, key)
            return
        with self.fs.open(tmp, "wb") as f:
            for part in parts:
                f.write(part)
        self.fs.mv(tmp, key)

    def read_bytes(self, key: str) -> bytes:
        if self.local:
            with open(key, "rb") as f:
                return f.read()
        with self.fs.open(key, "rb") as f:
            return f.read()

    def chunk_key(self, job_id: str, frame: int, name: str) -> str:
        return f"{self.tile_dir(job_id, frame)}/{name}.chunk"

    def write_chunk(self, job_id: str, frame: int, name: str, tiles: dict[int, dict[str, np.ndarray]]) -> None:
        """Several tiles of a frame in one file (one write and one rename for
        all the tiles a worker finished between two commits)."""
        arrays = {f"{t}/{k}": a for t, d in tiles.items() for k, a in d.items()}
        self.write_bytes_atomic(self.chunk_key(job_id, frame, name), pack_buffers(arrays))

    def read_chunk(self, job_id: str, frame: int, name: str) -> dict[int, dict[str, np.ndarray]]:
        out: dict[int, dict[str, np.ndarray]] = {}
        for key, a in unpack_arrays(self.read_bytes(self.chunk_key(job_id, frame, name))).items():
            t, k = key.split("/", 1)
            out.setdefault(int(t), {})[k] = a
        return out

    def remove_tiles(self, job_id: str, frame: int) -> None:
        """Drops a frame's tiles once the frame is assembled (its EXR holds them)."""
        d = self.tile_dir(job_id, frame)
        self._dirs.discard(d)
        if self.fs.exists(d):
            self.fs.rm(d, recursive=True)

    def exists(self, key: str) -> bool:
        return self.fs.exists(key)

    def remove_job(self, job_id: str) -> None:
        self._dirs = {d for d in self._dirs if not d.startswith(self.job_dir(job_id))}
        if self.fs.exists(self.job_dir(job_id)):
            self.fs.rm(self.job_dir(job_id), recursive=True)
