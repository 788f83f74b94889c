"""Whole files or none: the one way Argand writes a file that someone may be
reading (a frame's EXR and PNG, a root field, an animation, a tile chunk),
on this machine and in the farm's shared store alike.

A file is written as an anonymous file in its final folder (Linux's
O_TMPFILE: it has no name while it is written), then linked under a
temporary name of its own and renamed over its final path at once: a
reader sees the old file, or the new one whole, never half of one. Two
writers of the same path (two processes, two requests) each write their own
file and the last rename wins with a whole file. A write that fails leaves
nothing behind, and so does a writer killed mid-write (a worker stopped at
its hard time limit): the kernel drops a file that was never linked. Where
the filesystem has no O_TMPFILE (NFS), the file is written under its
temporary name from the start; a killed writer then leaves that name,
which is_temporary recognises for the sweeps that remove it (the farm's
FrameStore at a job's end, `argand render` at the start of a run). This
needs of a shared filesystem only an atomic rename within a folder
(docs/deploy.md).
"""

from __future__ import annotations

import errno
import os
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator


def temporary_beside(path: Path) -> Path:
    """A fresh temporary name beside ``path`` that keeps its suffix (so
    writers that pick a format by the extension, like OpenImageIO and PyAV,
    write the right one): ``frame_0001.exr`` -> ``frame_0001.exr.<hex>.tmp.exr``."""
    return path.parent / _temporary_name(path.name)


def _temporary_name(name: str) -> str:
    """temporary_beside's name for a file named ``name`` (its suffix as
    pathlib's: from the last dot, unless the name starts or ends there),
    made with string operations: a worker makes one for every file it
    writes, and pathlib's took some 6% of its time."""
    dot = name.rfind(".")
    suffix = name[dot:] if 0 < dot < len(name) - 1 else ""
    return f"{name}.{uuid.uuid4().hex[:12]}.tmp{suffix}"


#: Whether this process can link an anonymous file into a folder: the
#: system has O_TMPFILE and /proc/self/fd (looked at once, on import), and
#: no link failed yet for a reason other than a folder removed meanwhile (a
#: sandbox that forbids linkat through /proc). False: files are written
#: under temporary names from the start.
_linkable = getattr(os, "O_TMPFILE", None) is not None and os.path.isdir("/proc/self/fd")


def _anonymous(folder: Path) -> int | None:
    """A file descriptor of a new anonymous file in ``folder`` (O_TMPFILE),
    or None where the system or the filesystem has none (the caller then
    writes under a temporary name)."""
    if not _linkable:
        return None
    try:
        return os.open(folder, os.O_TMPFILE | os.O_RDWR, 0o644)
    except OSError as exc:
        if exc.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOENT, errno.ENOTDIR):
            return None  # (no O_TMPFILE there, or the folder is gone: the named way says which)
        raise


def _publish(fd: int, path: Path) -> None:
    """Gives the anonymous file ``fd`` the name ``path``, replacing what was
    there in one rename (a file cannot be linked over an existing name, so
    it gets a temporary name first, for the microseconds until the rename)."""
    tmp = _temporary_name(path.name)
    # linkat(AT_SYMLINK_FOLLOW) on the /proc link: Python calls plain link()
    # (which would link the symlink itself) unless a folder descriptor is
    # given; the names are then the folder's (no path is resolved again).
    folder = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            os.link(f"/proc/self/fd/{fd}", tmp, src_dir_fd=folder, dst_dir_fd=folder, follow_symlinks=True)
        except OSError as exc:
            if exc.errno == errno.ENOENT:  # (the folder was removed under us: as a rename would)
                raise
            global _linkable
            _linkable = False
            _copy_out(fd, path.parent / tmp)
        try:
            os.replace(tmp, path.name, src_dir_fd=folder, dst_dir_fd=folder)
        except BaseException:
            try:
                os.unlink(tmp, dir_fd=folder)  # only there when the rename failed
            except FileNotFoundError:
                pass
            raise
    finally:
        os.close(folder)


def _copy_out(fd: int, tmp: Path) -> None:
    """The anonymous file's content, copied to the new file ``tmp`` (where
    it cannot be linked)."""
    out = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    try:
        offset = 0
        while block := os.pread(fd, 1 << 20, offset):
            os.write(out, block)  # (a regular file: written whole)
            offset += len(block)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        os.close(out)


def _folder_of(path: Path, make_folder: bool) -> None:
    if make_folder:
        path.parent.mkdir(parents=True, exist_ok=True)


@contextmanager
def atomic_path(path: Path, make_folder: bool = True) -> Iterator[Path]:
    """Yields a path to write ``path``'s content to (opened by name, as
    OpenImageIO and PyAV do); on a normal exit the content becomes ``path``,
    on an exception it is dropped (and the exception goes on). The yielded
    path may have no suffix (/proc/self/fd/N of an anonymous file): writers
    that pick a format must take it from ``path``. ``make_folder``: create
    ``path``'s folder first."""
    path = Path(path)
    _folder_of(path, make_folder)
    fd = _anonymous(path.parent)
    if fd is not None:
        try:
            yield Path(f"/proc/self/fd/{fd}")
            _publish(fd, path)
        finally:
            os.close(fd)
        return
    with _named(path) as tmp:
        yield tmp


@contextmanager
def _named(path: Path) -> Iterator[Path]:
    """atomic_path where there is no anonymous file: under a temporary name."""
    tmp = temporary_beside(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)  # only there when something failed


def write_atomic(path: Path, data: bytes | bytearray | memoryview | Iterable[bytes | memoryview],
                 make_folder: bool = True) -> Path:
    """Writes ``data`` (bytes, or buffers written in order) to ``path``
    whole or not at all (atomic_path). A named temporary is created
    exclusively (O_EXCL), so a name collision can never mix two writers.
    Returns ``path``."""
    path = Path(path)
    parts = [data] if isinstance(data, (bytes, bytearray, memoryview)) else data
    _folder_of(path, make_folder)
    fd = _anonymous(path.parent)
    if fd is not None:
        with os.fdopen(fd, "wb") as f:
            _write_parts(f, parts)
            f.flush()
            _publish(f.fileno(), path)
        return path
    with _named(path) as tmp:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileNotFoundError:  # the folder was removed under us (a job deleted): made again
            if not make_folder:
                raise
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        with os.fdopen(fd, "wb") as f:
            _write_parts(f, parts)
    return path


def _write_parts(f, parts: Iterable[bytes | memoryview]) -> None:
    for part in parts:
        f.write(part)


def is_temporary(name: str) -> bool:
    """Whether a file name is one temporary_beside makes (what a killed
    writer leaves behind: never a finished file)."""
    parts = name.rsplit(".", 3)
    return (len(parts) == 4 and parts[2] == "tmp" and len(parts[1]) == 12
            and all(c in "0123456789abcdef" for c in parts[1]) and parts[0].endswith(parts[3]))
