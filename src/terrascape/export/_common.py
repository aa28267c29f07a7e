"""Shared pieces of the engine exporters: explicit size fitting, 16-bit codes, layer weights,
tiles and atomic writes of the small "how to import" text files."""

from __future__ import annotations

import contextlib
import functools
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from terrascape.errors import HeightmapSizeError, InvalidParameterError
from terrascape.filters.resample import resample_cubic
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import (
    atomic_output,
    atomic_outputs,
    output_unit,
    remove_with_unit,
    unit_outputs,
)
from terrascape.io.image import PNG16_COMPRESS_LEVEL

FITS = ("pad", "resample", "crop")


@dataclass(frozen=True)
class ExportOptions:
    """What ``terrascape export ENGINE`` passes to an exporter.

    Attributes
    ----------
    name
        Base name of the files written (``Name.raw``, ``Name_X_Z.raw`` ...).
    fit
        ``None`` (a wrong size is an error), ``"pad"`` (repeat edge samples up to the next
        accepted size), ``"resample"`` (cubic, to the nearest accepted size, same world extent)
        or ``"crop"`` (keep the largest accepted size from the top-left corner).
    tiles
        Tiles per side (1: one file).
    flip
        Unity: write rows in image order (north first) for "Flip Vertically" on.
    format
        Exporter-specific output format (``png``/``r16``, ``exr``/``r16``, ``tiff``/``glb``).
    plugin
        Godot: ``hterrain`` or ``terrain3d``.
    layers
        Also write texture-layer weights (alphamaps / weight maps).
    force
        Overwrite existing files.
    lonlat
        Tile pyramids: put the map's centre at this (longitude, latitude); default: its CRS.
    min_zoom, max_zoom
        Tile pyramids: levels written (default 0 … the level as dense as the map).
    max_error
        Meshes (blender glb, web; cesium tiles at the finest level): vertical error, world
        units.
    mesher
        Meshes (blender glb, web, cesium tiles): a static mesher of
        :data:`terrascape.lod.static_meshers.STATIC_MESHERS` (``None``: the default); the
        exporters that mesh with it say so with ``TAKES_MESHER = True``.
    workers
        Tile pyramids: worker processes.
    compress
        Meshes (blender glb): ``None``/``"none"`` (float32 positions) or ``"quantize"``
        (``KHR_mesh_quantization``: int16 positions, int8 normals, uint16 texture coordinates).
    objects
        Objects exported with the terrain (:mod:`terrascape.export.instances`): ``None``,
        :class:`~terrascape.objects.Instances`, or a callable placing them on the heightmap
        as the destination fits it.
    """

    name: str = "terrain"
    fit: str | None = None
    tiles: int = 1
    flip: bool = False
    format: str | None = None
    plugin: str | None = None
    layers: bool = True
    force: bool = False
    lonlat: tuple[float, float] | None = None
    min_zoom: int | None = None
    max_zoom: int | None = None
    max_error: float | None = None
    mesher: str | None = None
    workers: int = 2
    objects: object = None
    compress: str | None = None


def _fit_axis(n: int, accepted: Sequence[int], fit: str) -> int:
    accepted = sorted(accepted)
    if fit == "pad":
        bigger = [a for a in accepted if a >= n]
        if not bigger:
            raise HeightmapSizeError(
                f"{n} samples is more than the largest accepted size {accepted[-1]}; "
                "use --fit resample or --fit crop"
            )
        return bigger[0]
    if fit == "crop":
        smaller = [a for a in accepted if a <= n]
        if not smaller:
            raise HeightmapSizeError(
                f"{n} samples is less than the smallest accepted size {accepted[0]}; "
                "use --fit pad or --fit resample"
            )
        return smaller[-1]
    return min(accepted, key=lambda a: (abs(a - n), a))


