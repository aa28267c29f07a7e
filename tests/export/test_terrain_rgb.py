"""Terrain-RGB / Terrarium tiles decoded with Pillow and the published formulas, against the
exact heights of a tilted plane placed on the globe."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from terrascape import Heightmap, InvalidParameterError
from terrascape.export import ExportOptions, get_destination
from terrascape.export._geo import geo_grid, mercator_tile_lonlat
from terrascape.export.terrain_rgb import TILE, encode_mapbox, encode_terrarium

LONLAT = (15.97, 45.81)


@pytest.fixture(scope="module")
def plane() -> Heightmap:
    """h = 500 + 2·col − 3·row: bilinear sampling reproduces it exactly."""
    r, c = np.mgrid[0:100, 0:140]
    return Heightmap((500.0 + 2.0 * c - 3.0 * r).astype(np.float32), (40.0, 40.0))


def _expected(plane, z, x, y):
    grid = geo_grid(plane, LONLAT)
    t = (np.arange(TILE) + 0.5) / TILE
    lon, lat = np.broadcast_arrays(*mercator_tile_lonlat(z, x + t[None, :], y + t[:, None]))
    col = (lon - grid.west) / grid.dlon - 0.5
    row = (grid.north - lat) / grid.dlat - 0.5
    inside = (col >= 0) & (col <= 139) & (row >= 0) & (row <= 99)
    return 500.0 + 2.0 * col - 3.0 * row, inside


@pytest.mark.parametrize("fmt", ["mapbox", "terrarium"])
def test_tiles_decode_to_the_plane(plane, tmp_path, fmt):
    get_destination("terrain_rgb").export(plane, tmp_path, ExportOptions(
        name="p", lonlat=LONLAT, format=fmt, min_zoom=10))
    meta = json.loads((tmp_path / "tiles.json").read_text())
    assert meta["encoding"] == fmt and meta["minzoom"] == 10
    top = meta["maxzoom"]
    assert top == 12  # 40 m samples; zoom 12 pixels are 26.6 m at 45.8° N, zoom 11 53 m
    pngs = sorted((tmp_path / str(top)).rglob("*.png"))
    assert pngs
    checked = 0
    for path in pngs:
        x, y = int(path.parent.name), int(path.stem)
        img = np.asarray(Image.open(path)).astype(np.float64)
        assert img.shape == (TILE, TILE, 4)
        r, g, b, a = (img[..., k] for k in range(4))
        if fmt == "mapbox":
            h = -10000.0 + (r * 65536 + g * 256 + b) * 0.1
            tol = 0.05 + 1e-3
        else:
            h = r * 256 + g + b / 256 - 32768
            tol = 1 / 256 + 1e-3
        want, inside = _expected(plane, top, x, y)
        # the pixel ring on the data's edge may fall either side of it: skip a 1 px margin
        core = inside & np.roll(inside, 1, 0) & np.roll(inside, -1, 0) & np.roll(
            inside, 1, 1) & np.roll(inside, -1, 1)
        np.testing.assert_array_equal(a[core], 255)
        np.testing.assert_allclose(h[core], want[core], atol=tol)
        outside = ~inside & ~np.roll(inside, 1, 0) & ~np.roll(inside, -1, 0)
        outside &= ~np.roll(inside, 1, 1) & ~np.roll(inside, -1, 1)
        assert np.all(a[outside] == 0)
        checked += int(core.sum())
    assert checked > 5000


def test_encoders_match_the_published_examples():
    np.testing.assert_array_equal(encode_mapbox(np.array([0.0])), [[1, 134, 160]])
    np.testing.assert_array_equal(encode_terrarium(np.array([0.0, 100.5])),
                                  [[128, 0, 0], [128, 100, 128]])
    with pytest.raises(InvalidParameterError):
        encode_terrarium(np.array([40000.0]))
