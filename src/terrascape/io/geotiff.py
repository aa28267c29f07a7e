"""GeoTIFF heightmaps through rasterio (GDAL): transform, CRS and nodata kept exactly.

:func:`read_geotiff` / :func:`write_geotiff` are what ``.tif`` files go through when
rasterio (the ``geo`` extra) is installed; without it they fall back to the tifffile
reader/writer of :mod:`terrascape.io.tiff`, which keeps an EPSG code, the origin and nodata.

The georeference model is that of :class:`~terrascape.heightmap.Heightmap`: ``origin`` is the
outer corner of sample ``[0, 0]`` (GDAL's geotransform ``(c, f)``), rows run south. Projected
CRSs keep their pixel size as ``spacing``; for geographic CRSs (degrees) ``spacing`` is in
metres at the centre latitude (as the tifffile reader does) and the exact pixel size in degrees
rides in ``metadata["crs_pixel_size"]`` so the file written back has the same transform.

:func:`reproject` warps a map to another CRS (``rasterio.warp``), e.g. a DEM in degrees to
UTM metres; :func:`degree_warning` says when a map without a CRS has a spacing that looks
like degrees (the renderer would draw a needle 0.3 units wide and 800 tall).
"""

from __future__ import annotations

import contextlib
import math
import os
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np

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

__all__ = [
    "assign_crs",
    "crs_pixel_size",
    "degree_warning",
    "geotransform",
    "quiet_not_georeferenced",
    "rasterio_available",
    "read_geotiff",
    "reproject",
    "restore_nodata",
    "write_geotiff",
]


def rasterio_available() -> bool:
    """True when rasterio (GDAL) can be imported."""
    try:
        import rasterio  # noqa: F401
    except ImportError:
        return False
    return True


@contextlib.contextmanager
def quiet_not_georeferenced() -> Iterator[None]:
    """Rasterio's "not georeferenced" warning silenced while a GeoTIFF is read or written.

    A map without a CRS at spacing 1 has the transform (1, 0, 0, 0, −1, 0), which rasterio
    warns "may be ignored" on writing; GDAL's GeoTIFF and COG drivers keep it (read back
    equal), and a plain TIFF read is not georeferenced by design: neither is the user's
    problem."""
    import rasterio.errors

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        yield


def _require_rasterio(what: str):
    try:
        import rasterio
    except ImportError:
        raise InvalidParameterError(
            f"{what} needs rasterio: pip install 'terrascape[geo]'"
        ) from None
    return rasterio


def is_geographic_epsg(code: int) -> bool:
    """True for a geographic (degrees) EPSG code; rasterio decides when installed, else the
    common geographic codes (4326 WGS84, 4269 NAD83, 4258 ETRS89, 4230, 4267, 4283, 4612)."""
    if rasterio_available():
        from rasterio.crs import CRS

        try:
            return bool(CRS.from_epsg(code).is_geographic)
        except Exception:
            pass
    return code in {4326, 4269, 4258, 4230, 4267, 4283, 4612, 4019}


def _crs_is_geographic(crs: str | None) -> bool:
    if crs is None:
        return False
    if crs.upper().startswith("EPSG:") and crs[5:].isdigit():
        return is_geographic_epsg(int(crs[5:]))
    rasterio = _require_rasterio(f"the CRS {crs[:40]!r}")
    try:
        return bool(rasterio.crs.CRS.from_user_input(crs).is_geographic)
    except Exception as exc:
        raise InvalidParameterError(f"unknown CRS {crs[:60]!r}: {exc}") from None


def crs_pixel_size(heightmap: Heightmap) -> tuple[float, float]:
    """Pixel size ``(px, py)`` in CRS units (> 0).

    Projected or local maps: ``spacing``. Geographic maps: the degrees the reader found,
    scaled by how much ``spacing`` changed since (a resampled map keeps its extent).
    """
    sp = heightmap.spacing
    md = heightmap.metadata
    if _crs_is_geographic(heightmap.crs) and "crs_pixel_size" in md and "crs_pixel_spacing" in md:
        (px, py), (sx, sz) = md["crs_pixel_size"], md["crs_pixel_spacing"]
        if (sx, sz) == tuple(sp):
            return float(px), float(py)
        return float(px) * sp[0] / sx, float(py) * sp[1] / sz
    if _crs_is_geographic(heightmap.crs):
        # Spacing in metres at the origin's latitude → degrees (inverse of the reader).
        from terrascape.io.tiff import geographic_spacing

        lat = heightmap.origin[1]
        for _ in range(3):  # the centre latitude depends on the pixel size sought
            mx, mz = geographic_spacing(1.0, 1.0, max(-89.0, min(89.0, lat)))
            lat = heightmap.origin[1] - sp[1] / mz * heightmap.rows / 2.0
        return sp[0] / mx, sp[1] / mz
    return float(sp[0]), float(sp[1])


