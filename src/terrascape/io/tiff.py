"""TIFF / GeoTIFF heightmaps (tifffile): any integer or float sample type in, float32 out.

Sample values are taken as world heights (the DEM convention of GeoTIFF/GDAL; a 16-bit TIFF
holding metres is not normalised). GeoTIFF tags used:

* ``GDAL_NODATA`` (42113, ASCII): samples equal to it — and non-finite float samples — are
  nodata and are filled from the nearest valid sample (:func:`terrascape.io.fill.fill_nodata`)
  with a warning saying how many were filled.
* ``ModelPixelScaleTag`` (33550): ``(sx, sy, sz)`` → sample spacing ``(dx, dz) = (sx, sy)``.
* ``GeoKeyDirectoryTag`` (34735): if ``GTModelTypeGeoKey`` (1024) is 2 (geographic), the
  pixel scale is in degrees and is converted to metres at the tile's centre latitude, which
  comes from ``ModelTiepointTag`` (33922) and the pixel scale
  (see :func:`geographic_spacing` for the WGS84 formula).
"""

from __future__ import annotations

import logging
import math
import os
import struct
import warnings
from pathlib import Path

import numpy as np
import tifffile

from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    file_metadata,
    normalise_spacing,
)
from terrascape.io.atomic import atomic_output
from terrascape.io.fill import fill_nodata

TAG_MODEL_PIXEL_SCALE = 33550
TAG_MODEL_TIEPOINT = 33922
TAG_GEO_KEY_DIRECTORY = 34735
TAG_GDAL_NODATA = 42113
GEOKEY_MODEL_TYPE = 1024
GEOKEY_RASTER_TYPE = 1025
GEOKEY_GEOGRAPHIC_TYPE = 2048
GEOKEY_PROJECTED_CS = 3072
MODEL_TYPE_PROJECTED = 1
MODEL_TYPE_GEOGRAPHIC = 2
RASTER_PIXEL_IS_AREA = 1

# WGS84 ellipsoid.
_WGS84_A = 6378137.0
_WGS84_F = 1.0 / 298.257223563
_WGS84_E2 = _WGS84_F * (2.0 - _WGS84_F)


def geographic_spacing(
    scale_x_deg: float, scale_y_deg: float, latitude_deg: float
) -> tuple[float, float]:
    """Metres per sample for a pixel scale given in degrees, at ``latitude_deg``.

    Uses the WGS84 radii of curvature instead of the spherical 111 320 m/° rule:
    ``N = a / sqrt(1 − e² sin²φ)`` (prime vertical) and ``M = a(1 − e²) / (1 − e² sin²φ)^1.5``
    (meridian), so ``dx = sx · π/180 · N cos φ`` and ``dz = sy · π/180 · M``. At the equator
    this gives 111 319.5 m/° east and 110 574.3 m/° north, the two constants of the simple
    rule, and stays exact (to the ellipsoid) at high latitudes.
    """
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise InvalidParameterError(f"latitude must be in [-90, 90] degrees, got {latitude_deg}")
    phi = math.radians(latitude_deg)
    w = 1.0 - _WGS84_E2 * math.sin(phi) ** 2
    n = _WGS84_A / math.sqrt(w)
    m = _WGS84_A * (1.0 - _WGS84_E2) / w**1.5
    dx = abs(scale_x_deg) * math.radians(1.0) * n * math.cos(phi)
    dz = abs(scale_y_deg) * math.radians(1.0) * m
    return dx, dz


def _geokeys(directory: object) -> dict[int, int]:
    """Short (inline) geokeys from a raw GeoKeyDirectoryTag value: ``{key_id: value}``."""
    values = [int(v) for v in np.asarray(directory).ravel()]
    if len(values) < 4:
        raise FileFormatError(f"GeoKeyDirectoryTag too short: {len(values)} values")
    count = values[3]
    keys: dict[int, int] = {}
    for k in range(count):
        entry = values[4 + 4 * k : 8 + 4 * k]
        if len(entry) < 4:
            raise FileFormatError("GeoKeyDirectoryTag is truncated")
        key_id, location, _n, value = entry
        if location == 0:  # value stored inline (all the SHORT keys we need)
            keys[key_id] = value
    return keys


def _tag_values(tags: dict, code: int) -> list[float] | None:
    if code not in tags:
        return None
    return [float(v) for v in np.asarray(tags[code]).ravel()]


def _parse_nodata(text: object) -> float | None:
    if isinstance(text, bytes):
        text = text.decode("latin-1")
    s = str(text).strip().strip("\x00").strip()
    if not s:
        return None
    try:
        return float(s)
    except ValueError:
        raise FileFormatError(f"bad GDAL_NODATA value {s!r}; expected a number") from None


