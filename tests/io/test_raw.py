"""RAW 16-bit and float32 heightmaps: size inference, sidecar, byte order, bad lengths."""

from __future__ import annotations

import json

import numpy as np
import pytest

from terrascape import FileFormatError, Heightmap, InvalidParameterError, OutputExistsError
from terrascape.io import read_raw16, read_raw32, sidecar_path, write_raw16, write_raw32


def test_r16_is_little_endian_unsigned_and_square_size_is_inferred(tmp_path):
    codes = np.array([[0, 1, 256], [65535, 4660, 2], [9, 8, 7]], dtype="<u2")
    raw = codes.tobytes()
    assert raw[:6] == b"\x00\x00\x01\x00\x00\x01"  # little-endian on disk
    (tmp_path / "a.r16").write_bytes(raw)
    hm = read_raw16(tmp_path / "a.r16", vertical_scale=655.35)
    assert hm.shape == (3, 3)
    np.testing.assert_allclose(hm.heights, codes * 0.01, rtol=1e-6)
    assert hm.metadata["step"] == pytest.approx(0.01)
    assert read_raw16(tmp_path / "a.r16").heights[1, 0] == 1.0


def test_non_square_needs_size_and_size_must_match(tmp_path):
    codes = np.arange(6 * 4, dtype="<u2").reshape(4, 6)
    (tmp_path / "b.raw").write_bytes(codes.tobytes())
    with pytest.raises(FileFormatError, match=r"not a square grid.*size=\(cols, rows\)"):
        read_raw16(tmp_path / "b.raw")
    hm = read_raw16(tmp_path / "b.raw", size=(6, 4), vertical_scale=65535)
    np.testing.assert_array_equal(hm.heights, codes)
    assert (hm.cols, hm.rows) == (6, 4)
    with pytest.raises(FileFormatError, match=r"5×4 .*needs 40 bytes.*48 bytes"):
        read_raw16(tmp_path / "b.raw", size=(5, 4))
    with pytest.raises(InvalidParameterError, match="size"):
        read_raw16(tmp_path / "b.raw", size=(6, 4, 1))


def test_odd_length_and_empty_files(tmp_path):
    (tmp_path / "odd.r16").write_bytes(b"\x00" * 9)
    with pytest.raises(FileFormatError, match="not a multiple of 2"):
        read_raw16(tmp_path / "odd.r16")
    (tmp_path / "odd.r32").write_bytes(b"\x00" * 18)
    with pytest.raises(FileFormatError, match="not a multiple of 4"):
        read_raw32(tmp_path / "odd.r32")
    (tmp_path / "e.r16").write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty"):
        read_raw16(tmp_path / "e.r16")


def test_r16_round_trip_with_sidecar(rng, tmp_path):
    hm = Heightmap(rng.uniform(-30, 970, (7, 11)).astype(np.float32), (0.5, 0.25))
    write_raw16(hm, tmp_path / "h.r16")
    side = json.loads(sidecar_path(tmp_path / "h.r16").read_text())
    assert (side["cols"], side["rows"], side["dtype"]) == (11, 7, "<u2")
    back = read_raw16(tmp_path / "h.r16")  # size from the sidecar, not square
    assert back.shape == (7, 11) and back.spacing == (0.5, 0.25)
    step = (hm.max - hm.min) / 65535
    assert np.abs(back.heights.astype(np.float64) - hm.heights).max() <= step / 2 + 1e-4
    codes = np.frombuffer((tmp_path / "h.r16").read_bytes(), "<u2")
    assert codes.min() == 0 and codes.max() == 65535


def test_r32_round_trip_is_exact(rng, tmp_path):
    hm = Heightmap(rng.normal(0, 100, (5, 9)).astype(np.float32), (3.0, 3.0))
    write_raw32(hm, tmp_path / "h.r32")
    assert (tmp_path / "h.r32").stat().st_size == 5 * 9 * 4
    back = read_raw32(tmp_path / "h.r32")
    np.testing.assert_array_equal(back.heights, hm.heights)
    assert back.spacing == (3.0, 3.0)
    # Without the sidecar the bytes alone still read (size given).
    write_raw32(hm, tmp_path / "n.r32", sidecar=False)
    assert not sidecar_path(tmp_path / "n.r32").exists()
    np.testing.assert_array_equal(read_raw32(tmp_path / "n.r32", size=(9, 5)).heights, hm.heights)


def test_r32_nan_is_filled_with_a_warning_like_tiff(tmp_path):
    a = np.ones((3, 3), "<f4")
    a[1, 1] = np.nan
    (tmp_path / "n.r32").write_bytes(a.tobytes())
    with pytest.warns(UserWarning, match="filled 1 NaN/infinite"):
        hm = read_raw32(tmp_path / "n.r32")
    np.testing.assert_array_equal(hm.heights, np.ones((3, 3)))
    assert hm.metadata["filled"] == 1


def test_sidecar_is_part_of_overwrite_protection(rng, tmp_path):
    hm = Heightmap(rng.random((3, 3)).astype(np.float32))
    sidecar_path(tmp_path / "h.r16").write_text("keep")
    with pytest.raises(OutputExistsError):
        write_raw16(hm, tmp_path / "h.r16")
    assert not (tmp_path / "h.r16").exists()  # refused before writing anything
    assert sidecar_path(tmp_path / "h.r16").read_text() == "keep"
    # sidecar=False with force removes the stale sidecar (it would be trusted on read).
    write_raw16(hm, tmp_path / "h.r16", sidecar=False, force=True)
    assert not sidecar_path(tmp_path / "h.r16").exists()


def test_corrupt_or_mismatched_sidecar(tmp_path):
    (tmp_path / "h.r16").write_bytes(b"\x00" * 8)
    sidecar_path(tmp_path / "h.r16").write_text("{broken")
    with pytest.raises(FileFormatError, match="corrupt"):
        read_raw16(tmp_path / "h.r16")
    sidecar_path(tmp_path / "h.r16").write_text(
        json.dumps({"format": "terrascape", "version": 1, "dtype": "<f4", "cols": 2, "rows": 1})
    )
    with pytest.raises(FileFormatError, match="dtype"):
        read_raw16(tmp_path / "h.r16")
