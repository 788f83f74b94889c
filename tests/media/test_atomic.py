"""argand.media.atomic: the one way every file someone may read is written
(frames, root fields, animations, tile chunks): whole or not at all."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading

import pytest

from argand.media import atomic
from argand.media.atomic import atomic_path, is_temporary, temporary_beside, write_atomic


@pytest.fixture(autouse=True, params=["anonymous", "named"])
def way(request, monkeypatch):
    """Every test runs both ways a file is written: as an anonymous file
    (O_TMPFILE, where the filesystem has it) and under a temporary name
    (where it has not, as on NFS)."""
    if request.param == "named":
        monkeypatch.setattr(atomic, "_anonymous", lambda folder: None)
    return request.param


def test_the_anonymous_way_is_taken_where_the_filesystem_has_it(tmp_path, way):
    """On this machine's temporary folder (ext4, tmpfs or overlayfs: all have
    O_TMPFILE) the anonymous way is the one taken."""
    fd = atomic._anonymous(tmp_path)
    assert (fd is not None) == (way == "anonymous")
    if fd is not None:
        os.close(fd)


def test_a_write_is_whole_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "deep" / "er" / "frame_0001.json"
    assert write_atomic(path, [b"ab", memoryview(b"cd"), bytearray(b"ef")]) == path
    assert path.read_bytes() == b"abcdef"
    write_atomic(path, b"new")
    assert path.read_bytes() == b"new"
    assert sorted(p.name for p in path.parent.iterdir()) == ["frame_0001.json"]


def test_a_failed_write_keeps_the_old_file_and_removes_its_temporary(tmp_path):
    path = tmp_path / "frame_0000.exr"
    path.write_bytes(b"old")

    def parts():
        yield b"half of a new "
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        write_atomic(path, parts())
    with pytest.raises(RuntimeError):
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("the encoder failed")
    assert path.read_bytes() == b"old" and sorted(os.listdir(tmp_path)) == ["frame_0000.exr"]


def test_temporaries_keep_the_suffix_and_are_told_apart_from_finished_files(tmp_path):
    names = {temporary_beside(tmp_path / n).name for n in ("frame_0003.exr", "animation.mp4", "0007.tape")
             for _ in range(50)}
    assert len(names) == 150  # each writer its own name
    assert all(is_temporary(n) for n in names)
    assert {n.rsplit(".", 1)[-1] for n in names} == {"exr", "mp4", "tape"}
    for finished in ("frame_0003.exr", "animation.mp4", "0007.tape", "00000-a1b2c3d4e5.chunk", "a.tmp",
                     "frame_0003.exr.tmp", "x.0123456789ab.tmp.png"):
        assert not is_temporary(finished), finished


def test_concurrent_writers_of_one_path_leave_one_whole_file(tmp_path):
    """Eight threads write the same path 40 times each with distinct
    contents, while a reader keeps reading: every read is one whole
    content, and the end is one of them, with no temporary left."""
    path = tmp_path / "band.png"
    contents = [bytes([k]) * 200_000 for k in range(8)]
    write_atomic(path, contents[0])
    seen: set[bytes] = set()
    stop = threading.Event()

    def read():
        while not stop.is_set():
            data = path.read_bytes()
            seen.add(data[:1] * len(data) == data and len(data) == 200_000)

    def write(k):
        for _ in range(40):
            write_atomic(path, contents[k])

    reader = threading.Thread(target=read)
    reader.start()
    writers = [threading.Thread(target=write, args=(k,)) for k in range(8)]
    for t in writers:
        t.start()
    for t in writers:
        t.join()
    stop.set()
    reader.join()
    assert seen == {True}
    assert path.read_bytes() in contents and os.listdir(tmp_path) == ["band.png"]


def test_a_folder_removed_under_the_writer_is_made_again(tmp_path):
    folder = tmp_path / "jobs" / "j1" / "gif"
    write_atomic(folder / "0000.gif", b"GIF89a")
    shutil.rmtree(tmp_path / "jobs")
    write_atomic(folder / "0001.gif", b"GIF89a")
    assert (folder / "0001.gif").read_bytes() == b"GIF89a"
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "absent" / "x.bin", b"x", make_folder=False)


_KILLED_WRITER = """
import sys, time
from pathlib import Path
from argand.media import atomic
if sys.argv[2] == "named":
    atomic._anonymous = lambda folder: None
