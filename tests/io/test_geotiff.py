"""GeoTIFF georeference round trips: terrascape ↔ rasterio (GDAL), the tifffile fallback,
reprojection of a real DEM in degrees, and the degrees-without-CRS warning."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
from rasterio.crs import CRS  # noqa: E402
from rasterio.transform import Affine  # noqa: E402

from terrascape import Heightmap  # noqa: E402
from terrascape.cli import run_app  # noqa: E402
from terrascape.io import (  # noqa: E402
    geotiff,
    read_heightmap,
    write_heightmap,
)
from terrascape.io.tiff import read_tiff, write_tiff  # noqa: E402

UTM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


def _utm_dem(path, rng, *, holes=True):
    data = (rng.normal(800, 150, (40, 56))).astype(np.float32)
    if holes:
        data[3, 4] = data[20:23, 30] = -9999.0
    profile = dict(driver="GTiff", width=56, height=40, count=1, dtype="float32",
                   crs=CRS.from_epsg(32633), transform=UTM, nodata=-9999.0)
    with rasterio.open(path, "w", **profile) as ds:
        ds.write(data, 1)
    return data


def test_utm_dem_round_trips_transform_crs_nodata_and_values(tmp_path, rng):
    data = _utm_dem(tmp_path / "dem.tif", rng)
    with pytest.warns(UserWarning, match="filled 4 nodata"):
        hm = read_heightmap(tmp_path / "dem.tif")
    assert hm.crs == "EPSG:32633"
    assert hm.origin == (500000.0, 5000000.0)
    assert hm.nodata == -9999.0
    assert hm.spacing == (30.0, 30.0)
    assert np.all(hm.heights > 0)  # holes filled for the renderer
    write_heightmap(hm, tmp_path / "back.tif")
    with rasterio.open(tmp_path / "back.tif") as ds:
        assert ds.transform == UTM
        assert ds.crs == CRS.from_epsg(32633)
        assert ds.nodata == -9999.0
        np.testing.assert_array_equal(ds.read(1), data)


def test_wkt_crs_and_geographic_transform_are_exact(tmp_path, rng):
    """A CRS with no EPSG code keeps its WKT; a degree transform survives the metres spacing."""
    wkt = CRS.from_proj4("+proj=tmerc +lat_0=0 +lon_0=15.5 +k=0.9999 +x_0=500000 "
                         "+y_0=0 +ellps=GRS80 +units=m +no_defs").to_wkt()
    data = rng.normal(300, 20, (12, 10)).astype(np.float32)
    for crs, transform in ((CRS.from_wkt(wkt), Affine(2.5, 0, 12345.5, 0, -2.5, 67890.25)),
                           (CRS.from_epsg(4326),
                            Affine(1 / 1200, 0, -84.41375, 0, -1 / 1200, 36.73291667))):
        path = tmp_path / "g.tif"
        with rasterio.open(path, "w", driver="GTiff", width=10, height=12, count=1,
                           dtype="float32", crs=crs, transform=transform) as ds:
            ds.write(data, 1)
        hm = read_heightmap(path)
        if crs.is_geographic:
            assert hm.crs == "EPSG:4326"
            assert 70.0 < hm.spacing[0] < 80.0 and 92.0 < hm.spacing[1] < 93.0  # metres
        write_heightmap(hm, tmp_path / "o.tif", force=True)
        with rasterio.open(tmp_path / "o.tif") as ds:
            assert ds.transform == transform
            assert ds.crs == crs
            np.testing.assert_array_equal(ds.read(1), data)
        path.unlink()


def test_tifffile_fallback_keeps_epsg_origin_and_nodata(tmp_path, rng, monkeypatch):
    data = _utm_dem(tmp_path / "dem.tif", rng)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hm = read_tiff(tmp_path / "dem.tif")  # the reader used without rasterio
    assert (hm.crs, hm.origin, hm.nodata) == ("EPSG:32633", (500000.0, 5000000.0), -9999.0)
    monkeypatch.setattr(geotiff, "rasterio_available", lambda: False)
    write_tiff(hm, tmp_path / "t.tif")
    monkeypatch.undo()
    with rasterio.open(tmp_path / "t.tif") as ds:  # GDAL reads tifffile's geokeys
        assert ds.transform == UTM
        assert ds.crs == CRS.from_epsg(32633)
        assert ds.nodata == -9999.0
        np.testing.assert_array_equal(ds.read(1), data)


def test_plain_heightmap_defaults_are_backward_compatible(tmp_path):
    hm = Heightmap(np.ones((3, 4)), 2.0)
    assert (hm.origin, hm.crs, hm.nodata) == ((0.0, 0.0), None, None)
    assert hm.with_heights(np.zeros((3, 4))).crs is None
    write_heightmap(hm, tmp_path / "p.tif")
    back = read_heightmap(tmp_path / "p.tif")
    assert back.spacing == (2.0, 2.0) and back.crs is None and back.origin == (0.0, 0.0)


def _jacksboro():
    from matplotlib.cbook import get_sample_data

    d = get_sample_data("jacksboro_fault_dem.npz")
    # the file's "ymin" is the northern edge (rows run south)
    return (d["elevation"].astype(np.float32), float(d["dx"]), float(d["xmin"]),
            float(d["ymin"]))


def test_real_dem_in_degrees_reprojects_to_utm(tmp_path):
    z, deg, west, north = _jacksboro()
    with rasterio.open(tmp_path / "j.tif", "w", driver="GTiff", width=z.shape[1],
                       height=z.shape[0], count=1, dtype="float32", crs="EPSG:4326",
                       transform=Affine(deg, 0, west, 0, -deg, north)) as ds:
        ds.write(z, 1)
    hm = read_heightmap(tmp_path / "j.tif")
    assert geotiff.degree_warning(hm) is None  # the CRS says degrees, spacing is metres
    assert 73.0 < hm.spacing[0] < 76.0 and 92.0 < hm.spacing[1] < 93.0
    utm = geotiff.reproject(hm, "EPSG:32616")
    assert utm.crs == "EPSG:32616" and not utm.metadata["geographic"]
    assert 60.0 < utm.spacing[0] < 90.0
    ex, ez = utm.extent
    assert 28_000 < ex < 34_000 and 29_000 < ez < 34_000  # ≈ 0.336° × 0.287° at 36.6° N
    assert utm.min >= 230 and utm.max <= 1080
    # the CLI: degrees in, UTM out, read back by GDAL
    assert run_app(["convert", str(tmp_path / "j.tif"), str(tmp_path / "u.tif"),
                    "--reproject", "EPSG:32616"]) == 0
    with rasterio.open(tmp_path / "u.tif") as ds:
        assert ds.crs == CRS.from_epsg(32616)
        assert ds.transform.a == pytest.approx(utm.spacing[0])
        band = ds.read(1)
        assert band[band != ds.nodata].max() <= 1080


def test_degrees_without_crs_warn_naming_the_fix(tmp_path, capsys):
    z, deg, _west, _north = _jacksboro()
    hm = Heightmap(z, deg)
    message = geotiff.degree_warning(hm)
    assert message is not None and "--spacing" in message and "--crs" in message
    np.save(tmp_path / "j.npy", z)
    assert run_app(["info", str(tmp_path / "j.npy"), "--spacing", str(deg)]) == 0
    assert "looks like degrees" in capsys.readouterr().err
    # --crs declares the degrees: spacing becomes metres, no warning
    assert run_app(["info", str(tmp_path / "j.npy"), "--spacing", str(deg),
                    "--crs", "EPSG:4326"]) == 0
    captured = capsys.readouterr()
    assert "looks like degrees" not in captured.err
    assert "EPSG:4326" in captured.out


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_a_plain_tiff_from_an_image_editor_is_read_the_right_way_up(tmp_path, dtype):
    # No geotransform at all (what image editors and many terrain tools write): GDAL reports
    # the identity, whose row step is +1, but the rows are in file order, first row north —
    # as the reader without rasterio reads them.
    import tifffile

    data = (np.arange(35).reshape(5, 7) * 3).astype(dtype)
    tifffile.imwrite(tmp_path / "plain.tif", data, photometric="minisblack", metadata=None)
    hm = read_heightmap(tmp_path / "plain.tif")
    np.testing.assert_array_equal(hm.heights, data.astype(np.float32))
    np.testing.assert_array_equal(hm.heights, read_tiff(tmp_path / "plain.tif").heights)
    assert hm.spacing == (1.0, 1.0) and hm.crs is None and hm.origin == (0.0, 0.0)
