"""NumPy .npy heightmaps: exact round trip and the rejections (NaN, 3-D, pickles, junk)."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import FileFormatError, Heightmap, InvalidParameterError
from terrascape.io import read_npy, write_npy


def test_round_trip_is_exact_float32(rng, tmp_path):
    hm = Heightmap(rng.normal(0, 1e3, (6, 10)).astype(np.float32), (4.0, 4.0))
    write_npy(hm, tmp_path / "h.npy")
    raw = np.load(tmp_path / "h.npy")
    assert raw.dtype == np.float32 and raw.shape == (6, 10)
    back = read_npy(tmp_path / "h.npy")
    np.testing.assert_array_equal(back.heights, hm.heights)
    assert back.spacing == (4.0, 4.0)  # from the h.npy.json sidecar
    assert read_npy(tmp_path / "h.npy", spacing=2.0).spacing == (2.0, 2.0)  # override
    (tmp_path / "h.npy.json").unlink()
    assert read_npy(tmp_path / "h.npy").spacing == (1.0, 1.0)  # a bare .npy has none


def test_integer_arrays_and_vertical_scale(tmp_path):
    np.save(tmp_path / "i.npy", np.arange(6, dtype=np.int64).reshape(2, 3))
    hm = read_npy(tmp_path / "i.npy", vertical_scale=0.5)
    np.testing.assert_array_equal(hm.heights, np.arange(6).reshape(2, 3) * 0.5)
    assert hm.metadata["dtype"] == "int64"


def test_nan_is_filled_with_a_warning_like_tiff(tmp_path):
    a = np.zeros((3, 3))
    a[0, 2] = np.nan
    a[1, 1] = np.inf
    a[2, 2] = 7.0
    np.save(tmp_path / "n.npy", a)
    with pytest.warns(UserWarning, match="filled 2 NaN/infinite"):
        hm = read_npy(tmp_path / "n.npy")
    assert np.isfinite(hm.heights).all() and hm.metadata["filled"] == 2
    assert hm.heights[0, 2] == 0.0 and hm.heights[2, 2] == 7.0
    np.save(tmp_path / "all.npy", np.full((2, 2), np.nan))
    with pytest.raises(FileFormatError, match="all 4 samples are NaN"):
        read_npy(tmp_path / "all.npy")


def test_bad_arrays_and_files(tmp_path):
    np.save(tmp_path / "3d.npy", np.zeros((2, 3, 4)))
    with pytest.raises(FileFormatError, match=r"2-D array.*\(2, 3, 4\)"):
        read_npy(tmp_path / "3d.npy")
    np.save(tmp_path / "1d.npy", np.zeros(5))
    with pytest.raises(FileFormatError, match="2-D"):
        read_npy(tmp_path / "1d.npy")
    np.save(tmp_path / "obj.npy", np.array([[{}, 1]], dtype=object), allow_pickle=True)
    with pytest.raises(FileFormatError, match="cannot read"):
        read_npy(tmp_path / "obj.npy")
    np.save(tmp_path / "str.npy", np.array([["a", "b"], ["c", "d"]]))
    with pytest.raises(FileFormatError, match="integer or float"):
        read_npy(tmp_path / "str.npy")
    np.save(tmp_path / "full.npy", np.zeros((50, 50)))
    data = (tmp_path / "full.npy").read_bytes()
    (tmp_path / "cut.npy").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match="cannot read"):
        read_npy(tmp_path / "cut.npy")
    np.save(tmp_path / "tiny.npy", np.zeros((1, 5)))
    with pytest.raises(InvalidParameterError, match="at least 2×2"):
        read_npy(tmp_path / "tiny.npy")