def geotransform(heightmap: Heightmap) -> tuple[float, float, float, float, float, float]:
    """GDAL/rasterio affine ``(a, b, c, d, e, f)``: ``x = a·col + c``, ``y = e·row + f``."""
    px, py = crs_pixel_size(heightmap)
    return (px, 0.0, heightmap.origin[0], 0.0, -py, heightmap.origin[1])


def restore_nodata(heightmap: Heightmap) -> np.ndarray:
    """float32 heights with the source's nodata value back where the reader filled holes."""
    data = np.array(heightmap.heights, dtype=np.float32)
    mask = heightmap.metadata.get("nodata_mask")
    if heightmap.nodata is not None and isinstance(mask, np.ndarray) and mask.shape == data.shape:
        data[mask] = np.float32(heightmap.nodata)
    return data


def read_geotiff(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read band 1 of a GeoTIFF with rasterio, keeping transform, CRS and nodata.

    Without rasterio this is :func:`terrascape.io.tiff.read_tiff`. Nodata (and non-finite)
    samples are filled from their nearest valid neighbours with a warning; their mask is kept
    in ``metadata["nodata_mask"]`` so :func:`write_geotiff` writes the holes back.

    Raises
    ------
    FileFormatError
        Unreadable file, more than one band, rotated/sheared transform, all nodata.
    """
    from terrascape.io.tiff import fill_invalid, geographic_spacing, read_tiff

    if not rasterio_available():
        return read_tiff(path, spacing=spacing, vertical_scale=vertical_scale)
    import rasterio
    from rasterio.errors import RasterioError

    p = check_input_path(path)
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    try:
        with quiet_not_georeferenced(), rasterio.open(p) as ds:
            if ds.count != 1:
                raise FileFormatError(
                    f"expected a single-band 2-D TIFF in {p}, got {ds.count} bands"
                )
            data = ds.read(1)
            nodata = ds.nodata
            transform = ds.transform
            crs = ds.crs
            georeferenced = ds.crs is not None or not transform.is_identity
    except TerrascapeError:
        raise
    except (RasterioError, OSError, ValueError) as exc:
        raise FileFormatError(f"cannot read TIFF {p}: {exc}") from None
    if not (np.issubdtype(data.dtype, np.integer) or np.issubdtype(data.dtype, np.floating)):
        raise FileFormatError(f"expected integer or float TIFF samples in {p}, got {data.dtype}")
    if transform.b != 0 or transform.d != 0:
        raise FileFormatError(
            f"{p.name} has a rotated or sheared transform; warp it north-up first "
            "(gdalwarp) or use --reproject"
        )
    nodata = None if nodata is None or (isinstance(nodata, float) and math.isnan(nodata)) \
        else float(nodata)
    # a south-up raster is flipped to the north-up row order; a TIFF without a geotransform
    # (GDAL's identity, whose row step is +1 too) keeps its rows in file order, first north
    if georeferenced and transform.e > 0:
        data = data[::-1]
        transform = rasterio.Affine(transform.a, 0, transform.c, 0, -transform.e,
                                    transform.f + transform.e * data.shape[0])
    heights, invalid = fill_invalid(data, nodata, p)
    filled = int(np.count_nonzero(invalid))
    if vscale is not None:
        heights = heights * vscale

    px, py = abs(transform.a), abs(transform.e)
    crs_text = None
    if crs is not None:
        epsg = crs.to_epsg(confidence_threshold=100)
        crs_text = f"EPSG:{epsg}" if epsg is not None else crs.to_wkt()
    geographic = bool(crs is not None and crs.is_geographic)
    if geographic:
        centre_lat = transform.f - py * data.shape[0] / 2.0
        file_spacing = geographic_spacing(px, py, max(-90.0, min(90.0, centre_lat)))
    elif georeferenced:
        file_spacing = (px, py)
    else:
        file_spacing = None
    sp = spacing_t or file_spacing or (1.0, 1.0)
    md = file_metadata(p, "tiff", str(data.dtype), step=0.0, filled=filled,
                       geographic=geographic, nodata=nodata)
    if filled:
        md["nodata_mask"] = invalid
    if geographic:
        md["crs_pixel_size"] = (px, py)
        md["crs_pixel_spacing"] = sp
    origin = (float(transform.c), float(transform.f)) if georeferenced else (0.0, 0.0)
    return Heightmap(np.asarray(heights, np.float32), sp, md, origin=origin, crs=crs_text,
                     nodata=nodata)


def write_geotiff(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write a float32 GeoTIFF, atomically, with the map's transform, CRS and nodata.

    Uses rasterio when the map has a CRS and rasterio is installed (any CRS, exact WKT);
    otherwise :func:`terrascape.io.tiff.write_tiff` (tifffile: EPSG codes, origin, nodata).
    """
    from terrascape.io.tiff import write_tiff

    check_heightmap(heightmap)
    if heightmap.crs is None or not rasterio_available():
        return write_tiff(heightmap, path, force=force)
    import rasterio
    from rasterio.crs import CRS

    try:
        crs = CRS.from_user_input(heightmap.crs)
    except Exception as exc:
        raise InvalidParameterError(f"unknown CRS {heightmap.crs[:60]!r}: {exc}") from None
    data = restore_nodata(heightmap)
    profile = {
        "driver": "GTiff",
        "width": heightmap.cols,
        "height": heightmap.rows,
        "count": 1,
        "dtype": "float32",
        "crs": crs,
        "transform": rasterio.Affine(*geotransform(heightmap)),
        "nodata": heightmap.nodata,
    }
    with (atomic_output(path, force=force) as tmp, quiet_not_georeferenced(),
          rasterio.open(tmp, "w", **profile) as ds):
        ds.write(data, 1)
    return Path(path)


def assign_crs(heightmap: Heightmap, crs: str) -> Heightmap:
    """Declare the CRS of a map that has none (or a wrong one), keeping its numbers.

    For a geographic CRS the map's ``spacing`` is taken as the pixel size in DEGREES (what
    a DEM in degrees read without georeference carries) and converted to metres at the
    origin's latitude; ``origin`` is taken as (longitude, latitude) of the corner.
    """
    check_heightmap(heightmap)
    crs = _normalise_crs(crs)
    md = dict(heightmap.metadata)
    sp = heightmap.spacing
    if _crs_is_geographic(crs):
        from terrascape.io.tiff import geographic_spacing

        if heightmap.metadata.get("geographic") and heightmap.crs is not None:
            # already degrees → metres by a reader; keep its conversion
            return Heightmap(heightmap.heights, sp, md, heightmap.origin, crs, heightmap.nodata)
        lat = heightmap.origin[1] - sp[1] * heightmap.rows / 2.0
        md["crs_pixel_size"] = sp
        sp = geographic_spacing(sp[0], sp[1], max(-90.0, min(90.0, lat)))
        md["crs_pixel_spacing"] = sp
        md["geographic"] = True
    return Heightmap(heightmap.heights, sp, md, heightmap.origin, crs, heightmap.nodata)


def _normalise_crs(crs: str) -> str:
    if not isinstance(crs, str) or not crs.strip():
        raise InvalidParameterError(f"CRS must be like EPSG:32633 or WKT, got {crs!r}")
    text = crs.strip()
    if text.upper().startswith("EPSG:"):
        if not text[5:].isdigit():
            raise InvalidParameterError(f"bad EPSG code {text!r}; expected e.g. EPSG:32633")
        return "EPSG:" + text[5:]
    if rasterio_available():
        from rasterio.crs import CRS

        try:
            parsed = CRS.from_user_input(text)
        except Exception as exc:
            raise InvalidParameterError(f"unknown CRS {text[:60]!r}: {exc}") from None
        epsg = parsed.to_epsg(confidence_threshold=100)
        return f"EPSG:{epsg}" if epsg is not None else parsed.to_wkt()
    return text


def reproject(
    heightmap: Heightmap,
    dst_crs: str,
    *,
    resolution: float | None = None,
    resampling: str = "bilinear",
) -> Heightmap:
    """Warp a georeferenced map to ``dst_crs`` (rasterio.warp), e.g. degrees → UTM metres.

    Parameters
    ----------
    dst_crs
        Target CRS, ``"EPSG:…"`` or WKT; for rendering and meshing it should be metric.
    resolution
        Target pixel size in target units; default: GDAL's suggestion (about the source's).
    resampling
        ``nearest``, ``bilinear`` or ``cubic``.

    Returns
    -------
    Heightmap
        North-up map in ``dst_crs``; samples outside the source are filled from their
        nearest neighbours (and remembered as nodata holes).
    """
    check_heightmap(heightmap)
    if heightmap.crs is None:
        raise InvalidParameterError(
            "reprojecting needs the map's own CRS; the file has none (give it with --crs)"
        )
    _require_rasterio("reprojecting")
    from rasterio import Affine
    from rasterio.crs import CRS
    from rasterio.enums import Resampling
    from rasterio.warp import calculate_default_transform
    from rasterio.warp import reproject as warp

    methods = {"nearest": Resampling.nearest, "bilinear": Resampling.bilinear,
               "cubic": Resampling.cubic}
    if resampling not in methods:
        raise InvalidParameterError(
            f"resampling must be one of {', '.join(methods)}, got {resampling!r}"
        )
    dst = _normalise_crs(dst_crs)
    src_crs = CRS.from_user_input(heightmap.crs)
    dst_crs_obj = CRS.from_user_input(dst)
    src_transform = Affine(*geotransform(heightmap))
    left, top = heightmap.origin
    right = left + src_transform.a * heightmap.cols
    bottom = top + src_transform.e * heightmap.rows
    kwargs = {} if resolution is None else {"resolution": resolution}
    transform, width, height = calculate_default_transform(
        src_crs, dst_crs_obj, heightmap.cols, heightmap.rows, left, bottom, right, top, **kwargs
    )
    nodata = -3.0e38
    out = np.full((height, width), nodata, np.float32)
    warp(
        source=np.asarray(heightmap.heights, np.float32),
        destination=out,
        src_transform=src_transform,
        src_crs=src_crs,
        dst_transform=transform,
        dst_crs=dst_crs_obj,
        src_nodata=None,
        dst_nodata=nodata,
        resampling=methods[resampling],
    )
    from terrascape.io.fill import fill_nodata

    holes = out == np.float32(nodata)
    if holes.all():
        raise InvalidParameterError(f"the map does not overlap {dst} (nothing left after warping)")
    heights = out.astype(np.float64)
    md = {k: v for k, v in heightmap.metadata.items()
          if k not in ("crs_pixel_size", "crs_pixel_spacing", "nodata_mask")}
    if holes.any():
        heights[holes] = np.nan
        heights, _ = fill_nodata(heights)
        md["nodata_mask"] = holes
    md["reprojected_from"] = heightmap.crs
    px, py = abs(transform.a), abs(transform.e)
    geographic = bool(dst_crs_obj.is_geographic)
    md["geographic"] = geographic
    if geographic:
        from terrascape.io.tiff import geographic_spacing

        sp = geographic_spacing(px, py, transform.f - py * height / 2.0)
        md["crs_pixel_size"] = (px, py)
        md["crs_pixel_spacing"] = sp
    else:
        sp = (px, py)
    nd = heightmap.nodata if heightmap.nodata is not None else (nodata if holes.any() else None)
    return Heightmap(heights.astype(np.float32), sp, md, (float(transform.c), float(transform.f)),
                     dst, nd)


def degree_warning(heightmap: Heightmap) -> str | None:
    """A warning text when the spacing looks like degrees but no geographic CRS says so.

    The test: spacing below 0.01 (about a metre in degrees) while the height range is more
    than 100× the horizontal extent — a DEM in degrees read as if they were metres.
    """
    if _crs_is_geographic(heightmap.crs):
        return None
    dx, dz = heightmap.spacing
    extent = max(heightmap.extent)
    relief = heightmap.max - heightmap.min
    if max(dx, dz) < 0.01 and relief > 100.0 * extent:
        return (
            f"the sample spacing ({dx:.3g}, {dz:.3g}) looks like degrees, not metres (height "
            f"range {relief:.4g} over {extent:.3g} units): pass --spacing in metres, or "
            "--crs EPSG:4326 (then --reproject EPSG:… to a metric CRS)"
        )
    return None
