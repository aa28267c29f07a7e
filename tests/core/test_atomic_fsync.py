"""Durability of atomic outputs: every temporary file is fsynced before it gets its final
name, its folder after the rename; a failing fsync leaves nothing behind."""

from __future__ import annotations

import errno
import os
import stat

import pytest

from terrascape.errors import OutputWriteError
from terrascape.io.atomic import atomic_output, atomic_outputs


def _recording_fsync(monkeypatch, finals):
    """Replace os.fsync by a recorder of (what the fd is, which finals existed then)."""
    calls = []
    real = os.fsync

    def fsync(fd):
        target = os.readlink(f"/proc/self/fd/{fd}")
        is_dir = stat.S_ISDIR(os.fstat(fd).st_mode)
        calls.append((target, is_dir, [f.exists() for f in finals]))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    return calls


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_each_file_is_synced_before_its_name_and_the_folder_after(tmp_path, monkeypatch):
    finals = [tmp_path / "a.r16", tmp_path / "a.r16.json"]
    calls = _recording_fsync(monkeypatch, finals)
    with atomic_outputs(finals) as tmps:
        tmps[0].write_bytes(b"\x01\x02" * 100)
        tmps[1].write_text('{"rows": 10}')
    files = [c for c in calls if not c[1]]
    folders = [c for c in calls if c[1]]
    assert [os.path.basename(c[0]) for c in files] == [t.name for t in tmps]
    assert all(existed == [False, False] for _, _, existed in files)  # before any rename
    assert folders == [(str(tmp_path), True, [True, True])]  # after both renames
    assert finals[0].read_bytes() == b"\x01\x02" * 100
    assert finals[1].read_text() == '{"rows": 10}'


def test_a_failing_fsync_writes_nothing(tmp_path, monkeypatch):
    def broken(fd):
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(os, "fsync", broken)
    final = tmp_path / "h.npy"
    with pytest.raises(OutputWriteError, match=r"h\.npy"), atomic_output(final) as tmp:
        tmp.write_bytes(b"data")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_that_cannot_sync_still_commits(tmp_path, monkeypatch):
    real = os.fsync

    def no_folders(fd):
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            raise OSError(errno.EINVAL, "Invalid argument")
        real(fd)

    monkeypatch.setattr(os, "fsync", no_folders)
    final = tmp_path / "h.bin"
    with atomic_output(final) as tmp:
        tmp.write_bytes(b"abc")
    assert final.read_bytes() == b"abc"
    assert [p.name for p in tmp_path.iterdir()] == ["h.bin"]
