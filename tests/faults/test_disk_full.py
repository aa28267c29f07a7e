"""OS errors on outputs (disk full, file too large, a parent that is a file, a name too long):
one line naming the path and the reason, exit 1 (environment) or 2 (usage), and on disk the
old files unchanged and no temporary file left."""

from __future__ import annotations

import errno
import os
import pathlib
import re
import resource
import signal
import subprocess
import sys

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.cli.app import run_app
from terrascape.errors import OutputWriteError
from terrascape.io import read_heightmap, write_heightmap

SRC = str(pathlib.Path(__file__).resolve().parents[2] / "src")


# stage timings ("read… 0.00 s") and the note a stage still running after 5 s prints (a
# first run compiling, or a loaded machine): not error lines
_NOT_ERRORS = r"… \d+\.\d+ s$|: still working after \d"


def _error_lines(err: str) -> list[str]:
    assert "Traceback" not in err, err
    return [line for line in err.splitlines()
            if line.strip() and not re.search(_NOT_ERRORS, line)]


def _listing(folder) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture
def old_pair(tmp_path):
    hm = Heightmap(np.arange(64, dtype=np.float32).reshape(8, 8))
    write_heightmap(hm, tmp_path / "o.r16")
    return _listing(tmp_path)


def _enospc_after(limit: int):
    """A replacement for Path.write_bytes/write_text that writes ``limit`` bytes, then fails
    like a full disk."""
    real_bytes = pathlib.Path.write_bytes

    def write_bytes(self, data):
        real_bytes(self, bytes(data)[:limit])
        raise OSError(errno.ENOSPC, "No space left on device", str(self))

    def write_text(self, text, encoding=None, errors=None, newline=None):
        return write_bytes(self, text.encode(encoding or "utf-8"))

    return write_bytes, write_text


@pytest.mark.parametrize("limit", [0, 10])
def test_full_disk_during_raw_write_keeps_the_old_pair(tmp_path, old_pair, monkeypatch, limit):
    write_bytes, write_text = _enospc_after(limit)
    monkeypatch.setattr(pathlib.Path, "write_bytes", write_bytes)
    monkeypatch.setattr(pathlib.Path, "write_text", write_text)
    new = Heightmap(np.full((8, 8), 5.0, dtype=np.float32) + np.eye(8, dtype=np.float32))
    with pytest.raises(OutputWriteError, match=r"cannot write .*o\.r16.*: No space left on device; "
                                               "free some space"):
        write_heightmap(new, tmp_path / "o.r16", force=True)
    monkeypatch.undo()
    assert _listing(tmp_path) == old_pair  # byte for byte; no temporary file
    np.testing.assert_allclose(read_heightmap(tmp_path / "o.r16").heights,
                               np.arange(64).reshape(8, 8), atol=64 / 65535)


def test_full_disk_between_the_two_renames_rolls_back(tmp_path, old_pair, monkeypatch):
    real_replace = os.replace
    seen = []

    def replace(src, dst, *args, **kwargs):
        seen.append(os.path.basename(dst))
        if len(seen) == 2:  # sidecar renamed, then the RAW rename fails
            raise OSError(errno.ENOSPC, "No space left on device", str(dst))
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OutputWriteError):
        write_heightmap(Heightmap(np.ones((8, 8), np.float32) * np.arange(8)), tmp_path / "o.r16",
                        force=True)
    monkeypatch.undo()
    assert seen[0] == "o.r16.json" and seen[1] == "o.r16"
    assert _listing(tmp_path) == old_pair


def _cli(args, *, fsize: int | None = None, cwd=None):
    """Run the CLI in a subprocess, optionally with RLIMIT_FSIZE (writes beyond it fail with
    EFBIG, a real kernel-level write failure for every writer: Pillow, numpy, tifffile...)."""

    def limit():
        if fsize is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of a core dump
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    env = {**os.environ, "PYTHONPATH": SRC}
    return subprocess.run(
        [sys.executable, "-c", "from terrascape.cli import main; main()", *args],
        capture_output=True, text=True, preexec_fn=limit, env=env, cwd=cwd, timeout=120,
    )


@pytest.mark.parametrize("ext", [".png", ".r16", ".tif", ".npy", ".ter", ".exr"])
def test_file_too_large_is_one_line_exit_1_and_nothing_written(tmp_path, ext):
    out = tmp_path / f"big{ext}"
    proc = _cli(["generate", "diamond-square", "--size", "257", "-o", str(out), "-q"],
                fsize=4096)
    lines = _error_lines(proc.stderr)
    assert proc.returncode == 1, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("error: cannot write"), lines
    assert f"big{ext}" in lines[0]
    assert "File too large" in lines[0] or "the disk is probably full" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_usage_errors_on_output_paths_are_exit_2(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    src = tmp_path / "in.npy"
    np.save(src, np.zeros((4, 4), np.float32))
    cases = {
        str(tmp_path / "afile" / "o.png"): "is a file, not a folder",
        str(tmp_path / ("n" * 300 + ".png")): "use a shorter name",
        str(tmp_path / "adir"): "is a folder; the output must be a file path",
        str(tmp_path / "missing" / "o.png"): "does not exist; create it first",
    }
    for target, message in cases.items():
        assert run_app(["convert", str(src), target]) == 2, target
        lines = _error_lines(capsys.readouterr().err)
        assert len(lines) == 1 and message in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "afile", "in.npy"]
    assert list((tmp_path / "adir").iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_folder_is_refused_before_the_work(tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        assert run_app(["generate", "fault", "--size", "33", "-o", str(folder / "o.png")]) == 1
        assert "is not writable" in capsys.readouterr().err
    finally:
        folder.chmod(0o755)


def test_decompression_bomb_in_heightfromimage_is_one_line(tmp_path, capsys):
    from PIL import Image

    bomb = tmp_path / "bomb.png"
    Image.new("L", (16000, 16000)).save(bomb)  # 256 Mpx > 2 × Pillow's 89 Mpx limit
    assert run_app(["heightfromimage", str(bomb), "-o", str(tmp_path / "h.png")]) == 2
    lines = _error_lines(capsys.readouterr().err)
    assert len(lines) == 1 and "decompression bomb" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bomb.png"]
