"""Cesium terrain: a quantized-mesh 1.0 tile pyramid with ``layer.json``.

Tiles follow Cesium's geographic TMS scheme (EPSG:4326, 2 × 1 tiles at level 0, ``y`` from
the south). Each tile samples the map bilinearly on a 65 × 65 lon/lat grid (its edges shared
with the neighbours), is meshed at the level's error by a static mesher of
:data:`terrascape.lod.static_meshers.STATIC_MESHERS` (RTIN by default; ``--mesher greedy``
for fewer triangles), and is encoded by ``quantized-mesh-encoder`` with the edge-index lists
Cesium uses to stitch skirts, the ``octvertexnormals`` and ``watermask`` extensions, and gzip
(serve with ``Content-Encoding: gzip``). Outside the data the tiles are at height 0 and marked
water.

The level error is ``max_error · 2**(finest − level)`` (default 1 m at the finest level): it
halves from level to level as Cesium's own ``levelMaximumGeometricError`` does (its tiles
double their sample density per level), and never exceeds that Cesium value,
``2π·a/4 / (65·2) / 2**level`` (``a`` the WGS84 equatorial radius). The mesh of a tile is
within that error of the tile's samples (a true bound on every sample, by either mesher);
quantized-mesh then stores heights in 15 bits over the tile's height range, truncating (a
further ``(max − min) / 32767`` at most).

Tiles are encoded in parallel worker processes, each with one numba thread: a tile is small
and many in flight keep both cores busy without numba's thread start-up per tiny kernel.
This process writes them in units of :data:`WRITE_BATCH` tiles, each unit flushed to the
disk by a few threads and committed at once (:func:`terrascape.export._common.write_many`):
one flush and commit per tile waited about 20 ms on the disk, several times the tile's own
3 ms of CPU, and made the pyramid's wall time.

References
----------
Cesium, "quantized-mesh-1.0 terrain format", https://github.com/CesiumGS/quantized-mesh.
"""

from __future__ import annotations

import gzip
import io
import json
import math
import struct
from pathlib import Path

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape.errors import InvalidParameterError
from terrascape.export._common import ExportOptions, check_out_dir, one_unit, write_many, write_text
from terrascape.export._geo import GeoGrid, geo_grid, tms_geographic_bounds, tms_geographic_range
from terrascape.heightmap import Heightmap

NAME = "cesium"
SUMMARY = ("Cesium quantized-mesh 1.0 pyramid (RTIN or greedy TIN tiles, normals, water mask, "
           "layer.json).")
#: the tiles are meshed by ``ExportOptions.mesher``
TAKES_MESHER = True
TILE_SAMPLES = 65
_WGS84_A = 6378137.0
# gzip level 1: tiles a tenth larger than at level 6, compressed 2.3 times faster (measured on
# a 1025² pyramid); compression was a third of the time of a tile at level 6
_GZIP_LEVEL = 1
#: Tiles written and flushed to the disk together, by several threads, before they join the
#: export's unit: a flush per tile took 20 ms of waiting on the disk each, longer than
#: making the tile (3 ms of CPU).
WRITE_BATCH = 256


def cesium_geometric_error(level: int) -> float:
    """CesiumJS's ``levelMaximumGeometricError`` of a 65-sample heightmap tiling (metres)."""
    return 2.0 * math.pi * _WGS84_A * 0.25 / (TILE_SAMPLES * 2) / (1 << level)


def level_error(level: int, finest: int, max_error: float = 1.0) -> float:
    """Vertical error allowed in the tiles of ``level`` (metres); see the module docstring."""
    return min(float(max_error) * 2.0 ** (finest - level), cesium_geometric_error(level))


def finest_level(grid: GeoGrid) -> int:
    """The first level whose tile samples are as dense as the map's (latitude spacing)."""
    return max(0, math.ceil(math.log2(180.0 / ((TILE_SAMPLES - 1) * grid.dlat))))


