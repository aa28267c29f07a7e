"""(Geo)TIFF heightmaps: float round trip, integer DEMs, pixel scale, geographic spacing, nodata."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import tifffile

from terrascape import FileFormatError, Heightmap
from terrascape.io import geographic_spacing, read_tiff, write_tiff


def _geokeys(model_type: int, raster_type: int = 1) -> tuple[int, ...]:
    # header (version 1, rev 1.0, 2 keys), then (key, location 0 = inline, count 1, value)
    return (1, 1, 0, 2, 1024, 0, 1, model_type, 1025, 0, 1, raster_type)


def _write_geotiff(path, data, *, scale=None, tie=None, geokeys=None, nodata=None):
    tags = []
    if scale is not None:
        tags.append((33550, "d", 3, scale, True))
    if tie is not None:
        tags.append((33922, "d", 6, tie, True))
    if geokeys is not None:
        tags.append((34735, "H", len(geokeys), geokeys, True))
    if nodata is not None:
        tags.append((42113, "s", 0, nodata, True))
    tifffile.imwrite(path, data, photometric="minisblack", metadata=None, extratags=tags)


def test_float32_round_trip_is_exact_with_spacing(rng, tmp_path):
    hm = Heightmap(rng.normal(500, 200, (9, 14)).astype(np.float32), (12.5, 30.0))
    write_tiff(hm, tmp_path / "h.tif")
    back = read_tiff(tmp_path / "h.tif")
    np.testing.assert_array_equal(back.heights, hm.heights)
    assert back.spacing == (12.5, 30.0)
    with tifffile.TiffFile(tmp_path / "h.tif") as tif:
        page = tif.pages[0]
        assert page.dtype == np.float32
        assert tuple(page.tags[33550].value) == (12.5, 30.0, 0.0)


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint16, np.int32, np.float64])
def test_integer_and_float_dems_are_world_units(tmp_path, dtype):
    data = (np.arange(12).reshape(3, 4) * 7).astype(dtype)
    _write_geotiff(tmp_path / "d.tif", data, scale=(5.0, 5.0, 0.0))
    hm = read_tiff(tmp_path / "d.tif")
    np.testing.assert_array_equal(hm.heights, data.astype(np.float32))
    assert hm.spacing == (5.0, 5.0)
    assert hm.metadata["dtype"] == np.dtype(dtype).name
    assert read_tiff(tmp_path / "d.tif", vertical_scale=2).heights[2, 3] == 2 * 77


def test_projected_geotiff_uses_pixel_scale_in_metres(tmp_path):
    data = np.zeros((5, 6), np.float32)
    _write_geotiff(
        tmp_path / "p.tif",
        data,
        scale=(30.0, 25.0, 0.0),
        tie=(0, 0, 0, 500000.0, 4649776.0, 0),
        geokeys=_geokeys(1),
    )
    hm = read_tiff(tmp_path / "p.tif")
    assert hm.spacing == (30.0, 25.0)
    assert hm.metadata["geographic"] is False


def test_geographic_geotiff_converts_degrees_at_centre_latitude(tmp_path):
    # 21 rows, 0.1° apart, PixelIsPoint, tiepoint row 0 at 61°N -> centre row 10 is at 60°N.
    data = np.zeros((21, 21), np.float32)
    _write_geotiff(
        tmp_path / "g.tif",
        data,
        scale=(0.1, 0.1, 0.0),
        tie=(0, 0, 0, 15.0, 61.0, 0),
        geokeys=_geokeys(2, raster_type=2),
    )
    hm = read_tiff(tmp_path / "g.tif")
    # Independent check with the classic WGS84 series for metres per degree at 60°.
    phi = math.radians(60.0)
    lon_m = 111412.84 * math.cos(phi) - 93.5 * math.cos(3 * phi) + 0.118 * math.cos(5 * phi)
    lat_m = (
        111132.92
        - 559.82 * math.cos(2 * phi)
        + 1.175 * math.cos(4 * phi)
        - 0.0023 * math.cos(6 * phi)
    )
    assert hm.spacing[0] == pytest.approx(0.1 * lon_m, abs=0.05)
    assert hm.spacing[1] == pytest.approx(0.1 * lat_m, abs=0.05)
    assert hm.metadata["geographic"] is True


def test_geographic_spacing_matches_the_simple_rule_at_the_equator():
    dx, dz = geographic_spacing(1.0, 1.0, 0.0)
    assert dx == pytest.approx(111320, abs=1)
    assert dz == pytest.approx(110574, abs=1)
    dx45, _ = geographic_spacing(1.0, 1.0, 45.0)
    assert dx45 == pytest.approx(111320 * math.cos(math.radians(45)), rel=3e-3)
    assert geographic_spacing(1.0, 1.0, 90.0)[0] == pytest.approx(0.0, abs=1e-6)


def test_nodata_is_filled_from_nearest_neighbour_with_warning(tmp_path):
    data = np.array(
        [[10, 10, 10, 20], [10, -9999, 20, 20], [30, 30, -9999, -9999], [30, 30, 40, 40]],
        dtype=np.int16,
    )
    _write_geotiff(tmp_path / "n.tif", data, scale=(1.0, 1.0, 0.0), nodata="-9999")
    with pytest.warns(UserWarning, match="filled 3 nodata"):
        hm = read_tiff(tmp_path / "n.tif")
    assert hm.metadata["filled"] == 3
    assert np.isfinite(hm.heights).all()
    assert hm.heights[1, 1] in (10, 20, 30)  # one of its 4-neighbours
    assert hm.heights[2, 3] in (20, 40)  # nearest valid samples are above/below
    assert hm.heights[2, 2] in (20, 30, 40)
    valid = data != -9999
    np.testing.assert_array_equal(hm.heights[valid], data[valid])  # valid samples untouched


def test_float_nodata_and_nan_are_filled(tmp_path):
    data = np.full((4, 4), 5.0, np.float32)
    data[0, 0] = np.float32(-3.4028234663852886e38)
    data[3, 3] = np.nan
    _write_geotiff(tmp_path / "f.tif", data, nodata="-3.40282e+38")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hm = read_tiff(tmp_path / "f.tif")
    # GDAL's short "-3.40282e+38" text still matches the stored -FLT_MAX.
    assert hm.metadata["filled"] == 2
    assert any("filled 2 nodata" in str(w.message) for w in caught)
    np.testing.assert_array_equal(hm.heights, 5.0)


def test_all_nodata_multiband_and_corrupt_tiffs_are_errors(tmp_path):
    _write_geotiff(tmp_path / "a.tif", np.full((3, 3), -1, np.int16), nodata="-1")
    with pytest.raises(FileFormatError, match="all 9 samples are nodata"):
        read_tiff(tmp_path / "a.tif")
    tifffile.imwrite(tmp_path / "rgb.tif", np.zeros((4, 4, 3), np.uint8), photometric="rgb")
    with pytest.raises(FileFormatError, match="single-band"):
        read_tiff(tmp_path / "rgb.tif")
    write_tiff(Heightmap(np.ones((64, 64), np.float32)), tmp_path / "ok.tif")
    data = (tmp_path / "ok.tif").read_bytes()
    (tmp_path / "cut.tif").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match="cannot read TIFF"):
        read_tiff(tmp_path / "cut.tif")
    (tmp_path / "junk.tif").write_bytes(b"II*\x00garbage")
    with pytest.raises(FileFormatError):
        read_tiff(tmp_path / "junk.tif")
