"""The frame store: one small interface over fsspec (a folder by default; an
S3 bucket later by URL). Every write is atomic (temporary name + rename)."""

from __future__ import annotations

import io
import os
import uuid

import fsspec
import numpy as np


class FrameStore:
    def __init__(self, root: str) -> None:
        self.fs, self.root = fsspec.core.url_to_fs(str(root))
        self.fs.makedirs(self.root, exist_ok=True)

    def path(self, *parts: str) -> str:
        return "/".join([self.root.rstrip("/"), *parts])

    def job_dir(self, job_id: str) -> str:
        return self.path("jobs", job_id)

    def tile_key(self, job_id: str, frame: int, tile: int) -> str:
        return self.path("jobs", job_id, "tiles", f"{frame:04d}", f"{tile:05d}.npz")

    def write_bytes_atomic(self, key: str, data: bytes) -> None:
        parent = key.rsplit("/", 1)[0]
        self.fs.makedirs(parent, exist_ok=True)
        tmp = f"{key}.{uuid.uuid4().hex}.tmp"
        with self.fs.open(tmp, "wb") as f:
            f.write(data)
        self.fs.mv(tmp, key)

    def write_tile(self, job_id: str, frame: int, tile: int, arrays: dict[str, np.ndarray]) -> None:
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        self.write_bytes_atomic(self.tile_key(job_id, frame, tile), buf.getvalue())

    def read_tile(self, job_id: str, frame: int, tile: int) -> dict[str, np.ndarray]:
        with self.fs.open(self.tile_key(job_id, frame, tile), "rb") as f:
            with np.load(io.BytesIO(f.read())) as z:
                return {k: z[k] for k in z.files}

    def exists(self, key: str) -> bool:
        return self.fs.exists(key)

    def local_path(self, key: str) -> str:
        """For the local filesystem, the OS path of a key (used to write
        images with OpenImageIO and to serve them)."""
        return key if os.path.isabs(key) else os.path.abspath(key)

    def remove_job(self, job_id: str) -> None:
        if self.fs.exists(self.job_dir(job_id)):
            self.fs.rm(self.job_dir(job_id), recursive=True)