def fit_to_sizes(
    heightmap: Heightmap,
    accepted: Sequence[int],
    fit: str | None,
    *,
    square: bool,
    what: str,
) -> Heightmap:
    """Return a map whose sides are in ``accepted`` (and equal when ``square``).

    Never resamples silently: without ``fit`` a wrong size raises
    :class:`~terrascape.errors.HeightmapSizeError` listing the accepted sizes.
    """
    rows, cols = heightmap.shape
    ok = rows in accepted and cols in accepted and (rows == cols or not square)
    if ok:
        return heightmap
    if fit is None:
        shape = "square " if square else ""
        raise HeightmapSizeError(
            f"{what} takes {shape}heightmaps of {', '.join(map(str, accepted))} samples per side; "
            f"this one is {cols}×{rows}: pass --fit pad, --fit resample or --fit crop"
        )
    if fit not in FITS:
        raise InvalidParameterError(f"--fit must be one of {', '.join(FITS)}, got {fit!r}")
    if square:
        basis = max(rows, cols) if fit != "crop" else min(rows, cols)
        side = _fit_axis(basis, accepted, fit)
        target = (side, side)
    else:
        target = (_fit_axis(rows, accepted, fit), _fit_axis(cols, accepted, fit))
    h = heightmap.heights
    if fit == "pad":
        out = np.pad(h, ((0, max(0, target[0] - rows)), (0, max(0, target[1] - cols))), "edge")
        out = out[:target[0], :target[1]]
        return heightmap.with_heights(out)
    if fit == "crop":
        if target[0] > rows or target[1] > cols:
            raise HeightmapSizeError(
                f"cannot crop {cols}×{rows} to {target[1]}×{target[0]}; use --fit pad"
            )
        return heightmap.with_heights(h[:target[0], :target[1]])
    out = resample_cubic(h, target)
    ex, ez = heightmap.extent
    md = dict(heightmap.metadata)
    md.pop("nodata_mask", None)
    return Heightmap(out, (ex / (target[1] - 1), ez / (target[0] - 1)), md,
                     heightmap.origin, heightmap.crs, heightmap.nodata)


def tiled_sizes(tile_sizes: Sequence[int], tiles: int) -> list[int]:
    """Whole-map sizes that split into ``tiles`` tiles per side sharing their edge samples."""
    return [tiles * (s - 1) + 1 for s in tile_sizes]


def split_tiles(heights: np.ndarray, tiles: int) -> dict[tuple[int, int], np.ndarray]:
    """``{(row_tile, col_tile): block}``; neighbouring blocks share one row/column of samples."""
    rows, cols = heights.shape
    tr, tc = (rows - 1) // tiles, (cols - 1) // tiles
    return {(i, j): heights[i * tr:(i + 1) * tr + 1, j * tc:(j + 1) * tc + 1]
            for i in range(tiles) for j in range(tiles)}


# rows of a map converted to codes at a time: float64 temporaries of a band, not the map's
_CODE_ROWS = 256


def _rounded_codes(values: np.ndarray, lo: float, scale: float, top: int,
                   dtype: type) -> np.ndarray:
    """``clip(rint((values - lo)·scale), 0, top)`` as ``dtype``, computed in float64 a band
    of rows at a time (the same values as on the whole array, without its float64 copies)."""
    out = np.empty(values.shape, dtype)
    for start in range(0, values.shape[0], _CODE_ROWS):
        rows = slice(start, start + _CODE_ROWS)
        band = values[rows].astype(np.float64)
        band -= lo
        band *= scale
        np.rint(band, out=band)
        np.clip(band, 0, top, out=band)
        out[rows] = band
    return out


