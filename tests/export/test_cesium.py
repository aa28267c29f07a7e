"""Cesium quantized-mesh pyramid: decoded with an independent reader of the 1.0 format and
checked against the tile samples within the level's error."""

from __future__ import annotations

import gzip
import json
import struct

import numpy as np
import pytest
from scipy import ndimage

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export import ExportOptions, get_destination
from terrascape.export._geo import geo_grid, tms_geographic_bounds
from terrascape.export.cesium import TILE_SAMPLES, level_error, tile_samples
from terrascape.lod.mesh_checks import max_vertical_error

pytest.importorskip("quantized_mesh_encoder")


def _zigzag_deltas(raw: np.ndarray) -> np.ndarray:
    v = raw.astype(np.int64)
    return np.cumsum((v >> 1) ^ -(v & 1))


def read_quantized_mesh(data: bytes) -> dict:
    """Decode quantized-mesh-1.0 (https://github.com/CesiumGS/quantized-mesh)."""
    header = struct.unpack_from("<3d2f4d3d", data, 0)
    pos = 88
    (n,) = struct.unpack_from("<I", data, pos)
    pos += 4
    uvh = np.frombuffer(data, "<u2", 3 * n, pos).reshape(3, n)
    pos += 6 * n
    u, v, h = (_zigzag_deltas(a) for a in uvh)
    wide = n > 65536
    size = 4 if wide else 2
    if pos % size:
        pos += size - pos % size
    (tri_count,) = struct.unpack_from("<I", data, pos)
    pos += 4
    codes = np.frombuffer(data, "<u4" if wide else "<u2", 3 * tri_count, pos).astype(np.int64)
    pos += 3 * tri_count * size
    highest, indices = 0, np.empty_like(codes)
    for k, code in enumerate(codes):  # high-water-mark decoding
        indices[k] = highest - code
        if code == 0:
            highest += 1
    edges = {}
    for side in ("west", "south", "east", "north"):
        (count,) = struct.unpack_from("<I", data, pos)
        pos += 4
        edges[side] = np.frombuffer(data, "<u4" if wide else "<u2", count, pos)
        pos += count * size
    extensions = {}
    while pos < len(data):
        ext_id, length = struct.unpack_from("<BI", data, pos)
        pos += 5
        extensions[ext_id] = data[pos:pos + length]
        pos += length
    return {"min_height": header[3], "max_height": header[4], "u": u, "v": v, "h": h,
            "triangles": indices.reshape(-1, 3), "edges": edges, "extensions": extensions,
            "occlusion": header[12:15]}


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    rng = np.random.default_rng(8)
    h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 5) * 6000 + 700
    return Heightmap(h.astype(np.float32), (30.0, 30.0))


def test_pyramid_tiles_decode_within_the_level_error(terrain, tmp_path):
    files = get_destination("cesium").export(
        terrain, tmp_path, ExportOptions(name="c", lonlat=(15.97, 45.81), workers=1))
    layer = json.loads((tmp_path / "layer.json").read_text())
    assert layer["format"] == "quantized-mesh-1.0" and layer["scheme"] == "tms"
    assert layer["extensions"] == ["octvertexnormals", "watermask"]
    top = layer["maxzoom"]
    assert top == 14  # 30 m samples: level 13 tiles step 38 m in latitude, level 14 19 m
    assert len(layer["available"]) == top + 1
    grid = geo_grid(terrain, (15.97, 45.81))
    checked = 0
    for z, ranges in enumerate(layer["available"]):
        r = ranges[0]
        for x in range(r["startX"], r["endX"] + 1):
            for y in range(r["startY"], r["endY"] + 1):
                raw = (tmp_path / str(z) / str(x) / f"{y}.terrain").read_bytes()
                assert raw[:2] == b"\x1f\x8b"  # gzip
                tile = read_quantized_mesh(gzip.decompress(raw))
                assert np.isfinite(tile["occlusion"]).all()
                assert set(tile["extensions"]) == {1, 2}  # octvertexnormals, watermask
                assert len(tile["extensions"][1]) == 2 * len(tile["u"])
                if z < top - 3:
                    continue
                _, _, heights, _inside, _ = tile_samples(grid, z, x, y)
                # back to the tile's grid: u, v in 0…32767 (truncated), v from the south
                col = np.rint(tile["u"] * (TILE_SAMPLES - 1) / 32767).astype(np.int64)
                row = TILE_SAMPLES - 1 - np.rint(
                    tile["v"] * (TILE_SAMPLES - 1) / 32767).astype(np.int64)
                span = tile["max_height"] - tile["min_height"]
                decoded = tile["min_height"] + tile["h"] * span / 32767
                np.testing.assert_allclose(decoded, heights[row, col],
                                           atol=span / 32767 + 1e-3)
                grid_tri = (row * TILE_SAMPLES + col)[tile["triangles"]]
                mesh_err = max_vertical_error(Heightmap(heights.astype(np.float32)), grid_tri)
                assert mesh_err <= level_error(z, top) + 1e-6
                u, v = tile["u"][tile["triangles"]], tile["v"][tile["triangles"]]
                cross = (u[:, 1] - u[:, 0]) * (v[:, 2] - v[:, 0]) - (v[:, 1] - v[:, 0]) * (
                    u[:, 2] - u[:, 0])
                assert np.all(cross > 0)  # counter-clockwise in (u, v), as Cesium wants
                assert len(tile["edges"]["west"]) >= 2 and len(tile["edges"]["north"]) >= 2
                checked += 1
    assert checked >= 4
    assert len(files) == sum((r[0]["endX"] - r[0]["startX"] + 1) * (r[0]["endY"] - r[0]["startY"]
                                                                   + 1)
                             for r in layer["available"]) + 2


def test_georeferenced_dem_needs_no_lonlat_and_local_maps_do(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import Affine

    h = np.full((65, 65), 100.0, np.float32)
    h[20:40, 20:40] = 300.0
    with rasterio.open(tmp_path / "d.tif", "w", driver="GTiff", width=65, height=65, count=1,
                       dtype="float32", crs="EPSG:32633",
                       transform=Affine(30.0, 0, 500000.0, 0, -30.0, 5000000.0)) as ds:
        ds.write(h, 1)
    assert run_app(["export", "cesium", str(tmp_path / "d.tif"), "-o", str(tmp_path / "t"),
                    "--max-zoom", "12", "-q"]) == 0
    layer = json.loads((tmp_path / "t" / "layer.json").read_text())
    r = layer["available"][12][0]
    w, s, e, n = tms_geographic_bounds(12, r["startX"], r["startY"])
    # UTM 33N, 500 km east, 5000 km north: 15° E, ≈ 45.1° N
    assert w <= 15.0 + 0.03 and e >= 15.0 and s <= 45.15 <= n + 0.1
    tile = read_quantized_mesh(gzip.decompress(
        (tmp_path / "t" / "12" / str(r["startX"]) / f"{r['startY']}.terrain").read_bytes()))
    assert tile["max_height"] <= 300.0 + 1e-3
    np.save(tmp_path / "local.npy", h)
    assert run_app(["export", "cesium", str(tmp_path / "local.npy"), "-o",
                    str(tmp_path / "x")]) == 2
