"""`terrascape info` and `terrascape convert`, run in-process."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

import terrascape.cli  # noqa: F401  (registers the cmd_* commands)
from terrascape import Heightmap
from terrascape.cli.app import run_app
from terrascape.io import read_heightmap, write_heightmap


@pytest.fixture
def png(tmp_path, rng):
    hm = Heightmap(rng.uniform(-5, 95, (9, 12)).astype(np.float32), (3.0, 4.0))
    return write_heightmap(hm, tmp_path / "in.png"), hm


def test_info_prints_size_range_dtype_spacing_extent(png, capsys):
    path, hm = png
    assert run_app(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "12×9 (cols×rows)" in text
    assert "uint16" in text
    assert f"{hm.min:.4g}"[:4] in text and f"{hm.max:.4g}"[:4] in text
    assert "dx=3, dz=4" in text
    assert "33 × 32" in text  # extent (12-1)*3 × (9-1)*4
    assert "NaN/nodata filled" in text


def test_info_reports_filled_nodata(tmp_path, capsys):
    data = np.array([[1, 2, 3], [4, -1, 6], [7, 8, -1]], dtype=np.int16)
    tifffile.imwrite(tmp_path / "n.tif", data, extratags=[(42113, "s", 0, "-1", True)])
    assert run_app(["info", str(tmp_path / "n.tif")]) == 0
    captured = capsys.readouterr()
    assert "filled 2 nodata" in captured.err
    row = next(line for line in captured.out.splitlines() if "NaN/nodata filled" in line)
    assert row.replace("│", " ").split()[-1] == "2"


def test_info_raw_needs_size(tmp_path, capsys):
    (tmp_path / "r.r16").write_bytes(np.arange(12, dtype="<u2").tobytes())
    assert run_app(["info", str(tmp_path / "r.r16")]) == 2
    assert "--size" in capsys.readouterr().err
    assert run_app(["info", str(tmp_path / "r.r16"), "--size", "4x3"]) == 0
    assert "4×3 (cols×rows)" in capsys.readouterr().out
    assert run_app(["info", str(tmp_path / "r.r16"), "--size", "five"]) == 2


def test_convert_writes_by_extension(png, tmp_path, capsys):
    path, hm = png
    assert run_app(["convert", str(path), str(tmp_path / "out.ter")]) == 0
    back = read_heightmap(tmp_path / "out.ter")
    assert np.abs(back.heights - hm.heights).max() < 100 / 65535 * 2
    assert back.spacing == (3.0, 4.0)
    assert (
        run_app(
            [
                "convert",
                str(path),
                str(tmp_path / "o.npy"),
                "--spacing",
                "2,5",
                "--vertical-scale",
                "2",
            ]
        )
        == 0
    )
    np.testing.assert_allclose(np.load(tmp_path / "o.npy"), 2 * hm.heights, atol=0.01)


def test_convert_refuses_existing_output_without_force(png, tmp_path, capsys):
    path, _ = png
    target = tmp_path / "exists.tif"
    target.write_bytes(b"keep me")
    assert run_app(["convert", str(path), str(target)]) == 2
    assert "exists" in capsys.readouterr().err
    assert target.read_bytes() == b"keep me"
    assert run_app(["convert", str(path), str(target), "--force"]) == 0
    assert read_heightmap(target).shape == (9, 12)


def test_convert_bad_inputs_exit_2(tmp_path, png, capsys):
    path, _ = png
    assert run_app(["convert", str(tmp_path / "missing.png"), str(tmp_path / "o.tif")]) == 2
    assert "not found" in capsys.readouterr().err
    (tmp_path / "bad.ter").write_bytes(b"NOTTERRAGEN" * 4)
    assert run_app(["convert", str(tmp_path / "bad.ter"), str(tmp_path / "o.tif")]) == 2
    assert run_app(["convert", str(path), str(tmp_path / "o.gif")]) == 2
    assert "cannot write heightmaps as '.gif'" in capsys.readouterr().err
    assert run_app(["convert", str(path), str(tmp_path / "o.tif"), "--spacing", "-1"]) == 2
    assert not (tmp_path / "o.tif").exists()
    assert run_app(["convert", str(path)]) == 2  # missing argument: click usage error


def test_convert_says_what_a_preview_loses_and_npy_keeps_spacing(tmp_path, capsys):
    """The newcomer's bug: `convert hm.png hm.bmp` claimed 0 … 300, spacing (4, 4)."""
    z, x = np.mgrid[0:33, 0:33]
    src = tmp_path / "hm.png"
    write_heightmap(Heightmap((300 * (x + z) / 64).astype(np.float32), (4.0, 4.0)), src)
    assert run_app(["convert", str(src), str(tmp_path / "hm.bmp")]) == 0
    captured = capsys.readouterr()
    assert "stored as 0 … 1" in captured.out and "not stored" in captured.out
    assert "normalised to 0…1" in captured.err and ".npy" in captured.err
    assert run_app(["convert", str(src), str(tmp_path / "hm.npy")]) == 0
    assert "not stored" not in capsys.readouterr().out
    # erode on the .npy erodes with the file's spacing and keeps it
    assert run_app(["erode", str(tmp_path / "hm.npy"), str(tmp_path / "e.npy"),
                    "--thermal", "2", "-q"]) == 0
    assert read_heightmap(tmp_path / "e.npy").spacing == (4.0, 4.0)
