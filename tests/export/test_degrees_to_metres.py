"""Maps in degrees are converted to the UTM zone of their centre before ``mesh``, ``render``,
``view`` and the engine exports use them (the real Jacksboro DEM: 403 × 344 samples 0.00083°
apart, heights 236–1076 m, which drawn in degrees is a needle 0.3 units wide); with
``--no-reproject`` they are kept and warned about."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.io import read_heightmap
from terrascape.io.geotiff import assign_crs
from terrascape.io.metric import to_metric, utm_crs
from terrascape.io.tiff import read_tiff, write_tiff


def _jacksboro() -> tuple[np.ndarray, float]:
    from matplotlib.cbook import get_sample_data

    d = get_sample_data("jacksboro_fault_dem.npz")
    return d["elevation"].astype(np.float32), float(d["dx"])


def test_utm_zone_of_a_point() -> None:
    assert utm_crs(15.98, 45.81) == "EPSG:32633"  # Zagreb
    assert utm_crs(-98.2, 33.2) == "EPSG:32614"  # Jacksboro, Texas
    assert utm_crs(-70.6, -33.4) == "EPSG:32719"  # Santiago
    assert utm_crs(180.0, 1.0) == "EPSG:32601" and utm_crs(179.99, 1.0) == "EPSG:32660"
    assert utm_crs(0.0, 88.0) == "EPSG:32661" and utm_crs(0.0, -85.0) == "EPSG:32761"


def test_a_map_without_crs_in_degrees_becomes_92_m_samples() -> None:
    z, deg = _jacksboro()
    metric, message = to_metric(Heightmap(z, (deg, deg)))
    # origin 0, 0: the equator, where 0.00083° is 0.00083 × 111.2 km ≈ 92.7 m both ways
    assert metric.crs == "EPSG:32731" and "UTM zone 31S" in message
    assert metric.spacing[0] == pytest.approx(92.6, abs=0.5)
    assert metric.spacing[1] == pytest.approx(92.6, abs=0.5)
    assert abs(metric.cols - 403) <= 2 and abs(metric.rows - 344) <= 2  # same extent
    assert 230 < metric.min < 250 and 1060 < metric.max < 1080  # heights kept (bilinear)
    # a map in metres, or one whose spacing does not look like degrees, is left alone
    same, none = to_metric(Heightmap(z, (92.6, 92.6)))
    assert none is None and same.spacing == (92.6, 92.6)


def test_a_geotiff_in_epsg_4326_goes_to_its_utm_zone(tmp_path) -> None:
    z, deg = _jacksboro()
    src = assign_crs(Heightmap(z, (deg, deg), origin=(-98.35, 33.35)), "EPSG:4326")
    from terrascape.io.geotiff import write_geotiff

    path = write_geotiff(src, tmp_path / "j.tif")
    metric, message = to_metric(read_heightmap(path))
    assert metric.crs == "EPSG:32614" and "EPSG:4326" in message
    # 0.00083° of latitude is 92.4 m, of longitude at 33.2° N 77.7 m: square pixels between
    assert 77.0 < metric.spacing[0] < 93.0 and metric.spacing[0] == metric.spacing[1]
    ex, ez = metric.extent
    assert ex == pytest.approx(403 * deg * 111_320 * np.cos(np.radians(33.2)), rel=0.03)
    assert ez == pytest.approx(344 * deg * 110_900, rel=0.03)


def test_mesh_converts_degrees_and_no_reproject_keeps_them(tmp_path, capsys) -> None:
    z, deg = _jacksboro()
    np.save(tmp_path / "j.npy", z)
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(tmp_path / "d.obj"),
                    "--max-error", "20", "--spacing", str(deg), "-q"]) == 0
    err = capsys.readouterr().err
    assert "converted to UTM zone 31S" in err and "--no-reproject" in err
    v = np.array([[float(t) for t in line.split()[1:4]]
                  for line in (tmp_path / "d.obj").read_text().splitlines()
                  if line.startswith("v ")])
    span = v.max(axis=0) - v.min(axis=0)
    assert span[0] == pytest.approx(402 * 92.6, rel=0.02)  # metres across, not 0.33
    assert span[2] == pytest.approx(343 * 92.6, rel=0.02)
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(tmp_path / "k.obj"),
                    "--max-error", "20", "--spacing", str(deg), "--no-reproject", "-q"]) == 0
    err = capsys.readouterr().err
    assert "looks like degrees" in err and "converted" not in err
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(tmp_path / "m.obj"),
                    "--max-error", "20", "--spacing", "74.5,92.6", "-q"]) == 0
    err = capsys.readouterr().err
    assert "looks like degrees" not in err and "converted" not in err


def test_export_converts_degrees(tmp_path, capsys) -> None:
    z, deg = _jacksboro()
    np.save(tmp_path / "j.npy", z)
    assert run_app(["export", "blender", str(tmp_path / "j.npy"), "-o", str(tmp_path / "o"),
                    "--spacing", str(deg), "-q"]) == 0
    assert "converted to UTM zone 31S" in capsys.readouterr().err
    note = (tmp_path / "o" / "j_import.txt").read_text()
    tif = read_tiff(tmp_path / "o" / "j.tif")
    assert abs(tif.cols - 403) <= 2
    # Blender's plane scaled to the extent in metres (403 samples × 92.6 m), not 0.33
    scale_x, scale_y = (float(v) for v in re.search(r"scale X ([0-9.]+)\s+Y ([0-9.]+)",
                                                    note).groups())
    assert scale_x == pytest.approx(403 * 92.6, rel=0.02)
    assert scale_y == pytest.approx(343 * 92.6, rel=0.02)


def _green_share(path) -> float:
    """Share of pixels that are ground (green or brown: red or green well above blue)."""
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.int32)
    ground = np.maximum(rgb[..., 0], rgb[..., 1]) > rgb[..., 2] + 12
    return float(ground.mean())


@pytest.mark.gl
def test_render_draws_a_degree_tiff_as_terrain(tmp_path, capsys) -> None:
    z, deg = _jacksboro()
    path = write_tiff(Heightmap(z, (deg, deg)), tmp_path / "j.tif")
    assert read_tiff(path).spacing == pytest.approx((deg, deg))  # kept, and no CRS
    out = tmp_path / "j.png"
    assert run_app(["render", str(path), "-o", str(out), "--size", "96x72", "-q"]) == 0
    assert "converted to UTM zone 31S" in capsys.readouterr().err
    needle = tmp_path / "n.png"
    assert run_app(["render", str(path), "-o", str(needle), "--size", "96x72", "-q",
                    "--no-reproject"]) == 0
    assert "looks like degrees" in capsys.readouterr().err
    # terrain fills the lower part of the frame; in degrees it was a needle in an empty sky
    assert _green_share(out) > 0.4
    assert _green_share(needle) < 0.05
