"""Every export destination writes its files as one unit: interrupted or failing half-way,
it leaves none of them, not even those it had finished, and with ``force`` the previous
export's files stay byte for byte."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.errors import Interrupted, OutputExistsError
from terrascape.export import ExportOptions, destinations, get_destination
from terrascape.io import atomic
from terrascape.io.atomic import output_unit

# options that each destination takes for a small map (the engines crop it to a size they
# accept, the globes place it somewhere)
OPTIONS = {"cesium": {"lonlat": (15.9, 45.8), "max_zoom": 12},
           "terrain_rgb": {"lonlat": (15.9, 45.8), "max_zoom": 12}}


def _map() -> Heightmap:
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:130, 0:130] / 130.0
    heights = 300.0 * np.sin(3 * x) * np.cos(2 * y) + rng.random((130, 130)) * 5.0
    return Heightmap(heights.astype(np.float32), (30.0, 30.0))


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _export(name: str, folder: Path, *, force: bool = False, stop_at: int | None = None,
            monkeypatch=None) -> int:
    """Export to ``folder``; with ``stop_at``, an interrupt as its ``stop_at``-th batch of
    files is finished (written, about to be committed or handed to the unit: every batch
    reads the umask then). Returns how many batches it wrote."""
    batches = []
    real_umask = atomic._current_umask

    def umask():
        batches.append(1)
        if stop_at is not None and len(batches) == stop_at:
            raise Interrupted(signal.SIGTERM)
        return real_umask()

    monkeypatch.setattr(atomic, "_current_umask", umask)
    options = ExportOptions(name="T", fit="crop", force=force, **OPTIONS.get(name, {}))
    try:
        get_destination(name).export(_map(), folder, options)
    finally:
        monkeypatch.setattr(atomic, "_current_umask", real_umask)
    return len(batches)


@pytest.mark.parametrize("name", destinations())
def test_an_export_interrupted_at_its_last_file_leaves_none(tmp_path, monkeypatch, name):
    whole = tmp_path / "whole"
    whole.mkdir()
    batches = _export(name, whole, monkeypatch=monkeypatch)
    written = _files(whole)
    assert batches >= 2 and len(written) >= 2, "a destination of one file tests nothing here"

    cut = tmp_path / "cut"
    cut.mkdir()
    with pytest.raises(Interrupted):
        _export(name, cut, stop_at=batches, monkeypatch=monkeypatch)
    assert _files(cut) == {}, "files finished before the interrupt were left"

    # over the complete export with force: the old files stay, byte for byte
    with pytest.raises(Interrupted):
        _export(name, whole, force=True, stop_at=batches, monkeypatch=monkeypatch)
    assert _files(whole) == written
    # and uninterrupted with force, the same bytes again (no temporary file left)
    assert _export(name, whole, force=True, monkeypatch=monkeypatch) == batches
    assert _files(whole) == written


@pytest.mark.parametrize("name", ["unreal", "web"])
def test_an_existing_file_without_force_stops_the_export_before_any_file(tmp_path,
                                                                           monkeypatch, name):
    whole = tmp_path / "whole"
    whole.mkdir()
    _export(name, whole, monkeypatch=monkeypatch)
    # the last file written, not the hidden manifest that follows it
    last = max((p for p in whole.rglob("*") if not p.name.startswith(".")),
               key=lambda p: p.stat().st_mtime_ns)
    taken = tmp_path / "taken"
    (taken / last.relative_to(whole)).parent.mkdir(parents=True, exist_ok=True)
    (taken / last.relative_to(whole)).write_bytes(b"mine")
    with pytest.raises(OutputExistsError):
        _export(name, taken, monkeypatch=monkeypatch)
    assert _files(taken) == {str(last.relative_to(whole)): b"mine"}


def test_a_unit_commits_at_its_end_and_joins_an_outer_one(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    with output_unit():
        with atomic.atomic_output(a) as tmp:
            Path(tmp).write_text("A")
        assert not a.exists()  # waits for the unit
        with output_unit(), atomic.atomic_output(b) as tmp:  # joins the outer unit
            Path(tmp).write_text("B")
        assert not b.exists()
    assert a.read_text() == "A" and b.read_text() == "B"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]
    with pytest.raises(Exception, match="written twice"), output_unit():
        for _ in range(2):
            with atomic.atomic_output(tmp_path / "c.txt") as tmp:
                Path(tmp).write_text("C")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]


# `export unreal` whose second PNG pauses half-way and says so: the signal lands while the
# first PNG is finished and waiting for the unit
SLOW_SECOND_PNG = """
import sys, time
from PIL import Image
real = Image.Image.save
count = [0]
def slow(self, fp, *args, **kwargs):
    count[0] += 1
    if count[0] == 2:
        print("writing", flush=True)
        time.sleep(30)
    return real(self, fp, *args, **kwargs)
