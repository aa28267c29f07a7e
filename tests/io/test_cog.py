"""Cloud-Optimized GeoTIFF: written by GDAL's COG driver, validated by rio-cogeo (an
independent reader of the layout), read back by rasterio with its georeference and values."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
from rasterio.crs import CRS  # noqa: E402
from rasterio.transform import Affine  # noqa: E402
from rio_cogeo.cogeo import cog_validate  # noqa: E402

from terrascape import Heightmap  # noqa: E402
from terrascape.cli import run_app  # noqa: E402
from terrascape.errors import FileFormatError, InvalidParameterError  # noqa: E402
from terrascape.io import read_heightmap, write_heightmap  # noqa: E402
from terrascape.io.cog import write_cog  # noqa: E402

UTM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


def _utm_dem(path, rng) -> np.ndarray:
    data = rng.normal(800, 150, (1100, 1300)).astype(np.float32)
    data[3, 4] = data[700:703, 300] = -9999.0
    profile = dict(driver="GTiff", width=1300, height=1100, count=1, dtype="float32",
                   crs=CRS.from_epsg(32633), transform=UTM, nodata=-9999.0)
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(data, 1)
    return data


def _check_cog(path, data: np.ndarray, *, block: int = 512) -> None:
    valid, errors, warns = cog_validate(str(path))
    assert valid and not errors and not warns, (errors, warns)
    with rasterio.open(path) as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert ds.profile["tiled"] and ds.block_shapes == [(block, block)]
        assert ds.compression.name == "deflate" and ds.dtypes == ("float32",)
        # Overviews halve until one block holds the map.
        factors = ds.overviews(1)
        side = max(ds.shape)
        expected = []
        while side > block:
            side = -(-side // 2)
            expected.append(2 ** (len(expected) + 1))
        assert factors == expected
        np.testing.assert_array_equal(ds.read(1), data)


def test_utm_dem_as_cog_keeps_transform_crs_nodata_and_values(tmp_path, rng):
    data = _utm_dem(tmp_path / "dem.tif", rng)
    with pytest.warns(UserWarning, match="nodata"):
        hm = read_heightmap(tmp_path / "dem.tif")
    out = write_heightmap(hm, tmp_path / "dem_cog.tif", format="cog")
    _check_cog(out, data)
    with rasterio.open(out) as ds:
        assert ds.transform == UTM and ds.crs == CRS.from_epsg(32633) and ds.nodata == -9999.0
        # The first overview averages 2 × 2 samples, leaving nodata out.
        with rasterio.open(out, OVERVIEW_LEVEL=0) as ov:
            first = ov.read(1)
        block = data[:4, :4].astype(np.float64).reshape(2, 2, 2, 2).mean(axis=(1, 3))
        np.testing.assert_allclose(first[1, 1], block[1, 1], rtol=1e-6)
        valid = data[2:4, 4:6][data[2:4, 4:6] != -9999.0]
        np.testing.assert_allclose(first[1, 2], valid.mean(), rtol=1e-6)
    # terrascape reads it back as it was written.
    with pytest.warns(UserWarning, match="nodata"):
        back = read_heightmap(out)
    assert (back.crs, back.origin, back.nodata, back.spacing) == \
        ("EPSG:32633", (500000.0, 5000000.0), -9999.0, (30.0, 30.0))
    np.testing.assert_array_equal(back.heights, hm.heights)


def test_cog_bytes_are_deterministic_and_local_maps_keep_spacing(tmp_path, rng):
    hm = Heightmap(rng.random((600, 700)).astype(np.float32) * 50, (2.5, 2.5))
    a = write_cog(hm, tmp_path / "a.tif")
    b = write_cog(hm, tmp_path / "b.tif")
    assert a.read_bytes() == b.read_bytes()
    _check_cog(a, hm.heights)
    with rasterio.open(a) as ds:
        assert ds.crs is None and ds.transform == Affine(2.5, 0, 0, 0, -2.5, 0)
    assert read_heightmap(a).spacing == (2.5, 2.5)
    with pytest.raises(Exception, match="exists"):
        write_cog(hm, a)
    with pytest.raises(FileFormatError, match=r"\.tif"):
        write_cog(hm, tmp_path / "a.png")
    with pytest.raises(InvalidParameterError, match="multiple of 16"):
        write_cog(hm, tmp_path / "c.tif", blocksize=100)


def test_convert_cog_from_the_command_line(tmp_path, rng, capsys):
    data = _utm_dem(tmp_path / "dem.tif", rng)
    assert run_app(["convert", str(tmp_path / "dem.tif"), str(tmp_path / "web.tif"),
                    "--cog"]) == 0
    _check_cog(tmp_path / "web.tif", data)
    assert run_app(["convert", str(tmp_path / "dem.tif"), str(tmp_path / "web.png"),
                    "--cog"]) == 2
    assert "--cog writes a .tif" in capsys.readouterr().err
    assert not (tmp_path / "web.png").exists()


def test_a_local_map_at_spacing_one_is_written_without_gdals_warning(tmp_path, rng, capsys):
    # Spacing 1 and no CRS make GDAL's identity-like transform, which rasterio warns "may be
    # ignored": it is kept (read back below), so the user must not be told otherwise.
    hm = Heightmap(rng.random((40, 50)).astype(np.float32) * 9, (1.0, 1.0))
    np.save(tmp_path / "m.npy", hm.heights)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_cog(hm, tmp_path / "api.tif")
    assert run_app(["convert", str(tmp_path / "m.npy"), str(tmp_path / "cli.tif"),
                    "--cog"]) == 0
    assert "warning" not in capsys.readouterr().err.lower()
    for name in ("api.tif", "cli.tif"):
        with rasterio.open(tmp_path / name) as ds:
            assert ds.transform == Affine(1, 0, 0, 0, -1, 0) and ds.crs is None
        np.testing.assert_array_equal(read_heightmap(tmp_path / name).heights, hm.heights)