def read_tiff(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read the first image of a (Geo)TIFF as world heights.

    Parameters
    ----------
    spacing
        Override ``(dx, dz)``; default from ModelPixelScale (converted from degrees for
        geographic models), else ``(1, 1)``.
    vertical_scale
        Multiplier on the heights (default 1).

    Warns
    -----
    UserWarning
        When nodata samples were filled (says how many).

    Raises
    ------
    FileFormatError
        Missing/corrupt/truncated file, multi-band or non-numeric image, all-nodata image.
    """
    p = check_input_path(path)
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    # tifffile logs (not raises) when it cannot parse tags it interprets itself, such as a
    # GDAL_NODATA it cannot cast; we parse those tags ourselves, so silence that chatter.
    tiff_log = logging.getLogger("tifffile")
    old_level = tiff_log.level
    tiff_log.setLevel(logging.ERROR)
    try:
        with tifffile.TiffFile(p) as tif:
            page = tif.pages[0]
            data = page.asarray()
            tags = {tag.code: tag.value for tag in page.tags}
    except TerrascapeError:
        raise
    except (
        tifffile.TiffFileError,
        OSError,
        ValueError,
        struct.error,
        IndexError,
        KeyError,
        EOFError,
        TypeError,
        RuntimeError,
    ) as exc:
        raise FileFormatError(f"cannot read TIFF {p}: {exc}") from None
    finally:
        tiff_log.setLevel(old_level)

    data = np.asarray(data)
    if data.ndim == 3 and 1 in data.shape:
        data = data.reshape([s for s in data.shape if s != 1] or [1])
    if data.ndim != 2:
        raise FileFormatError(
            f"expected a single-band 2-D TIFF in {p}, got array shape {data.shape}"
        )
    if not (np.issubdtype(data.dtype, np.integer) or np.issubdtype(data.dtype, np.floating)):
        raise FileFormatError(f"expected integer or float TIFF samples in {p}, got {data.dtype}")

    nodata = _parse_nodata(tags[TAG_GDAL_NODATA]) if TAG_GDAL_NODATA in tags else None
    heights, invalid = fill_invalid(data, nodata, p)
    filled = int(np.count_nonzero(invalid))
    if vscale is not None:
        heights = heights * vscale

    file_spacing, geographic = _tiff_spacing(tags, data.shape, p)
    sp = spacing_t or file_spacing or (1.0, 1.0)
    md = file_metadata(
        p,
        "tiff",
        str(data.dtype),
        step=0.0,
        filled=filled,
        geographic=geographic,
        nodata=nodata,
    )
    if filled:
        md["nodata_mask"] = invalid
    origin, pixel = _tiff_origin(tags)
    if geographic and pixel is not None:
        md["crs_pixel_size"] = pixel
        md["crs_pixel_spacing"] = sp
    return Heightmap(np.asarray(heights, dtype=np.float32), sp, md, origin=origin,
                     crs=_tiff_epsg(tags), nodata=nodata)


def fill_invalid(data: np.ndarray, nodata: float | None, p: Path) -> tuple[np.ndarray, np.ndarray]:
    """float64 heights with nodata and non-finite samples filled from their nearest valid
    neighbours (warning with the count), and the boolean mask of the filled samples."""
    invalid = np.zeros(data.shape, dtype=bool)
    if nodata is not None:
        if np.issubdtype(data.dtype, np.floating):
            # Exact match in the file's precision and in float64 ...
            with np.errstate(over="ignore", invalid="ignore"):
                invalid |= data == np.asarray(nodata).astype(data.dtype)
                invalid |= data.astype(np.float64) == nodata
                # ... and the ±FLT_MAX/DBL_MAX sentinels, which GDAL may print with only six
                # digits ("-3.40282e+38"), within 1e-5 relative. No real height is near 1e30.
                if abs(nodata) > 1e30:
                    invalid |= np.abs(data.astype(np.float64) - nodata) <= 1e-5 * abs(nodata)
        elif float(nodata).is_integer():
            invalid |= data.astype(np.float64) == nodata
    if np.issubdtype(data.dtype, np.floating):
        invalid |= ~np.isfinite(data)

    heights = data.astype(np.float64)
    filled = int(np.count_nonzero(invalid))
    if filled:
        if filled == data.size:
            raise FileFormatError(f"{p}: all {data.size} samples are nodata")
        heights[invalid] = np.nan
        heights, filled = fill_nodata(heights)
        warnings.warn(
            f"{p.name}: filled {filled} nodata sample(s) of {data.size} from their nearest "
            "valid neighbours",
            stacklevel=3,
        )
    return heights, invalid


def _tiff_origin(tags: dict) -> tuple[tuple[float, float], tuple[float, float] | None]:
    """Corner of sample [0, 0] (CRS units) and pixel size from the tiepoint and pixel scale."""
    scale = _tag_values(tags, TAG_MODEL_PIXEL_SCALE)
    tie = _tag_values(tags, TAG_MODEL_TIEPOINT)
    if scale is None or tie is None or len(tie) < 6 or len(scale) < 2:
        return (0.0, 0.0), None
    keys = _geokeys(tags[TAG_GEO_KEY_DIRECTORY]) if TAG_GEO_KEY_DIRECTORY in tags else {}
    i, j, x, y = tie[0], tie[1], tie[3], tie[4]
    if keys.get(GEOKEY_RASTER_TYPE, RASTER_PIXEL_IS_AREA) != RASTER_PIXEL_IS_AREA:
        i, j = i + 0.5, j + 0.5  # PixelIsPoint: the tiepoint names a sample centre
    sx, sy = abs(scale[0]), abs(scale[1])
    return (x - i * sx, y + j * sy), (sx, sy)


def _tiff_epsg(tags: dict) -> str | None:
    """``"EPSG:n"`` from ProjectedCSTypeGeoKey (3072) or GeographicTypeGeoKey (2048)."""
    if TAG_GEO_KEY_DIRECTORY not in tags:
        return None
    keys = _geokeys(tags[TAG_GEO_KEY_DIRECTORY])
    for key in (GEOKEY_PROJECTED_CS, GEOKEY_GEOGRAPHIC_TYPE):
        code = keys.get(key)
        if code is not None and 1024 <= code < 32767:  # user-defined / undefined are not codes
            return f"EPSG:{code}"
    return None


def _tiff_spacing(
    tags: dict, shape: tuple[int, int], p: Path
) -> tuple[tuple[float, float] | None, bool]:
    scale = _tag_values(tags, TAG_MODEL_PIXEL_SCALE)
    if scale is None:
        return None, False
    if len(scale) < 2 or not all(math.isfinite(v) and v != 0 for v in scale[:2]):
        raise FileFormatError(f"bad ModelPixelScaleTag in {p}: {scale}")
    sx, sy = abs(scale[0]), abs(scale[1])
    keys = _geokeys(tags[TAG_GEO_KEY_DIRECTORY]) if TAG_GEO_KEY_DIRECTORY in tags else {}
    if keys.get(GEOKEY_MODEL_TYPE) != MODEL_TYPE_GEOGRAPHIC:
        return (sx, sy), False
    tie = _tag_values(tags, TAG_MODEL_TIEPOINT)
    if tie is None or len(tie) < 6:
        warnings.warn(
            f"{p.name}: geographic GeoTIFF without ModelTiepointTag; converting degrees to "
            "metres at latitude 0",
            stacklevel=3,
        )
        lat = 0.0
    else:
        # Tiepoint (i, j, k, lon, lat, h): raster (i, j) sits at (lon, lat). Rows go south
        # (sy > 0 means latitude decreases with the row). With PixelIsArea the centre of
        # row r is at raster coordinate r + 0.5.
        j, lat0 = tie[1], tie[4]
        half = 0.5 if keys.get(GEOKEY_RASTER_TYPE, RASTER_PIXEL_IS_AREA) == 1 else 0.0
        centre_row = (shape[0] - 1) / 2.0 + half
        lat = lat0 - scale[1] * (centre_row - j)
        lat = min(90.0, max(-90.0, lat))
    return geographic_spacing(sx, sy, lat), True


def write_tiff(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write a float32 TIFF (exact) with ModelPixelScale and a tiepoint at the map's origin.

    This is the writer used without rasterio. An ``"EPSG:n"`` CRS is written as a
    GeoKeyDirectory (projected or geographic model, PixelIsArea) and ``nodata`` as
    GDAL_NODATA, restored where the source had holes; other CRSs (WKT) need rasterio
    (:func:`terrascape.io.geotiff.write_geotiff`). Readers that understand GeoTIFF (GDAL,
    QGIS, :func:`read_tiff`) get the spacing and georeference.
    """
    check_heightmap(heightmap)
    from terrascape.io.geotiff import crs_pixel_size, is_geographic_epsg, restore_nodata

    px, py = crs_pixel_size(heightmap)
    ox, oy = heightmap.origin
    extratags = [
        (TAG_MODEL_PIXEL_SCALE, "d", 3, (float(px), float(py), 0.0), True),
        (TAG_MODEL_TIEPOINT, "d", 6, (0.0, 0.0, 0.0, float(ox), float(oy), 0.0), True),
    ]
    crs = heightmap.crs
    if crs is not None and crs.upper().startswith("EPSG:") and crs[5:].isdigit():
        code = int(crs[5:])
        geographic = is_geographic_epsg(code)
        model = MODEL_TYPE_GEOGRAPHIC if geographic else MODEL_TYPE_PROJECTED
        cs_key = GEOKEY_GEOGRAPHIC_TYPE if geographic else GEOKEY_PROJECTED_CS
        keys = (1, 1, 0, 3, GEOKEY_MODEL_TYPE, 0, 1, model, GEOKEY_RASTER_TYPE, 0, 1,
                RASTER_PIXEL_IS_AREA, cs_key, 0, 1, code)
        extratags.append((TAG_GEO_KEY_DIRECTORY, "H", len(keys), keys, True))
    data = restore_nodata(heightmap)
    if heightmap.nodata is not None:
        extratags.append((TAG_GDAL_NODATA, "s", 0, repr(float(heightmap.nodata)), True))
    with atomic_output(path, force=force) as tmp:
        tifffile.imwrite(
            tmp,
            data,
            photometric="minisblack",
            metadata=None,
            extratags=extratags,
        )
    return Path(path)
