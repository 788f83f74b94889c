"""Whole files or none: the one way Argand writes a file that someone may be
reading (a frame's EXR and PNG, a root field, an animation, a tile chunk),
on this machine and in the farm's shared store alike.

A file is written under a temporary name of its own beside its final path
(the same folder, so the rename stays on one filesystem) and renamed over
it once complete: a reader sees the old file, or the new one whole, never
half of one. Two writers of the same path (two processes, two requests)
each write their own temporary and the last rename wins with a whole file.
A write that fails leaves no temporary behind. This needs of a shared
filesystem only an atomic rename within a folder (docs/deploy.md).
"""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator


def temporary_beside(path: Path) -> Path:
    """A fresh temporary name beside ``path`` that keeps its suffix (so
    writers that pick a format by the extension, like OpenImageIO and PyAV,
    write the right one): ``frame_0001.exr`` -> ``frame_0001.exr.<hex>.tmp.exr``."""
    return path.with_name(f"{path.name}.{uuid.uuid4().hex[:12]}.tmp{path.suffix}")


@contextmanager
def atomic_path(path: Path, make_folder: bool = True) -> Iterator[Path]:
    """Yields a temporary path to write ``path``'s content to; on a normal
    exit it is renamed to ``path``, on an exception it is removed (and the
    exception goes on). ``make_folder``: create ``path``'s folder first."""
    path = Path(path)
    if make_folder:
        path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_beside(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)  # only there when something failed


def write_atomic(path: Path, data: bytes | bytearray | memoryview | Iterable[bytes | memoryview],
                 make_folder: bool = True) -> Path:
    """Writes ``data`` (bytes, or buffers written in order) to ``path``
    whole or not at all (atomic_path). The temporary is created exclusively
    (O_EXCL), so a name collision can never mix two writers. Returns ``path``."""
    path = Path(path)
    parts = [data] if isinstance(data, (bytes, bytearray, memoryview)) else data
    with atomic_path(path, make_folder) as tmp:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileNotFoundError:  # the folder was removed under us (a job deleted): made again
            if not make_folder:
                raise
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        with os.fdopen(fd, "wb") as f:
            for part in parts:
                f.write(part)
    return path


def is_temporary(name: str) -> bool:
    """Whether a file name is one temporary_beside makes (what a killed
    writer leaves behind: never a finished file)."""
    parts = name.rsplit(".", 3)
    return (len(parts) == 4 and parts[2] == "tmp" and len(parts[1]) == 12
            and all(c in "0123456789abcdef" for c in parts[1]) and parts[0].endswith(parts[3]))
