"""argand.media.atomic: the one way every file someone may read is written
(frames, root fields, animations, tile chunks): whole or not at all."""

from __future__ import annotations

import os
import shutil
import threading

import pytest

from argand.media.atomic import atomic_path, is_temporary, temporary_beside, write_atomic


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