def parts():
    yield b"x" * 100_000
    print("writing", flush=True)
    time.sleep(60)
    yield b"never"
if sys.argv[3] == "bytes":
    atomic.write_atomic(Path(sys.argv[1]), parts())
else:
    with atomic.atomic_path(Path(sys.argv[1])) as tmp:
        with open(tmp, "wb") as f:
            f.write(b"x" * 100_000)
            f.flush()
            print("writing", flush=True)
            time.sleep(60)
"""


@pytest.mark.parametrize("how", ["bytes", "path"])
def test_a_writer_killed_mid_write_keeps_the_old_file(tmp_path, way, how):
    """A writer killed (SIGKILL, as a worker at its hard time limit) in the
    middle of a write: the old file stays whole; the anonymous way leaves
    nothing else, the named way leaves one temporary that is_temporary
    recognises (what the sweeps remove)."""
    path = tmp_path / "frame_0002.exr"
    path.write_bytes(b"old")
    with subprocess.Popen([sys.executable, "-c", _KILLED_WRITER, str(path), way, how],
                          stdout=subprocess.PIPE, text=True) as proc:
        try:
            assert proc.stdout.readline().strip() == "writing"
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
    assert path.read_bytes() == b"old"
    left = sorted(set(os.listdir(tmp_path)) - {"frame_0002.exr"})
    if way == "anonymous":
        assert left == []
    else:
        assert len(left) == 1 and is_temporary(left[0]), left


def test_an_image_and_a_video_are_written_by_name_both_ways(tmp_path):
    """OpenImageIO and PyAV open the path they are given by name (PyAV twice,
    to move the MP4's index to the front): both write whole files either way."""
    import numpy as np

    from argand.media.frame_files import write_png
    from argand.media.video import Mp4Encoder

    pixels = np.zeros((16, 16, 4), np.uint8)
    pixels[..., 0] = np.arange(16, dtype=np.uint8)[None, :] * 16
    write_png(pixels, tmp_path / "a.png")
    assert (tmp_path / "a.png").read_bytes()[-12:] == b"\x00\x00\x00\x00IEND\xaeB`\x82"
    with atomic_path(tmp_path / "animation.mp4") as tmp, Mp4Encoder(tmp, 8) as encoder:
        for k in range(4):
            encoder.add(np.full((16, 16, 3), 60 * k, np.uint8))
    data = (tmp_path / "animation.mp4").read_bytes()
    assert data[4:8] == b"ftyp" and data.index(b"moov") < data.index(b"mdat")  # faststart: the index first
    assert sorted(os.listdir(tmp_path)) == ["a.png", "animation.mp4"]


def test_where_an_anonymous_file_cannot_be_linked_it_is_copied_and_later_writes_are_named(tmp_path, way,
                                                                                          monkeypatch):
    """A sandbox that forbids linkat through /proc (EPERM): the write still
    lands whole (copied out of the anonymous file), and the process takes
    the named way from then on. (The named way links nothing.)"""
    calls = []

    def refuse(*args, **kwargs):
        calls.append(args)
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(atomic, "_linkable", True)
    monkeypatch.setattr(os, "link", refuse)
    data = bytes(range(256)) * 5000  # more than one copy block
    write_atomic(tmp_path / "frame_0001.exr", data)
    if way == "named":
        assert calls == [] and (tmp_path / "frame_0001.exr").read_bytes() == data
        return
    assert (tmp_path / "frame_0001.exr").read_bytes() == data and len(calls) == 1
    assert atomic._linkable is False and atomic._anonymous(tmp_path) is None
    write_atomic(tmp_path / "frame_0002.exr", b"named")
    assert len(calls) == 1 and sorted(os.listdir(tmp_path)) == ["frame_0001.exr", "frame_0002.exr"]
