"""Export a world in parallel, tile by tile: a tiled GeoTIFF or Cloud-Optimized GeoTIFF,
Terrain-RGB/Terrarium tiles and the Cesium quantized-mesh pyramid.

Each GeoTIFF block, and each group of tiles (16 Terrain-RGB or 64 quantized-mesh tiles),
is one task on the cluster (``client.map``); with no client the same function runs in a
loop here. The tasks write their tiles into a hidden folder of the output folder, and this
process gives all of them their names at the end, with the pyramid's metadata, as one
unit: an export interrupted or failed half-way leaves no tile, and over an earlier export
(``force``) the earlier files as they were. A task reads only the window of the store its
tile needs, so memory stays bounded whatever the world's size, and both ways give the same
bytes:

* **GeoTIFF** (tiled, deflate with the floating-point predictor, BigTIFF when needed): the
  workers read and pack the blocks; this process writes them with rasterio windows *in
  block order*, so the file's layout does not depend on which worker finished first.
* **Terrain-RGB / Terrarium** (:mod:`terrascape.export.terrain_rgb`'s encodings and XYZ Web
  Mercator pyramid, placed with ``lonlat``): every tile is a PNG written by its task. A tile
  samples the world bilinearly at its pixel centres, on the pyramid level whose samples are
  at most as large as its pixels (level 0 at the finest zoom, where the tiles equal
  ``terrascape export terrain_rgb`` of the map loaded whole, byte for byte; coarser zooms
  read the overviews instead of the full-resolution map).
* **COG** (GDAL's COG driver): the GeoTIFF above, then copied with overviews.
* **Cesium quantized-mesh** (:mod:`terrascape.export.cesium`'s tiles, levels and errors):
  every tile samples the pyramid level whose samples are no larger than its own, meshes
  and encodes them, and writes its ``.terrain`` file; where the tiles are finer than the
  world (the finest levels) they equal ``terrascape export cesium`` of the map loaded
  whole, byte for byte.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import json
import math
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from terrascape.errors import InvalidParameterError
from terrascape.io.atomic import flush_files, output_unit
from terrascape.io.geotiff import quiet_not_georeferenced
from terrascape.world.store import open_world
from terrascape.world.window import level_shape, read_level

#: Pixels per side of a GeoTIFF block.
TIFF_BLOCK = 512
TILE = 256


def _run(client, fn, args: list[tuple]) -> list:
    """``fn(*a)`` for every ``a``, in order: as tasks on ``client`` or here."""
    if client is None:
        return [fn(*a) for a in args]
    if not args:
        return []
    return client.gather(client.map(fn, *zip(*args, strict=True), pure=False))


def _stage(folder: str, named: list[tuple[str, bytes]]) -> None:
    """Write each ``(name, bytes)`` into the staging ``folder`` and flush them to the disk (a
    worker's part of :func:`_staged_tiles`). The folder is never created here: once the
    command has removed it (interrupted), a late task writes nothing. A file is replaced if
    there: dask runs a task again when its worker died, and the bytes are the same."""
    from terrascape.export._common import SYNC_THREADS

    paths = []
    for name, data in named:
        path = Path(folder) / name
        with open(path, "wb") as f:
            f.write(data)
        paths.append(path)
    flush_files(paths, threads=SYNC_THREADS)


def _staged_name(z: int, x: int, y: int, suffix: str) -> str:
    return f"{z}-{x}-{y}{suffix}"


@contextlib.contextmanager
def _staged_tiles(out: Path, tiles: np.ndarray, suffix: str, *,
                  force: bool) -> Iterator[Path]:
    """A hidden folder in ``out`` for the workers' tiles (``tiles``: rows ``z, x, y``, each
    written there as :func:`_staged_name`), inside an output unit for the block's other
    files (the metadata, the manifest). When the block ends without an error the tiles get
    their names ``z/x/y`` + ``suffix``, then the unit commits; if either fails, or the block
    does, no tile is left and, over an earlier export (``force``), the files it replaced
    are put back.

    An existing tile without ``force`` is refused before any work, and again when it is
    placed (another writer). A task still running after an interruption finds the folder
    gone; what it may have written in between is removed again at exit. The tiles are
    held as three numbers each, not as paths: a pyramid has millions."""
    from terrascape.export._common import SYNC_THREADS
    from terrascape.io.atomic import (
        check_output_path,
        commit_lock,
        in_output_unit,
        place_files,
        record_bulk_commit,
    )

    def final(i: int) -> str:
        z, x, y = tiles[i]
        return f"{out}/{z}/{x}/{y}{suffix}"

    folders, in_folder = np.unique(tiles[:, :2], axis=0, return_inverse=True)
    folders = [out / str(z) / str(x) for z, x in folders.tolist()]
    existing = np.array([folder.is_dir() for folder in folders], np.bool_)
    for i in np.flatnonzero(existing[in_folder.reshape(-1)]):
        check_output_path(final(i), force=force)
    if in_output_unit():  # its commit comes after this block's tiles are placed
        raise RuntimeError("a world's tiles are their own output unit")
    staging = Path(tempfile.mkdtemp(prefix=".tiles-", suffix=".part", dir=out))
    aside = staging / "replaced"
    made: list[Path] = []
    placed = None

    def pair(i: int) -> tuple[str, str]:
        z, x, y = tiles[i]
        return f"{staging}/{_staged_name(z, x, y, suffix)}", final(i)

    try:
        with contextlib.ExitStack() as locked:
            try:
                with output_unit(sync_threads=SYNC_THREADS):
                    yield staging
                    for folder in folders:
                        missing = []
                        while not folder.is_dir():
                            missing.append(folder)
                            folder = folder.parent
                        for new in reversed(missing):
                            new.mkdir(exist_ok=True)
                            made.append(new)
                    aside.mkdir()
                    # the output folder is held from the tiles' naming to the end of the
                    # metadata's commit (or the tiles' undoing): another export into it
                    # waits, and the two never mix
                    locked.enter_context(commit_lock([out]))
                    placed = place_files(len(tiles), pair, aside, force=force,
                                         sync_threads=SYNC_THREADS)
            except BaseException:
                if placed is not None:
                    placed.undo()
                raise
    except BaseException:
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    finally:
        _remove_staging(staging)
    record_bulk_commit(len(tiles), out)


def _remove_staging(staging: Path) -> None:
    """Remove the staging folder so that no task still running (the export failed or was
    interrupted while a worker thread of this process wrote a tile) can write into it
    again: renamed first — a task's next file then fails to open — then removed, again
    if a file being created at the moment of the rename made the first removal fail, and
    at exit as a last resort."""
    gone = staging.with_name(staging.name + "-gone")
    try:
        os.rename(staging, gone)
    except OSError:
        gone = staging
    for _ in range(5):
        shutil.rmtree(gone, ignore_errors=True)
        if not os.path.lexists(gone):
            return
        time.sleep(0.02)
    atexit.register(shutil.rmtree, gone, True)


def _tiff_block(path: str, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    group, _ = open_world(path)
    return np.asarray(group["height"][r0:r1, c0:c1])


def export_geotiff(path, out, *, client=None, force: bool = False) -> Path:
    """The world's heights as a tiled float32 GeoTIFF at ``out`` (written atomically).

    The transform puts sample ``[0, 0]``'s outer corner at (0, 0) with the world's spacing
    (a local grid: no CRS); readers get the heights in world units.
    """
    from terrascape.io.atomic import atomic_output

    group, recipe = _finished_world(path)
    with atomic_output(Path(out), force=force) as tmp:
        _write_tiled_geotiff(path, group, recipe, tmp, client)
    return Path(out)


def export_cog(path, out, *, client=None, force: bool = False, blocksize: int = 512) -> Path:
    """The world's heights as a Cloud-Optimized GeoTIFF at ``out`` (written atomically):
    ``blocksize``² DEFLATE tiles, overviews down to one tile (each sample the average of the four
    below), the same transform and tags as :func:`export_geotiff`.

    The workers read and pack the blocks into a tiled GeoTIFF next to ``out`` (as
    :func:`export_geotiff`); GDAL's COG driver then copies it block by block, building the
    overviews, and the intermediate file is removed: no process holds the whole map, but
    the folder needs about twice the output's size free while it runs.
    """
    import tempfile

    from terrascape.io.atomic import check_output_path
    from terrascape.io.cog import cog_creation_options, copy_to_cog

    cog_creation_options(blocksize=blocksize)  # a bad size before any work
    out = Path(out)
    if out.suffix.lower() not in (".tif", ".tiff"):
        raise InvalidParameterError(f"COG output must end in .tif, got {out.name!r}")
    check_output_path(out, force=force)
    group, recipe = _finished_world(path)
    with tempfile.TemporaryDirectory(prefix=f".{out.stem[:40]}-cog-",
                                     dir=out.parent if out.parent.is_dir() else None) as tmp:
        tiled = Path(tmp) / "tiled.tif"
        _write_tiled_geotiff(path, group, recipe, tiled, client)
        copy_to_cog(tiled, out, force=force, blocksize=blocksize)
    return out


def _finished_world(path):
    group, recipe = open_world(path)
    if not group.attrs.get("complete", False):
        raise InvalidParameterError(f"{path} is not finished: run `terrascape world build` "
                                    "again to complete it before exporting")
    return group, recipe


def _write_tiled_geotiff(path, group, recipe, target: Path, client) -> None:
    """Write the world's heights as a tiled GeoTIFF at ``target`` (blocks packed by the
    workers, written here in block order)."""
    import rasterio
    from rasterio.transform import Affine
    from rasterio.windows import Window

    rows, cols = recipe.shape
    b = TIFF_BLOCK
    blocks = [(str(path), r, min(r + b, rows), c, min(c + b, cols))
              for r in range(0, rows, b) for c in range(0, cols, b)]
    sp = recipe.spacing
    profile = {"driver": "GTiff", "width": cols, "height": rows, "count": 1,
               "dtype": "float32", "tiled": True, "blockxsize": b, "blockysize": b,
               "compress": "deflate", "predictor": 3, "transform": Affine(sp, 0, 0, 0, -sp, 0),
               "BIGTIFF": "IF_SAFER"}
    with quiet_not_georeferenced(), rasterio.open(target, "w", **profile) as dst:
        dst.update_tags(terrascape_world=group.attrs["recipe_hash"],
                        spacing=str(sp), seed=str(recipe.seed))
        for (_, r0, r1, c0, c1), data in zip(blocks, _in_order(client, _tiff_block, blocks),
                                             strict=True):
            dst.write(data, 1, window=Window(c0, r0, c1 - c0, r1 - r0))


def _in_order(client, fn, args: list[tuple]):
    """Yield ``fn(*a)`` for every ``a`` in order; on a cluster at most a few blocks per
    worker are in flight, so the blocks waiting for the writer stay few (bounded memory)."""
    if client is None:
        for a in args:
            yield fn(*a)
        return
    ahead = 2 * max(1, len(client.scheduler_info().get("workers", {}))) + 2
    queue = []
    for a in args:
        queue.append(client.submit(fn, *a, pure=False))
        if len(queue) >= ahead:
            first = queue.pop(0)
            yield first.result()
            first.release()
    for f in queue:
        yield f.result()
        f.release()


# --- Terrain-RGB / Terrarium -------------------------------------------------------------
def _geo(recipe, lonlat) -> tuple[float, float, float, float]:
    """``(west, north, dlon, dlat)`` of the world placed with its centre at ``lonlat`` (as
    :func:`terrascape.export._geo.geo_grid` places a map)."""
    from terrascape.io.tiff import geographic_spacing

    lon, lat = (float(v) for v in lonlat)
    if not (-180 <= lon <= 180 and -85 <= lat <= 85):
        raise InvalidParameterError(
            f"--lonlat must be a longitude in [-180, 180] and latitude in [-85, 85], got "
            f"{lon}, {lat}")
    mx, mz = geographic_spacing(1.0, 1.0, lat)
    dlon, dlat = recipe.spacing / mx, recipe.spacing / mz
    return lon - recipe.cols * dlon / 2, lat + recipe.rows * dlat / 2, dlon, dlat


#: Terrain-RGB tiles per task, written as one unit (see ``write_many``).
RGB_TILES_PER_TASK = 16


def _rgb_tiles(path: str, geo, tiles: list, fmt: str, staging: str) -> None:
    """Encode the tiles ``(z, x, y)`` and write them into the ``staging`` folder."""
    group, recipe = open_world(path)
    _stage(staging, [(_staged_name(z, x, y, ".png"), _rgb_tile(group, recipe, geo, z, x, y, fmt))
                     for z, x, y in tiles])


def _level_window(recipe, group, row, col, pixel: float):
    """The coarsest pyramid level whose samples are no larger than ``pixel`` full-resolution
    samples: its window around the (full-resolution) ``row``/``col`` positions, and those
    positions in the window's own samples. Division by a power of two and subtraction of
    whole numbers are exact, so bilinear weights are those of the whole map."""
    level = max(0, math.floor(math.log2(pixel))) if pixel > 1 else 0
    step = 1 << level
    lrows, lcols = level_shape(recipe.shape, level)
    lr = np.clip(row / step, 0, lrows - 1)
    lc = np.clip(col / step, 0, lcols - 1)
    a0, b0 = int(np.floor(lr.min())), int(np.floor(lc.min()))
    a1, b1 = min(lrows, int(np.floor(lr.max())) + 2), min(lcols, int(np.floor(lc.max())) + 2)
    return read_level(group, level, a0, a1, b0, b1), lr - a0, lc - b0


def _rgb_tile(group, recipe, geo, z: int, x: int, y: int, fmt: str) -> bytes:
    """The PNG bytes of tile ``z/x/y``."""
    from PIL import Image

    from terrascape.export._geo import mercator_tile_lonlat
    from terrascape.export.terrain_rgb import encode_mapbox, encode_terrarium

    west, north, dlon, dlat = geo
    rows, cols = recipe.shape
    t = (np.arange(TILE) + 0.5) / TILE
    lon, lat = mercator_tile_lonlat(z, x + t[None, :], y + t[:, None])
    lon, lat = np.broadcast_arrays(lon, lat)
    # As GeoGrid.sample: sample coordinates of the pixel centres, the inside mask, clamped.
    col = (np.asarray(lon, np.float64) - west) / dlon - 0.5
    row = (north - np.asarray(lat, np.float64)) / dlat - 0.5
    eps = 1e-9
    inside = (col >= -eps) & (col <= cols - 1 + eps) & (row >= -eps) & (row <= rows - 1 + eps)
    # Level: the coarsest whose samples are no larger than the tile's pixels.
    pixel = max(float(np.ptp(col[0])), float(np.ptp(row[:, 0]))) / (TILE - 1)
    row = np.clip(row, 0, rows - 1)
    col = np.clip(col, 0, cols - 1)
    window, lr, lc = _level_window(recipe, group, row, col, pixel)
    from scipy import ndimage

    # Whole numbers subtracted from the coordinates: exact, so the bilinear weights are
    # those of the whole map.
    h = ndimage.map_coordinates(window, np.stack([lr, lc]).reshape(2, -1), order=1,
                                mode="nearest", output=np.float64).reshape(lr.shape)
    encoder = encode_mapbox if fmt == "mapbox" else encode_terrarium
    rgba = np.zeros((TILE, TILE, 4), np.uint8)
    rgba[..., :3] = encoder(np.where(inside, h, 0.0))
    rgba[..., 3] = np.where(inside, 255, 0)
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
    return buf.getvalue()


def export_terrain_rgb(path, out_dir, *, lonlat: tuple[float, float], fmt: str = "mapbox",
                       min_zoom: int | None = None, max_zoom: int | None = None,
                       name: str = "world", client=None, force: bool = False) -> list[Path]:
    """Terrain-RGB (``fmt="mapbox"``) or Terrarium PNG tiles of the world (one task per
    :data:`RGB_TILES_PER_TASK` tiles), plus ``tiles.json``; zooms ``min_zoom`` (0) to
    ``max_zoom`` (as dense as the world)."""
    from terrascape.export._common import (
        _remove_empty_folders,
        check_out_dir,
        record_export,
        write_text,
    )
    from terrascape.export._geo import GeoGrid, mercator_tile_range
    from terrascape.export.terrain_rgb import FORMATS, finest_zoom

    if fmt not in FORMATS:
        raise InvalidParameterError(f"terrain_rgb --format must be mapbox or terrarium, got "
                                    f"{fmt!r}")
    group, recipe = open_world(path)
    if not group.attrs.get("complete", False):
        raise InvalidParameterError(f"{path} is not finished: run `terrascape world build` "
                                    "again to complete it before exporting")
    out = check_out_dir(out_dir)
    geo = _geo(recipe, lonlat)
    # A grid of the world's shape for the pyramid's geometry (no heights are read).
    grid = GeoGrid(np.broadcast_to(np.float32(0), recipe.shape), geo[0], geo[1], geo[2],
                   geo[3])
    top = finest_zoom(grid) if max_zoom is None else max_zoom
    bottom = min_zoom or 0
    if bottom > top:
        raise InvalidParameterError(f"--min-zoom {bottom} is above --max-zoom {top}")
    tiles = []
    for z in range(bottom, top + 1):
        x0, y0, x1, y1 = mercator_tile_range(z, grid.bounds)
        tiles += [(z, x, y) for x in range(x0, x1 + 1) for y in range(y0, y1 + 1)]
    n = RGB_TILES_PER_TASK
    zxy = np.array(tiles, np.int64).reshape(-1, 3)
    w, s, e, nn = grid.bounds
    tilejson = {"tilejson": "2.2.0", "name": name, "scheme": "xyz",
                "tiles": ["{z}/{x}/{y}.png"], "minzoom": bottom, "maxzoom": top,
                "bounds": [w, s, e, nn], "encoding": fmt, "tileSize": TILE}
    with _staged_tiles(out, zxy, ".png", force=force) as staging:
        _run(client, _rgb_tiles, [(str(path), geo, tiles[k:k + n], fmt, str(staging))
                                  for k in range(0, len(tiles), n)])
        written = [out / str(z) / str(x) / f"{y}.png" for z, x, y in tiles]
        written.append(write_text(out / "tiles.json", json.dumps(tilejson, indent=1) + "\n",
                                  force=force))
        # the manifest the in-memory export writes too; with force, the earlier export's
        # tiles this one does not write go
        removed = record_export(out, "terrain_rgb", name, written, force=force)
    _remove_empty_folders(removed, out)
    return written


# --- Cesium quantized-mesh ----------------------------------------------------------------
def _world_grid(recipe, lonlat):
    """A :class:`~terrascape.export._geo.GeoGrid` of the world's shape placed at ``lonlat``
    (as the single-map exporters place a map); its heights are a zero-size-in-memory
    broadcast — only the shape and georeference are used."""
    from terrascape.export._geo import GeoGrid

    west, north, dlon, dlat = _geo(recipe, lonlat)
    return GeoGrid(np.broadcast_to(np.float32(0), recipe.shape), west, north, dlon, dlat)


#: Tiles per quantized-mesh task: a tile takes a few milliseconds, so one task a tile would
#: be mostly scheduling; the task writes its tiles as one unit (see ``write_many``).
QM_TILES_PER_TASK = 64


def _quantized_mesh_tiles(path: str, lonlat, jobs: list, staging: str,
                          mesher: str | None = None) -> None:
    """Make the tiles ``jobs`` (``(z, x, y, error)`` each), meshed by the static mesher
    ``mesher``, and write them into the ``staging`` folder."""
    import numba

    numba.set_num_threads(1)  # one task = one core, as in a build
    group, recipe = open_world(path)
    _stage(staging, [(_staged_name(z, x, y, ".terrain"),
                      _quantized_mesh_tile(group, recipe, lonlat, z, x, y, error, mesher)[0])
                     for z, x, y, error in jobs])


def _quantized_mesh_tile(group, recipe, lonlat, z: int, x: int, y: int, error: float,
                         mesher: str | None = None) -> tuple[bytes, int]:
    """Sample, mesh and encode tile ``z/x/y``; returns its bytes and triangle count.

    The tile's 65 × 65 samples are bilinear in the pyramid level whose samples are no
    larger than the tile's (level 0 where the tiles are finer than the map: there they
    equal :func:`terrascape.export.cesium.tile_samples` of the map loaded whole, bit for
    bit), read as the small window that holds them.
    """
    from terrascape.export.cesium import bilinear_separable, encode_samples, tile_coordinates

    grid = _world_grid(recipe, lonlat)
    lon_1d, lat_1d, row, col, inside, bounds = tile_coordinates(grid, z, x, y)
    rows, cols = recipe.shape
    row = np.clip(row, 0, rows - 1)
    col = np.clip(col, 0, cols - 1)
    n = len(row) - 1
    pixel = max(float(np.ptp(row)), float(np.ptp(col))) / n
    window, lr, lc = _level_window(recipe, group, row, col, pixel)
    h = np.where(inside, bilinear_separable(window, lr, lc), 0.0)
    size = len(lon_1d)
    lon = np.broadcast_to(lon_1d, (size, size))
    lat = np.broadcast_to(lat_1d[:, None], (size, size))
    return encode_samples(lon, lat, h, inside, bounds, error, mesher)


def export_quantized_mesh(path, out_dir, *, lonlat: tuple[float, float],
                          min_zoom: int | None = None, max_zoom: int | None = None,
                          max_error: float = 1.0, name: str = "world", client=None,
                          force: bool = False, mesher: str | None = None) -> list[Path]:
    """The Cesium quantized-mesh 1.0 pyramid of the world (``layer.json`` and one
    ``z/x/y.terrain`` per tile, one task each), as ``terrascape export cesium`` writes it
    for a map: the same tiles, levels and per-level errors, meshed by the same static
    mesher (``mesher``; ``None``: the default); zooms ``min_zoom`` (0) to ``max_zoom``
    (the first as dense as the world)."""
    from terrascape.export._common import _remove_empty_folders, check_out_dir, record_export
    from terrascape.export.cesium import finest_level, tile_jobs, write_metadata
    from terrascape.lod.static_meshers import static_mesher

    mesher = static_mesher(mesher).name  # an unknown name fails here, not in a task
    _, recipe = _finished_world(path)
    if not (isinstance(max_error, int | float) and math.isfinite(max_error) and max_error > 0):
        raise InvalidParameterError(f"--max-error must be a positive number, got {max_error!r}")
    grid = _world_grid(recipe, lonlat)
    out = check_out_dir(out_dir)
    top = finest_level(grid) if max_zoom is None else max_zoom
    bottom = min_zoom or 0
    if bottom > top:
        raise InvalidParameterError(f"--min-zoom {bottom} is above --max-zoom {top}")
    jobs, available = tile_jobs(grid, bottom, top, max_error)
    ll = tuple(float(v) for v in lonlat)
    n = QM_TILES_PER_TASK
    zxy = np.array([job[:3] for job in jobs], np.int64).reshape(-1, 3)
    with _staged_tiles(out, zxy, ".terrain", force=force) as staging:
        _run(client, _quantized_mesh_tiles, [(str(path), ll, jobs[k:k + n], str(staging), mesher)
                                             for k in range(0, len(jobs), n)])
        written = [out / str(z) / str(x) / f"{y}.terrain" for z, x, y, _ in jobs]
        written += write_metadata(out, name, bottom, top, available, max_error, grid.bounds,
                                  force=force, mesher=mesher)
        removed = record_export(out, "cesium", name, written, force=force)
    _remove_empty_folders(removed, out)
    return written


__all__ = ["TIFF_BLOCK", "export_cog", "export_geotiff", "export_quantized_mesh",
           "export_terrain_rgb"]
