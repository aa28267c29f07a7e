"""Cloud-Optimized GeoTIFF (COG) heightmaps through GDAL's COG driver (rasterio).

A COG is a tiled GeoTIFF whose overviews (reduced-resolution copies) are stored in the same
file, with every image directory (IFD) at the start of the file and the tiles ordered from
the coarsest overview to the full resolution, so a client reading over HTTP range requests
(QGIS, GDAL's ``/vsicurl/``, titiler, OpenLayers) fetches only the tiles of the window and
the zoom it draws. GDAL's COG driver writes that layout (and its "ghost" header that says
so, ``LAYOUT=COG``) by copying a finished dataset: :func:`write_cog` copies a map from
memory, :func:`copy_to_cog` copies a tiled GeoTIFF on disk block by block (what a world's
export uses, so no process holds the whole map).

Heights stay float32, DEFLATE-compressed with the floating-point predictor (lossless); the
overviews halve the resolution until one 512² tile holds the map, each sample the average
of the ones below it (nodata excluded). Transform, CRS and nodata are those of the source.

References
----------
- Cloud Optimized GeoTIFF specification, https://github.com/cogeotiff/cog-spec (2023).
- GDAL, "COG -- Cloud Optimized GeoTIFF generator", https://gdal.org/drivers/raster/cog.html.
"""

from __future__ import annotations

import os
from pathlib import Path

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io._common import check_heightmap
from terrascape.io.atomic import atomic_output
from terrascape.io.geotiff import geotransform, quiet_not_georeferenced, restore_nodata

#: Pixels per side of a COG tile (GDAL's default, and the usual web-map tile multiple).
COG_BLOCK = 512
#: How an overview sample is made from the four below it.
OVERVIEW_RESAMPLING = "average"

__all__ = [
    "COG_BLOCK",
    "OVERVIEW_RESAMPLING",
    "cog_creation_options",
    "copy_to_cog",
    "write_cog",
]


def _rasterio():
    try:
        import rasterio
    except ImportError:
        raise InvalidParameterError(
            "Cloud-Optimized GeoTIFF needs rasterio: pip install 'terrascape[geo]'") from None
    return rasterio


def _check_tif(path: Path) -> None:
    if path.suffix.lower() not in (".tif", ".tiff"):
        raise FileFormatError(f"a Cloud-Optimized GeoTIFF must end in .tif, got {path.name!r}")


def cog_creation_options(*, blocksize: int = COG_BLOCK,
                         resampling: str = OVERVIEW_RESAMPLING) -> dict[str, str]:
    """The GDAL COG driver's creation options terrascape writes with (lossless float32)."""
    if not isinstance(blocksize, int) or blocksize < 16 or blocksize % 16:
        raise InvalidParameterError(
            f"COG block size must be a multiple of 16 (≥ 16), got {blocksize!r}")
    return {"BLOCKSIZE": str(blocksize), "COMPRESS": "DEFLATE", "PREDICTOR": "FLOATING_POINT",
            "OVERVIEWS": "IGNORE_EXISTING", "OVERVIEW_RESAMPLING": resampling.upper(),
            "BIGTIFF": "IF_SAFER", "NUM_THREADS": "1"}


def copy_to_cog(source: str | os.PathLike, path: str | os.PathLike, *, force: bool = False,
                blocksize: int = COG_BLOCK, resampling: str = OVERVIEW_RESAMPLING) -> Path:
    """Copy the raster ``source`` (any file GDAL reads, e.g. a tiled GeoTIFF) to a COG at
    ``path``, atomically, keeping its transform, CRS, nodata and metadata tags.

    GDAL reads the source block by block and builds the overviews in a temporary file next
    to the output, so memory stays bounded for maps larger than memory.
    """
    rasterio = _rasterio()
    from rasterio.shutil import copy as gdal_copy

    path = Path(path)
    _check_tif(path)
    options = cog_creation_options(blocksize=blocksize, resampling=resampling)
    with (atomic_output(path, force=force) as tmp, rasterio.Env(GDAL_NUM_THREADS="1"),
          quiet_not_georeferenced(), rasterio.open(source) as src):
        gdal_copy(src, tmp, driver="COG", **options)
    return path


def write_cog(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False,
              blocksize: int = COG_BLOCK, resampling: str = OVERVIEW_RESAMPLING) -> Path:
    """Write ``heightmap`` as a float32 Cloud-Optimized GeoTIFF, atomically, with its
    transform, CRS and nodata (as :func:`~terrascape.io.geotiff.write_geotiff` does)."""
    rasterio = _rasterio()
    from rasterio.crs import CRS
    from rasterio.io import MemoryFile
    from rasterio.shutil import copy as gdal_copy


    check_heightmap(heightmap)
    path = Path(path)
    _check_tif(path)
    options = cog_creation_options(blocksize=blocksize, resampling=resampling)
    crs = None
    if heightmap.crs is not None:
        try:
            crs = CRS.from_user_input(heightmap.crs)
        except Exception as exc:
            raise InvalidParameterError(f"unknown CRS {heightmap.crs[:60]!r}: {exc}") from None
    profile = {"driver": "GTiff", "width": heightmap.cols, "height": heightmap.rows,
               "count": 1, "dtype": "float32", "crs": crs,
               "transform": rasterio.Affine(*geotransform(heightmap)),
               "nodata": heightmap.nodata}
    sp = heightmap.spacing
    with atomic_output(path, force=force) as tmp, quiet_not_georeferenced(), MemoryFile() as memory:
        with memory.open(**profile) as mem:
            mem.write(restore_nodata(heightmap), 1)
            # Local maps (no CRS) keep their spacing in world units as a tag too.
            mem.update_tags(spacing=f"{sp[0]!r},{sp[1]!r}")
        with rasterio.Env(GDAL_NUM_THREADS="1"), memory.open() as mem:
            gdal_copy(mem, tmp, driver="COG", **options)
    return path