Image.Image.save = slow
from terrascape.cli import main
main()
"""


def test_sigterm_mid_export_leaves_the_old_export_byte_for_byte(tmp_path):
    np.save(tmp_path / "m.npy", _map().heights)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    command = ["export", "unreal", str(tmp_path / "m.npy"), "-o", str(tmp_path / "ue"),
               "--tiles", "2", "--layers", "--fit", "pad"]
    first = subprocess.run([sys.executable, "-c", SLOW_SECOND_PNG.replace("== 2", "== -1"),
                            *command], capture_output=True, text=True, env=env, timeout=300)
    assert first.returncode == 0, first.stderr
    old = _files(tmp_path / "ue")
    assert len(old) >= 3
    proc = subprocess.Popen([sys.executable, "-c", SLOW_SECOND_PNG, *command, "--force"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout.readline().strip() == "writing"
    proc.send_signal(signal.SIGTERM)
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "nothing was written" in err and "Traceback" not in err
    assert _files(tmp_path / "ue") == old  # no new file, no temporary, the old bytes


def _limited(fsize: int):
    def limit():
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of a core dump
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
    return limit


CLI_OPTIONS = {"cesium": ["--lonlat", "15,45", "--max-zoom", "12"],
               "terrain_rgb": ["--lonlat", "15,45", "--max-zoom", "12"],
               "unreal": ["--fit", "pad", "--layers"], "unity": ["--layers"]}


@pytest.mark.parametrize("name", destinations())
def test_a_file_too_large_in_an_export_is_one_line_and_leaves_nothing(tmp_path, name):
    """Files of at most 700 bytes can be written, larger ones fail with EFBIG (a real
    kernel write failure, in whatever library writes the file: Pillow, tifffile, OpenEXR,
    trimesh): one line, exit 1, and no file nor the folder the command made. (Which file
    fails first depends on the destination's order; the interrupt tests above put the
    failure after finished files.)"""
    rng = np.random.default_rng(3)
    np.save(tmp_path / "m.npy", (rng.random((257, 257)) * 50).astype(np.float32))
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", "from terrascape.cli import main; main()", "export", name,
         str(tmp_path / "m.npy"), "-o", str(out), "-q", *CLI_OPTIONS.get(name, [])],
        capture_output=True, text=True, env=env, preexec_fn=_limited(700), timeout=300)
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error")]
    assert proc.returncode == 1, proc.stderr
    assert len(errors) == 1 and errors[0].startswith("error: cannot write"), proc.stderr
    assert "File too large" in errors[0] or "the disk is probably full" in errors[0]
    assert "Traceback" not in proc.stderr
    assert not out.exists(), sorted(str(p) for p in out.rglob("*"))


def _export_cli(src: Path, folder: Path, name: str, *options: str) -> int:
    return run_app(["export", name, str(src), "-o", str(folder), "-q", *options])


def test_a_forced_export_replaces_the_previous_one_not_mixes_with_it(tmp_path, capsys):
    """Four tiles, then two tiles with --force: the folder holds the two-tile export, the
    same bytes as one made in an empty folder, and the user's own files."""
    np.save(tmp_path / "m.npy", _map().heights)
    src = tmp_path / "m.npy"
    ue = tmp_path / "ue"
    assert _export_cli(src, ue, "unreal", "--fit", "pad", "--tiles", "4", "--layers") == 0
    four = _files(ue)
    assert "m_x3_y3.png" in four and "m_x3_y3_layer_grass.png" in four
    (ue / "mine.txt").write_text("mine")
    (ue / "m_x9_y9.png").write_bytes(b"not from an export")  # never listed: never removed
    capsys.readouterr()
    assert _export_cli(src, ue, "unreal", "--fit", "pad", "--tiles", "2", "--layers",
                       "--force") == 0
    # 16 tiles and their 5 layers each, against 4 tiles: 72 files said to be removed
    assert ("removed 72 files of the previous unreal export named m that this one no longer "
            "writes") in capsys.readouterr().out
    fresh = tmp_path / "fresh"
    assert _export_cli(src, fresh, "unreal", "--fit", "pad", "--tiles", "2", "--layers") == 0
    assert _files(ue) == {**_files(fresh), "mine.txt": b"mine",
                          "m_x9_y9.png": b"not from an export"}
    assert not [p for p in ue.iterdir() if ".part" in p.name or ".bak" in p.name]


