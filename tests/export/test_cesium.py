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
from terrascape.export.cesium import (
    TILE_SAMPLES,
    encode_pyramid,
    encode_tile,
    level_error,
    tile_jobs,
    tile_samples,
)
from terrascape.lod.mesh_checks import max_vertical_error

pytest.importorskip("quantized_mesh_encoder")
quantized_mesh_tile = pytest.importorskip("quantized_mesh_tile")


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


def _same_as_quantized_mesh_tile(data: bytes, tile: dict, zxy) -> None:
    """The quantized-mesh-tile package (another reader) decodes the same tile."""
    import io

    from quantized_mesh_tile.terrain import TerrainTile

    w, s, e, n = tms_geographic_bounds(*zxy)
    other = TerrainTile(west=w, south=s, east=e, north=n)
    other.fromBytesIO(io.BytesIO(data), hasLighting=True, hasWatermask=True)
    np.testing.assert_array_equal(other.u, tile["u"])
    np.testing.assert_array_equal(other.v, tile["v"])
    np.testing.assert_array_equal(other.h, tile["h"])
    np.testing.assert_array_equal(np.asarray(other.indices).reshape(-1, 3), tile["triangles"])
    assert len(other.vLight) == len(tile["u"])
    assert other.header["minimumHeight"] == pytest.approx(tile["min_height"])
    lon, lat, h = np.asarray(other.getVerticesCoordinates()).T
    assert np.all((lon >= w - 1e-9) & (lon <= e + 1e-9) & (lat >= s - 1e-9) & (lat <= n + 1e-9))
    span = tile["max_height"] - tile["min_height"]
    np.testing.assert_allclose(h, tile["min_height"] + tile["h"] * span / 32767, atol=1e-3)


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    rng = np.random.default_rng(8)
    h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 5) * 6000 + 700
    return Heightmap(h.astype(np.float32), (30.0, 30.0))


@pytest.mark.parametrize("mesher", [None, "greedy"])
def test_pyramid_tiles_decode_within_the_level_error(terrain, tmp_path, mesher):
    files = get_destination("cesium").export(
        terrain, tmp_path, ExportOptions(name="c", lonlat=(15.97, 45.81), workers=1,
                                         mesher=mesher))
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
                _same_as_quantized_mesh_tile(gzip.decompress(raw), tile, (z, x, y))
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


def test_tile_samples_are_the_bilinear_map_samples(terrain):
    grid = geo_grid(terrain, (15.97, 45.81))
    jobs, _ = tile_jobs(grid, 0, 14, 1.0)
    for z, x, y, _err in jobs[::7]:
        lon, lat, heights, inside, _ = tile_samples(grid, z, x, y)
        reference, reference_inside = grid.sample(lon, lat)
        np.testing.assert_array_equal(inside, reference_inside)
        np.testing.assert_allclose(heights, np.where(inside, reference, 0.0), atol=1e-9)


def test_normals_are_those_quantized_mesh_encoder_computes(terrain):
    """The octvertexnormals payload equals the library's own VertexNormalsExtension."""
    from quantized_mesh_encoder import VertexNormalsExtension

    grid = geo_grid(terrain, (15.97, 45.81))
    jobs, _ = tile_jobs(grid, 12, 14, 1.0)
    for job in jobs[::5]:
        tile = read_quantized_mesh(gzip.decompress(encode_tile(grid, *job)[0]))
        w, s, e, n = tms_geographic_bounds(*job[:3])
        span = tile["max_height"] - tile["min_height"]
        # the library's normals from the decoded (dequantised) vertices and triangles
        lon = w + tile["u"] / 32767 * (e - w)
        lat = s + tile["v"] / 32767 * (n - s)
        h = tile["min_height"] + tile["h"] * span / 32767
        positions = np.stack([lon, lat, h], axis=1).reshape(-1)
        ours = np.frombuffer(tile["extensions"][1], np.uint8).reshape(-1, 2).astype(int)
        theirs = np.frombuffer(VertexNormalsExtension(
            indices=tile["triangles"].astype(np.uint32), positions=positions).encode()[5:],
            np.uint8).reshape(-1, 2).astype(int)
        # same up to the vertex quantisation of the decoded positions: one code at most
        assert np.abs(ours - theirs).max() <= 1
        assert np.mean(ours == theirs) > 0.95


@pytest.mark.parametrize("mesher", [None, "greedy"])
def test_parallel_pyramid_is_bit_identical_to_serial(terrain, mesher):
    grid = geo_grid(terrain, (15.97, 45.81))
    jobs, _ = tile_jobs(grid, 10, 14, 1.0)
    serial = list(encode_pyramid(grid, jobs, workers=1, mesher=mesher))
    parallel = list(encode_pyramid(grid, jobs, workers=2, min_parallel_jobs=1, mesher=mesher))
    assert len(serial) == len(jobs) >= 20
    assert [t[0] for t in serial] == [j[:3] for j in jobs]
    assert serial == parallel


def test_the_greedy_mesher_gives_the_pyramid_fewer_triangles_and_bytes(terrain, tmp_path):
    """The same tiles and levels; each tile within its level's error either way (the test
    above), the greedy TIN's with fewer triangles on every tile that has more than two."""
    grid = geo_grid(terrain, (15.97, 45.81))
    jobs, _ = tile_jobs(grid, 11, 14, 1.0)
    rtin = list(encode_pyramid(grid, jobs, workers=1))
    greedy = list(encode_pyramid(grid, jobs, workers=1, mesher="greedy"))
    assert [t[0] for t in rtin] == [t[0] for t in greedy]
    pairs = [(a[2], b[2]) for a, b in zip(rtin, greedy, strict=True) if a[2] > 2]
    assert len(pairs) >= 10 and all(g < r for r, g in pairs)
    assert sum(g for _, g in pairs) < 0.8 * sum(r for r, _ in pairs)
    assert sum(len(t[1]) for t in greedy) < sum(len(t[1]) for t in rtin)
    # through the command as well, and refused for a destination that does not mesh
    np.save(tmp_path / "t.npy", terrain.heights)
    assert run_app(["export", "cesium", str(tmp_path / "t.npy"), "-o", str(tmp_path / "c"),
                    "--spacing", "30", "--lonlat", "15.97,45.81", "--mesher", "greedy",
                    "--min-zoom", "14", "-q"]) == 0
    written = {p.relative_to(tmp_path / "c").as_posix(): p.read_bytes()
               for p in (tmp_path / "c").rglob("*.terrain")}
    expected = dict((f"{z}/{x}/{y}.terrain", data) for (z, x, y), data, _ in greedy if z == 14)
    assert written == expected
    assert "by the greedy TIN mesher" in (tmp_path / "c" / "t_import.txt").read_text()
    assert run_app(["export", "terrain_rgb", str(tmp_path / "t.npy"), "-o",
                    str(tmp_path / "r"), "--lonlat", "15.97,45.81", "--mesher", "greedy",
                    "-q"]) == 2