def tile_coordinates(grid: GeoGrid, z: int, x: int, y: int) -> tuple[np.ndarray, ...]:
    """``(lon_1d, lat_1d, row, col, inside, bounds)`` of the 65 × 65 tile grid (row 0 = north
    edge): the longitude of each column, the latitude of each row, their fractional map
    sample coordinates ``row``/``col`` (not clipped) and the mask of points inside the data.
    """
    w, s, e, n = tms_geographic_bounds(z, x, y)
    t = np.linspace(0.0, 1.0, TILE_SAMPLES)
    lon_1d, lat_1d = w + t * (e - w), n - t * (n - s)
    rows, cols = grid.heights.shape
    col = (lon_1d - grid.west) / grid.dlon - 0.5
    row = (grid.north - lat_1d) / grid.dlat - 0.5
    eps = 1e-9
    inside = (((row >= -eps) & (row <= rows - 1 + eps))[:, None]
              & ((col >= -eps) & (col <= cols - 1 + eps))[None, :])
    return lon_1d, lat_1d, row, col, inside, (w, s, e, n)


def bilinear_separable(heights: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """float64 bilinear samples of ``heights`` at every (``row[i]``, ``col[j]``) pair, the
    coordinates in ``[0, rows − 1]`` × ``[0, cols − 1]`` (as :meth:`GeoGrid.sample`)."""
    return _bilinear_separable(heights, np.asarray(row, np.float64), np.asarray(col, np.float64))


def tile_samples(grid: GeoGrid, z: int, x: int, y: int) -> tuple[np.ndarray, ...]:
    """``(lon, lat, heights, inside, bounds)`` of the 65 × 65 tile grid (row 0 = north edge);
    heights outside the data (``inside`` false) are 0.

    Heights are bilinear in the map's samples, as :meth:`GeoGrid.sample`; the tile grid is
    separable (a row shares its latitude, a column its longitude), so the weights are found
    once per row and per column.
    """
    lon_1d, lat_1d, row, col, inside, bounds = tile_coordinates(grid, z, x, y)
    rows, cols = grid.heights.shape
    h = _bilinear_separable(grid.heights, np.clip(row, 0, rows - 1), np.clip(col, 0, cols - 1))
    lon = np.broadcast_to(lon_1d, (TILE_SAMPLES, TILE_SAMPLES))
    lat = np.broadcast_to(lat_1d[:, None], (TILE_SAMPLES, TILE_SAMPLES))
    return lon, lat, np.where(inside, h, 0.0), inside, bounds


@njit(cache=CACHE, fastmath=FASTMATH)
def _bilinear_separable(heights, row, col):
    rows, cols = heights.shape
    out = np.empty((row.size, col.size), np.float64)
    for i in range(row.size):
        r0 = min(int(np.floor(row[i])), rows - 1)
        r1 = min(r0 + 1, rows - 1)
        fr = row[i] - r0
        for j in range(col.size):
            c0 = min(int(np.floor(col[j])), cols - 1)
            c1 = min(c0 + 1, cols - 1)
            fc = col[j] - c0
            top = (1.0 - fc) * heights[r0, c0] + fc * heights[r0, c1]
            bottom = (1.0 - fc) * heights[r1, c0] + fc * heights[r1, c1]
            out[i, j] = (1.0 - fr) * top + fr * bottom
    return out


@njit(cache=CACHE, fastmath=FASTMATH)
def _first_use_numbering(flat_indices, n_samples):
    # Quantized-mesh's high-water-mark index code wants vertices numbered in order of first use.
    number = np.full(n_samples, -1, np.int64)
    used = np.empty(flat_indices.size, np.int64)
    count = 0
    out = np.empty(flat_indices.size, np.uint32)
    for k in range(flat_indices.size):
        v = flat_indices[k]
        if number[v] < 0:
            number[v] = count
            used[count] = v
            count += 1
        out[k] = number[v]
    return used[:count], out


@njit(cache=CACHE, fastmath=FASTMATH)
def _oct_vertex_normals(lon, lat, height, triangles, a, e2):
    # The octvertexnormals extension's normals as quantized-mesh-encoder computes them: ECEF
    # positions, face normals weighted by triangle area summed per vertex, normalised, then
    # octahedron-encoded to two bytes.
    n = lon.size
    ecef = np.empty((n, 3), np.float64)
    for i in range(n):
        lo, la = lon[i] * np.pi / 180, lat[i] * np.pi / 180
        radius = a / np.sqrt(1 - e2 * np.sin(la) ** 2)
        ecef[i, 0] = (radius + height[i]) * np.cos(la) * np.cos(lo)
        ecef[i, 1] = (radius + height[i]) * np.cos(la) * np.sin(lo)
        ecef[i, 2] = (radius * (1 - e2) + height[i]) * np.sin(la)
    acc = np.zeros((n, 3), np.float64)
    for t in range(triangles.shape[0]):
        i, j, k = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        ux, uy, uz = ecef[j, 0] - ecef[i, 0], ecef[j, 1] - ecef[i, 1], ecef[j, 2] - ecef[i, 2]
        vx, vy, vz = ecef[k, 0] - ecef[i, 0], ecef[k, 1] - ecef[i, 1], ecef[k, 2] - ecef[i, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        half_area = np.sqrt(nx * nx + ny * ny + nz * nz) / 2
        for v in (i, j, k):
            acc[v, 0] += nx * half_area
            acc[v, 1] += ny * half_area
            acc[v, 2] += nz * half_area
    out = np.empty((n, 2), np.uint8)
    for i in range(n):
        length = np.sqrt(acc[i, 0] ** 2 + acc[i, 1] ** 2 + acc[i, 2] ** 2)
        if length == 0.0:  # only degenerate triangles (a pole): the radial direction
            acc[i] = ecef[i]
            length = np.sqrt(acc[i, 0] ** 2 + acc[i, 1] ** 2 + acc[i, 2] ** 2)
        x, y, z = acc[i, 0] / length, acc[i, 1] / length, acc[i, 2] / length
        l1 = abs(x) + abs(y) + abs(z)
        px, py = x / l1, y / l1
        if z < 0.0:
            px, py = ((1 - abs(py)) * (-1.0 if px < 0.0 else 1.0),
                      (1 - abs(px)) * (-1.0 if py < 0.0 else 1.0))
        out[i, 0] = np.uint8(np.floor((min(max(px, -1.0), 1.0) * 0.5 + 0.5) * 256))
        out[i, 1] = np.uint8(np.floor((min(max(py, -1.0), 1.0) * 0.5 + 0.5) * 256))
    return out


def encode_tile(grid: GeoGrid, z: int, x: int, y: int, error: float,
                mesher: str | None = None) -> tuple[bytes, int]:
    """The gzip-compressed quantized-mesh bytes of tile ``z/x/y`` meshed within ``error``
    metres by the static mesher ``mesher`` (``None``: the default), and its triangle
    count."""
    return encode_samples(*tile_samples(grid, z, x, y), error, mesher)


def encode_samples(lon: np.ndarray, lat: np.ndarray, heights: np.ndarray, inside: np.ndarray,
                   bounds, error: float, mesher: str | None = None) -> tuple[bytes, int]:
    """The gzip-compressed quantized-mesh bytes of a tile from its 65 × 65 samples (as
    :func:`tile_samples` gives them) meshed within ``error`` metres by the static mesher
    ``mesher`` (``None``: the default), and its triangle count."""
    from quantized_mesh_encoder import WaterMaskExtension, encode
    from quantized_mesh_encoder.constants import WGS84

    from terrascape.lod.static_meshers import static_mesher

    tile = Heightmap(heights.astype(np.float32))
    tri = static_mesher(mesher).mesh(tile, max_error=error)
    used, numbered = _first_use_numbering(tri.reshape(-1).astype(np.int64), tile.heights.size)
    positions = np.stack([lon.reshape(-1)[used], lat.reshape(-1)[used],
                          tile.heights.reshape(-1)[used].astype(np.float64)], axis=1)
    indices = numbered.reshape(-1, 3)
    water = ~inside | (heights <= 0.0)
    if not water.any():
        mask: np.ndarray | int = 0
    elif water.all():
        mask = 255
    else:  # 256 × 256, row 0 = north, nearest tile sample
        idx = np.rint(np.linspace(0, TILE_SAMPLES - 1, 256)).astype(int)
        mask = np.where(water[np.ix_(idx, idx)], 255, 0).astype(np.uint8)
    buf = io.BytesIO()
    flat = positions.reshape(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        encode(buf, flat, indices, bounds=list(bounds), sphere_method="naive")
        normals = _oct_vertex_normals(positions[:, 0], positions[:, 1], positions[:, 2],
                                      indices, WGS84.a, WGS84.e2).tobytes()
    # Extensions follow the edge indices, each as id (uint8), length (uint32), payload.
    buf.write(struct.pack("<BI", 1, len(normals)) + normals)
    buf.write(WaterMaskExtension(data=mask).encode())
    data = bytearray(buf.getvalue())
    occlusion = np.frombuffer(bytes(data[64:88]), "<f8")
    if not np.isfinite(occlusion).all():
        # Tiles wider than a hemisphere (levels 0–1) have no horizon occlusion point; use a
        # point far out above the tile's centre in ellipsoid-scaled space (never culled from
        # the tile's own side of the globe).
        centre = np.frombuffer(bytes(data[0:24]), "<f8")
        norm = float(np.linalg.norm(centre))
        far = centre / norm * 1e3 if norm > 0 else np.array([1e3, 0.0, 0.0])
        data[64:88] = far.astype("<f8").tobytes()
    return gzip.compress(bytes(data), compresslevel=_GZIP_LEVEL, mtime=0), len(tri)


_WORKER_GRID: GeoGrid | None = None
_WORKER_MESHER: str | None = None


def _init_worker(grid: GeoGrid, mesher: str | None = None) -> None:
    import numba

    global _WORKER_GRID, _WORKER_MESHER
    numba.set_num_threads(1)
    _WORKER_GRID = grid
    _WORKER_MESHER = mesher


def _encode_job(job: tuple[int, int, int, float]) -> tuple[tuple[int, int, int], bytes, int]:
    z, x, y, error = job
    data, n = encode_tile(_WORKER_GRID, z, x, y, error, _WORKER_MESHER)  # type: ignore[arg-type]
    return (z, x, y), data, n


def tile_jobs(grid: GeoGrid, bottom: int, top: int, max_error: float
              ) -> tuple[list[tuple[int, int, int, float]], list]:
    """Every ``(z, x, y, error)`` of the pyramid and layer.json's ``available`` ranges."""
    jobs, available = [], []
    for z in range(bottom, top + 1):
        if z == 0:
            x0, y0, x1, y1 = 0, 0, 1, 0  # Cesium asks for both root tiles
        else:
            x0, y0, x1, y1 = tms_geographic_range(z, grid.bounds)
        available.append([{"startX": x0, "startY": y0, "endX": x1, "endY": y1}])
        error = level_error(z, top, max_error)
        jobs += [(z, x, y, error) for x in range(x0, x1 + 1) for y in range(y0, y1 + 1)]
    return jobs, available


def encode_pyramid(grid: GeoGrid, jobs, *, workers: int = 2, min_parallel_jobs: int = 400,
                   mesher: str | None = None):
    """Yield ``((z, x, y), gzip bytes, triangles)`` for ``jobs`` in their order, meshed by
    the static mesher ``mesher`` (``None``: the default), in ``workers`` processes when
    there are at least ``min_parallel_jobs`` (starting the workers costs seconds). A tile's
    bytes depend on its job alone, so they are the same either way."""
    if workers <= 1 or len(jobs) < min_parallel_jobs:
        import numba

        previous = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            for z, x, y, error in jobs:
                data, n = encode_tile(grid, z, x, y, error, mesher)
                yield (z, x, y), data, n
        finally:
            numba.set_num_threads(previous)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")  # no forked numba thread pools
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_init_worker,
                             initargs=(grid, mesher)) as pool:
        yield from pool.map(_encode_job, jobs, chunksize=16)


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    grid = geo_grid(heightmap, options.lonlat)
    top = finest_level(grid) if options.max_zoom is None else options.max_zoom
    bottom = options.min_zoom or 0
    if bottom > top:
        raise InvalidParameterError(f"--min-zoom {bottom} is above --max-zoom {top}")
    max_error = 1.0 if options.max_error is None else options.max_error
    written: list[Path] = []
    jobs, available = tile_jobs(grid, bottom, top, max_error)
    batch: list[tuple[Path, bytes]] = []
    for (z, x, y), data, _ in encode_pyramid(grid, jobs, workers=options.workers,
                                             mesher=options.mesher):
        batch.append((out / str(z) / str(x) / f"{y}.terrain", data))
        if len(batch) == WRITE_BATCH:
            written += write_many(batch, force=options.force)
            batch = []
    written += write_many(batch, force=options.force)
    written += write_metadata(out, options.name, bottom, top, available, max_error,
                              grid.bounds, force=options.force, mesher=options.mesher)
    return written


def write_metadata(out: Path, name: str, bottom: int, top: int, available: list,
                   max_error: float, data_bounds, *, force: bool = False,
                   mesher: str | None = None) -> list[Path]:
    """``layer.json`` (what CesiumJS reads) and ``NAME_import.txt`` of a pyramid whose tiles
    the static mesher ``mesher`` (``None``: the default) meshed."""
    from terrascape.lod.static_meshers import static_mesher

    layer = {
        "tilejson": "2.1.0",
        "name": name,
        "format": "quantized-mesh-1.0",
        "version": "1.0.0",
        "scheme": "tms",
        "projection": "EPSG:4326",
        "tiles": ["{z}/{x}/{y}.terrain?v={version}"],
        "bounds": [-180.0, -90.0, 180.0, 90.0],
        "minzoom": bottom,
        "maxzoom": top,
        "available": available if bottom == 0 else [[]] * bottom + available,
        "extensions": ["octvertexnormals", "watermask"],
        "attribution": "terrascape",
    }
    written = [write_text(out / "layer.json", json.dumps(layer, indent=1) + "\n", force=force)]
    w, s, e, n = data_bounds
    note = [
        f"Cesium quantized-mesh terrain for {name} (written by terrascape)",
        "",
        f"Levels {bottom} … {top}; data bounds lon {w:.8g} … {e:.8g}, lat {s:.8g} … {n:.8g}",
        "Serve the folder over HTTP with 'Content-Encoding: gzip' on *.terrain and",
        "Content-Type application/vnd.quantized-mesh, then in CesiumJS:",
        "  viewer.terrainProvider = await Cesium.CesiumTerrainProvider.fromUrl("
        "'http://HOST/PATH/', {requestVertexNormals: true, requestWaterMask: true});",
        "Per-level error (m): " + ", ".join(f"{z}:{level_error(z, top, max_error):.3g}"
                                            for z in range(bottom, top + 1)),
        f"Tiles meshed within it by the {static_mesher(mesher).label} mesher "
        f"(terrascape mesh --mesher {static_mesher(mesher).name})",
    ]
    written.append(write_text(out / f"{name}_import.txt", "\n".join(note) + "\n",
                              force=force))
    return written