def test_a_forced_export_that_fails_at_its_commit_keeps_the_previous_one(tmp_path,
                                                                         monkeypatch):
    np.save(tmp_path / "m.npy", _map().heights)
    src = tmp_path / "m.npy"
    ue = tmp_path / "ue"
    assert _export_cli(src, ue, "unreal", "--fit", "pad", "--tiles", "4") == 0
    four = _files(ue)
    real_replace = os.replace

    def replace(source, target, *args, **kwargs):
        # the last stale tile's removal fails: everything renamed or removed goes back
        if Path(source).name == "m_x3_y3.png":
            raise OSError(28, "No space left on device", str(source))
        return real_replace(source, target, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace)
    assert _export_cli(src, ue, "unreal", "--fit", "pad", "--tiles", "2", "--force") == 1
    monkeypatch.setattr(os, "replace", real_replace)
    assert _files(ue) == four


def test_a_forced_pyramid_with_fewer_levels_leaves_no_deeper_tile(tmp_path):
    np.save(tmp_path / "m.npy", _map().heights)
    src = tmp_path / "m.npy"
    tiles = tmp_path / "tiles"
    assert _export_cli(src, tiles, "cesium", "--lonlat", "15,45", "--max-zoom", "12") == 0
    assert (tiles / "12").is_dir()
    assert _export_cli(src, tiles, "cesium", "--lonlat", "15,45", "--max-zoom", "9",
                       "--force") == 0
    fresh = tmp_path / "fresh"
    assert _export_cli(src, fresh, "cesium", "--lonlat", "15,45", "--max-zoom", "9") == 0
    assert _files(tiles) == _files(fresh)
    assert sorted(p.name for p in tiles.iterdir() if p.is_dir()) == [str(z) for z in
                                                                     sorted(range(10), key=str)]


def test_the_cli_sums_up_a_pyramids_tiles_and_lists_a_few(tmp_path, capsys):
    rng = np.random.default_rng(5)
    np.save(tmp_path / "m.npy", (rng.random((257, 257)) * 50).astype(np.float32))
    src = tmp_path / "m.npy"
    capsys.readouterr()
    assert _export_cli(src, tmp_path / "c", "cesium", "--lonlat", "15,45") == 0
    lines = capsys.readouterr().out.strip().splitlines()
    tiles = list((tmp_path / "c").rglob("*.terrain"))
    assert len(tiles) > 20
    size = sum(p.stat().st_size for p in tiles)
    deepest = max(int(p.relative_to(tmp_path / "c").parts[0]) for p in tiles)
    assert lines[-1] == (f"{tmp_path / 'c' / '0'} … {tmp_path / 'c' / str(deepest)}: "
                         f"{len(tiles):,} files ({size:,} bytes)")
    assert not [line for line in lines if ".terrain (" in line]
    assert any(line.startswith(f"{tmp_path / 'c' / 'layer.json'} (") for line in lines)
    # a few tiles are listed one by one
    assert _export_cli(src, tmp_path / "r", "terrain_rgb", "--lonlat", "15,45",
                       "--max-zoom", "12") == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if ".png (" in line]
    assert len(listed) == len(list((tmp_path / "r").rglob("*.png"))) == 13
