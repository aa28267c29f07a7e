"""read_heightmap / write_heightmap dispatch, every format's round trip, overwrite and atomicity."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import (
    FileFormatError,
    Heightmap,
    InvalidParameterError,
    OutputExistsError,
)
from terrascape.io import (
    FORMATS,
    READ_EXTENSIONS,
    WRITE_EXTENSIONS,
    read_heightmap,
    write_heightmap,
)
from terrascape.io.heightmap_file import WRITE_METADATA, MetadataLossWarning

# extension -> (exact?, spacing kept?)
ROUND_TRIPS = {
    ".png": (False, True),
    ".r16": (False, True),
    ".raw": (False, True),
    ".r32": (True, True),
    ".tif": (True, True),
    ".tiff": (True, True),
    ".npy": (True, True),
    ".ter": (False, True),
}


@pytest.fixture
def terrain(rng) -> Heightmap:
    z, x = np.mgrid[0:17, 0:21]
    h = 300 * np.sin(x / 4.0) * np.cos(z / 5.0) + 50 * rng.random((17, 21)) + 1000
    return Heightmap(h.astype(np.float32), (2.0, 2.5))


@pytest.mark.parametrize("ext", sorted(ROUND_TRIPS))
def test_every_written_format_round_trips(terrain, tmp_path, ext):
    exact, keeps_spacing = ROUND_TRIPS[ext]
    path = write_heightmap(terrain, tmp_path / f"t{ext}")
    back = read_heightmap(path)
    assert back.shape == terrain.shape
    if exact:
        np.testing.assert_array_equal(back.heights, terrain.heights)
        assert back.metadata["step"] == 0.0
    else:
        step = back.metadata["step"]
        assert 0 < step <= 1.25 * (terrain.max - terrain.min) / 65535
        err = np.abs(back.heights.astype(np.float64) - terrain.heights).max()
        assert err <= step / 2 + 2e-4  # float32 rounding near 1350
    assert back.spacing == (pytest.approx((2.0, 2.5)) if keeps_spacing else (1.0, 1.0))
    assert back.metadata["source"] == str(path)


def test_bmp_is_an_8bit_normalised_preview(terrain, tmp_path):
    with pytest.warns(MetadataLossWarning, match=r"normalised to 0…1.*\.png \(16-bit\)"):
        write_heightmap(terrain, tmp_path / "p.bmp")
    with pytest.warns(UserWarning, match="no height units"):
        back = read_heightmap(tmp_path / "p.bmp")
    expected = (terrain.heights - terrain.min) / (terrain.max - terrain.min)
    assert np.abs(back.heights - expected).max() <= 0.5 / 255 + 1e-6


@pytest.mark.parametrize("ext", WRITE_EXTENSIONS)
def test_write_metadata_table_says_what_reads_back(terrain, tmp_path, ext, recwarn):
    """WRITE_METADATA is what the warnings rely on: check it against a real round trip."""
    keeps = WRITE_METADATA[ext.lstrip(".")]
    back = read_heightmap(write_heightmap(terrain, tmp_path / f"t{ext}"))
    assert (back.spacing == pytest.approx(terrain.spacing)) == keeps.spacing
    in_world_units = abs(back.max - terrain.max) < 0.01 * (terrain.max - terrain.min)
    assert in_world_units == keeps.world_units
    assert (back.metadata["step"] == 0.0) == keeps.exact
    lossy = [w for w in recwarn if issubclass(w.category, MetadataLossWarning)]
    assert bool(lossy) == (not keeps.world_units)


def test_lossless_writes_give_no_warning(terrain, tmp_path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for ext in (".png", ".r16", ".r32", ".tif", ".npy", ".ter"):
            read_heightmap(write_heightmap(terrain, tmp_path / f"q{ext}"))


def test_npy_sidecar_keeps_spacing_and_checks_the_grid(terrain, tmp_path):
    path = write_heightmap(terrain, tmp_path / "h.npy")
    assert np.load(path).shape == terrain.shape  # still a plain .npy for numpy
    assert read_heightmap(path).spacing == (2.0, 2.5)
    with pytest.raises(OutputExistsError, match=r"h\.npy"):
        write_heightmap(terrain, path)
    (tmp_path / "h.npy").unlink()
    with pytest.raises(OutputExistsError, match=r"h\.npy\.json"):  # the sidecar too
        write_heightmap(terrain, path)
    np.save(tmp_path / "other.npy", np.zeros((3, 4), np.float32))
    (tmp_path / "other.npy.json").write_text((tmp_path / "h.npy.json").read_text())
    with pytest.raises(FileFormatError, match="describes a 21×17 grid"):
        read_heightmap(tmp_path / "other.npy")
    np.save(tmp_path / "bare.npy", np.zeros((3, 4), np.float32))  # from another tool
    assert read_heightmap(tmp_path / "bare.npy").spacing == (1.0, 1.0)


def test_format_argument_overrides_extension(terrain, tmp_path):
    with pytest.warns(MetadataLossWarning, match="256 levels"):
        write_heightmap(terrain, tmp_path / "p8.png", format="png8")
    assert read_heightmap(tmp_path / "p8.png").metadata["dtype"] == "uint8"
    write_heightmap(terrain, tmp_path / "h.dat", format="r32")
    assert (tmp_path / "h.dat").stat().st_size == terrain.heights.size * 4
    with pytest.raises(FileFormatError, match="unknown output format"):
        write_heightmap(terrain, tmp_path / "x.png", format="gif")
    with pytest.raises(FileFormatError, match=r"needs a \.bmp path"):
        write_heightmap(terrain, tmp_path / "x.png", format="bmp")


def test_formats_table_is_consistent():
    assert set(WRITE_EXTENSIONS) <= set(READ_EXTENSIONS) == set(FORMATS)
    assert ".jpg" in READ_EXTENSIONS and ".jpg" not in WRITE_EXTENSIONS
    assert set(ROUND_TRIPS) <= set(WRITE_EXTENSIONS)


def test_read_errors(terrain, tmp_path):
    with pytest.raises(FileFormatError, match="file not found"):
        read_heightmap(tmp_path / "nope.png")
    with pytest.raises(FileFormatError, match="regular file"):
        read_heightmap(tmp_path)
    (tmp_path / "a.xyz").write_bytes(b"1234")
    with pytest.raises(FileFormatError, match=r"unknown heightmap extension '.xyz'.*\.png"):
        read_heightmap(tmp_path / "a.xyz")
    write_heightmap(terrain, tmp_path / "t.png")
    with pytest.raises(InvalidParameterError, match="only to headerless RAW"):
        read_heightmap(tmp_path / "t.png", size=(21, 17))
    with pytest.raises(InvalidParameterError, match="spacing dx must be > 0"):
        read_heightmap(tmp_path / "t.png", spacing=(0, 1))


def test_write_errors(terrain, tmp_path):
    with pytest.raises(FileFormatError, match=r"cannot write heightmaps as '\.jpg'"):
        write_heightmap(terrain, tmp_path / "a.jpg")
    with pytest.raises(FileFormatError, match="does not exist"):
        write_heightmap(terrain, tmp_path / "missing" / "a.png")
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        write_heightmap(terrain.heights, tmp_path / "a.png")


@pytest.mark.parametrize("ext", [".png", ".r16", ".tif", ".npy", ".ter", ".bmp"])
def test_no_overwrite_without_force(terrain, tmp_path, ext):
    target = tmp_path / f"t{ext}"
    target.write_bytes(b"precious")
    with pytest.raises(OutputExistsError, match="exists"):
        write_heightmap(terrain, target)
    assert target.read_bytes() == b"precious"
    write_heightmap(terrain, target, force=True)
    assert read_heightmap(target).shape == terrain.shape


def test_failing_write_leaves_no_file_and_keeps_existing(terrain, tmp_path, monkeypatch):
    import terrascape.io.tiff as tiff_module

    def broken_imwrite(path, data, **kwargs):
        with open(path, "wb") as fh:
            fh.write(b"II*\x00half a tiff")  # partial output, then a crash
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(tiff_module.tifffile, "imwrite", broken_imwrite)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_heightmap(terrain, tmp_path / "new.tif")
    assert not (tmp_path / "new.tif").exists()
    (tmp_path / "old.tif").write_bytes(b"old content")
    with pytest.raises(RuntimeError):
        write_heightmap(terrain, tmp_path / "old.tif", force=True)
    assert (tmp_path / "old.tif").read_bytes() == b"old content"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.tif"]  # no temp files left