def uint16_codes(heights: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Heights mapped linearly onto 0…65535 (``lo`` → 0, ``hi`` → 65535), rounded."""
    span = hi - lo
    if span <= 0:
        return np.zeros(heights.shape, np.uint16)
    return _rounded_codes(heights, lo, 65535.0 / span, 65535, np.uint16)


def weight_codes(weights: np.ndarray) -> np.ndarray:
    """8-bit codes ``round(255·w)`` of weights in [0, 1] (any shape, rows first)."""
    return _rounded_codes(weights, 0.0, 255.0, 255, np.uint8)


def layer_weights(heightmap: Heightmap, seed: int = 0) -> tuple[list[str], np.ndarray]:
    """Texture-layer names and weights ``(rows, cols, layers)`` (sum 1) of the default height
    regions: float32, a view of the layers (each one contiguous)."""
    from terrascape.texture import default_regions, region_weights

    regions = default_regions(heightmap)
    w = region_weights(heightmap.heights, regions, seed=seed, slope=heightmap.slope(),
                       slope_rule=True)
    return [r.name for r in regions], np.moveaxis(w, 0, -1)


def write_bytes(path: Path, data: bytes, *, force: bool) -> Path:
    with atomic_output(path, force=force) as tmp:
        Path(tmp).write_bytes(data)
    return path


#: Threads flushing a batch of small files to the disk (see ``atomic_outputs``).
SYNC_THREADS = 8


def manifest_path(out_dir: str | os.PathLike, destination: str, name: str) -> Path:
    """The hidden list of the files an export of ``destination`` named ``name`` wrote into
    ``out_dir`` (read by the next ``force`` export of the same name and destination)."""
    return Path(out_dir) / f".{name}.{destination}-export.json"


def _listed_files(manifest: Path, out: Path) -> list[Path]:
    """The files a previous export's manifest lists, inside ``out`` only; none when the
    manifest is missing or unreadable (then nothing is removed)."""
    try:
        listed = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    files = []
    top = out.resolve()
    for rel in listed if isinstance(listed, list) else []:
        if not isinstance(rel, str) or not rel or os.path.isabs(rel):
            continue
        path = out / rel
        with contextlib.suppress(OSError, ValueError):
            path.parent.resolve().relative_to(top)  # never outside the output folder
            files.append(path)
    return files


def _remove_empty_folders(files: list[Path], out: Path) -> None:
    """Remove the folders below ``out`` that removing ``files`` left empty (a pyramid's
    levels and columns no longer written)."""
    folders = {f.parent for f in files}
    for folder in sorted(folders, key=lambda f: -len(f.parts)):
        while folder != out and out in folder.parents:
            try:
                folder.rmdir()
            except OSError:
                break
            folder = folder.parent


class ExportedFiles(list):
    """The files an export wrote (a list of paths), and in ``removed`` those of the previous
    export of its name that a ``force`` export removed because it no longer writes them."""

    removed: list[Path]


def one_unit(export: Callable[[Heightmap, Any, ExportOptions], list[Path]]
             ) -> Callable[[Heightmap, Any, ExportOptions], list[Path]]:
    """A destination's ``export`` whose files all appear when it ends, or none do
    (:func:`terrascape.io.atomic.output_unit`): interrupted or failing half-way (a signal,
    a full disk, an existing file without ``force``), it leaves no file of its own, not
    even those it had finished; with ``force``, the previous export's files stay as they
    were.

    The export also lists its files in a hidden manifest (:func:`manifest_path`). With
    ``force``, the files the previous export of the same name and destination listed and
    this one does not write (tiles of another count, levels no longer written) are
    removed in the same commit: the folder then holds one export, not a mix of two. No
    other file is ever removed."""
    destination = export.__module__.rsplit(".", 1)[-1]

    @functools.wraps(export)
    def export_as_one_unit(heightmap: Heightmap, out_dir: Any,
                           options: ExportOptions) -> list[Path]:
        with output_unit(sync_threads=SYNC_THREADS):
            written = export(heightmap, out_dir, options)
            removed = record_export(Path(out_dir), destination, options.name, unit_outputs(),
                                    force=options.force)
        _remove_empty_folders(removed, Path(out_dir))
        files = ExportedFiles(written)
        files.removed = list(removed)
        return files

    return export_as_one_unit


def record_export(out: Path, destination: str, name: str, files: Sequence[Path], *,
                  force: bool) -> list[Path]:
    """Inside an :func:`~terrascape.io.atomic.output_unit`: write the manifest of an export
    of ``files`` into ``out``, and with ``force`` have the unit's commit remove the files
    the previous manifest listed and ``files`` lacks. Returns the list the removed files
    are put in once the unit has committed (then :func:`_remove_empty_folders`)."""
    manifest = manifest_path(out, destination, name)
    removed = remove_with_unit(lambda: _listed_files(manifest, out)) if force else []
    listed = sorted(path.relative_to(out).as_posix() for path in map(Path, files)
                    if out in path.parents)
    record = {"destination": destination, "name": name, "files": listed}
    # the bookkeeping of this folder's exports: replaced whatever ``force`` says
    write_text(manifest, json.dumps(record, indent=0) + "\n", force=True)
    return removed


def write_many(items: list[tuple[Path, bytes]], *, force: bool) -> list[Path]:
    """Write every ``(path, bytes)`` as one atomic unit (all files or none; inside an
    export's unit, with the export's other files), flushed to the disk by
    :data:`SYNC_THREADS` threads: for the thousands of small files of a tile pyramid, a
    flush and a commit per file would take longer than making the tiles."""
    if not items:
        return []
    for path, _ in items:
        path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_outputs([p for p, _ in items], force=force, sync_threads=SYNC_THREADS) as tmps:
        for tmp, (_, data) in zip(tmps, items, strict=True):
            Path(tmp).write_bytes(data)
    return [p for p, _ in items]


def write_text(path: Path, text: str, *, force: bool) -> Path:
    return write_bytes(path, text.encode("utf-8"), force=force)


def write_png(path: Path, image: np.ndarray, *, force: bool) -> Path:
    """8-bit gray/RGB(A) or 16-bit gray PNG, atomically (16-bit heights at
    :data:`~terrascape.io.image.PNG16_COMPRESS_LEVEL`)."""
    level = PNG16_COMPRESS_LEVEL if image.dtype == np.uint16 else 6  # 6: Pillow's default
    with atomic_output(path, force=force) as tmp:
        Image.fromarray(np.ascontiguousarray(image)).save(tmp, format="PNG",
                                                          compress_level=level)
    return path


def check_out_dir(out_dir: str | os.PathLike) -> Path:
    p = Path(out_dir)
    if p.exists() and not p.is_dir():
        raise InvalidParameterError(f"{p} is a file; expected an output folder")
    p.mkdir(parents=True, exist_ok=True)
    return p


def check_name(name: str) -> str:
    if not name or any(ch in name for ch in "/\\:*?\"<>|") or name.startswith("."):
        raise InvalidParameterError(f"--name must be a plain file name, got {name!r}")
    return name


def write_world_file(image: Path, heightmap: Heightmap, *, row: int = 0, col: int = 0,
                     force: bool) -> list[Path]:
    """Georeference an image that holds ``heightmap`` from sample ``[row, col]`` on (its
    row 0 to the north): an ESRI world file (``.pgw`` next to a ``.png``) and the CRS in a
    GDAL ``.aux.xml``, which GDAL, QGIS and rasterio read. Nothing for a map without a CRS.

    The world file's six lines are the pixel's x size, two rotations (0), minus its y size,
    and the CRS coordinates of the *centre* of the image's first pixel.
    """
    if heightmap.crs is None:
        return []
    from terrascape.io.geotiff import crs_pixel_size

    px, py = crs_pixel_size(heightmap)
    x = heightmap.origin[0] + (col + 0.5) * px
    y = heightmap.origin[1] - (row + 0.5) * py
    suffix = image.suffix.lower()
    world = image.with_suffix(suffix[:2] + suffix[-1] + "w")  # .png → .pgw
    lines = [f"{px!r}", "0.0", "0.0", f"{-py!r}", f"{x!r}", f"{y!r}"]
    written = [write_text(world, "\n".join(lines) + "\n", force=force)]
    try:
        from rasterio.crs import CRS
    except ImportError:  # the world file alone still places the image
        return written
    wkt = CRS.from_user_input(heightmap.crs).to_wkt()
    wkt = wkt.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    aux = image.with_name(image.name + ".aux.xml")
    written.append(write_text(aux, f"<PAMDataset>\n  <SRS>{wkt}</SRS>\n</PAMDataset>\n",
                              force=force))
    return written
