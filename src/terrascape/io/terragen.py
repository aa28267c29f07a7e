"""Terragen terrain files (``.ter``), one of the formats the thesis names among heightmap formats.

Layout (Planetside "Terragen Terrain file specification"), all little-endian:

* 16-byte identifier ``"TERRAGENTERRAIN "``, then chunks, each a 4-byte marker followed by
  data and aligned to 4 bytes (chunks carry no length field, so unknown markers cannot be
  skipped):

  - ``SIZE`` int16 ``size`` = points on the shorter side − 1, 2 bytes padding (required);
  - ``XPTS`` / ``YPTS`` uint16 point counts, 2 bytes padding (required if not square);
  - ``SCAL`` 3 × float32: metres per terrain unit along x, y (horizontal) and z (vertical),
    default 30;
  - ``CRAD`` float32 planet radius in km (default 6370); ``CRVM`` uint32 curve mode;
  - ``ALTW`` int16 ``HeightScale``, int16 ``BaseHeight``, then ``xpts·ypts`` int16
    elevations, row by row with x varying fastest;
  - ``EOF `` end marker.

* Height in terrain units = ``BaseHeight + Elevation · HeightScale / 65536``; in metres
  multiplied by SCAL's vertical (z) scale. The sample spacing is SCAL's (x, y).

Terragen's y axis points north with the first stored row at the south edge, whereas
terrascape's row 0 is north (Z grows south, like image rows), so rows are flipped on read and
write — the same orientation GDAL's Terragen driver produces.

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.1.
"""

from __future__ import annotations

import math
import os
import struct
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError, HeightmapSizeError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    file_metadata,
    normalise_spacing,
)
from terrascape.io.atomic import atomic_output

MAGIC = b"TERRAGENTERRAIN "
DEFAULT_SCALE = 30.0
DEFAULT_RADIUS_KM = 6370.0
_INT16_MAX = 32767


def _need(data: bytes, pos: int, n: int, what: str, path: Path) -> None:
    if pos + n > len(data):
        raise FileFormatError(
            f"{path} is truncated: {what} at byte {pos} needs {n} bytes, "
            f"only {max(0, len(data) - pos)} left"
        )


def read_terragen(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a Terragen ``.ter`` file; heights in metres (terrain units × SCAL z).

    Parameters
    ----------
    spacing
        Override ``(dx, dz)``; default SCAL's ``(x, y)`` (30 m when SCAL is absent).
    vertical_scale
        Multiplier on the heights.

    Raises
    ------
    FileFormatError
        Bad identifier (e.g. a Leveller ``.ter``), unknown chunk, missing SIZE/ALTW, sizes
        inconsistent, truncated data.
    """
    p = check_input_path(path)
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise FileFormatError(f"cannot read {p}: {exc}") from None
    if data[:16] != MAGIC:
        hint = " (a Leveller .ter is not supported)" if data[:8] == b"trrn0004" else ""
        raise FileFormatError(
            f"{p} is not a Terragen terrain: expected identifier {MAGIC.decode()!r}, "
            f"got {data[:16]!r}{hint}"
        )
    size = xpts = ypts = None
    scal = (DEFAULT_SCALE, DEFAULT_SCALE, DEFAULT_SCALE)
    crad, crvm = DEFAULT_RADIUS_KM, 0
    altw = None
    pos = 16
    while pos + 4 <= len(data):
        marker = data[pos : pos + 4]
        pos += 4
        if marker == b"EOF ":
            break
        if marker == b"SIZE":
            _need(data, pos, 4, "SIZE", p)
            size = struct.unpack_from("<h", data, pos)[0]
            pos += 4
        elif marker in (b"XPTS", b"YPTS"):
            _need(data, pos, 4, marker.decode(), p)
            value = struct.unpack_from("<H", data, pos)[0]
            pos += 4
            if marker == b"XPTS":
                xpts = value
            else:
                ypts = value
        elif marker == b"SCAL":
            _need(data, pos, 12, "SCAL", p)
            scal = struct.unpack_from("<3f", data, pos)
            pos += 12
        elif marker == b"CRAD":
            _need(data, pos, 4, "CRAD", p)
            crad = struct.unpack_from("<f", data, pos)[0]
            pos += 4
        elif marker == b"CRVM":
            _need(data, pos, 4, "CRVM", p)
            crvm = struct.unpack_from("<I", data, pos)[0]
            pos += 4
        elif marker == b"ALTW":
            if size is None:
                raise FileFormatError(f"{p}: ALTW chunk before the required SIZE chunk")
            nx = xpts if xpts is not None else size + 1
            ny = ypts if ypts is not None else size + 1
            if nx < 2 or ny < 2:
                raise FileFormatError(f"{p}: expected at least 2×2 points, got {nx}×{ny}")
            n = nx * ny
            _need(data, pos, 4 + 2 * n, f"ALTW with {nx}×{ny} elevations", p)
            height_scale, base_height = struct.unpack_from("<hh", data, pos)
            elev = np.frombuffer(data, dtype="<i2", count=n, offset=pos + 4).reshape(ny, nx)
            altw = (height_scale, base_height, elev)
            pos += 4 + 2 * n
            # Chunks are 4-byte aligned, so an odd point count is followed by 2 padding
            # bytes; some writers omit them before "EOF ", which is accepted too.
            if pos % 4 and data[pos : pos + 4] != b"EOF ":
                pos += (-pos) % 4
        else:
            raise FileFormatError(
                f"{p}: unknown Terragen chunk {marker!r} at byte {pos - 4}; expected SIZE, "
                "XPTS, YPTS, SCAL, CRAD, CRVM, ALTW or EOF"
            )
    if size is None:
        raise FileFormatError(f"{p}: missing required SIZE chunk")
    if altw is None:
        raise FileFormatError(f"{p}: no ALTW elevation chunk (file truncated?)")
    if not all(math.isfinite(s) and s > 0 for s in scal):
        raise FileFormatError(f"{p}: SCAL must be three positive numbers, got {scal}")
    height_scale, base_height, elev = altw
    terrain_units = base_height + elev.astype(np.float64) * (height_scale / 65536.0)
    heights = terrain_units * float(scal[2])
    if vscale is not None:
        heights = heights * vscale
    step = abs(height_scale) / 65536.0 * float(scal[2]) * (vscale or 1.0)
    md = file_metadata(
        p,
        "ter",
        "int16",
        step=step,
        height_scale=int(height_scale),
        base_height=int(base_height),
        terragen_scale=tuple(float(s) for s in scal),
        planet_radius_km=float(crad),
        curve_mode=int(crvm),
    )
    sp = spacing_t or (float(scal[0]), float(scal[1]))
    return Heightmap(np.ascontiguousarray(heights[::-1], dtype=np.float32), sp, md)


def _fit_int16(t_lo: float, t_hi: float) -> tuple[int, int] | None:
    """Smallest ``HeightScale`` (with ``BaseHeight`` = rounded mid) that keeps every
    elevation ``(t − BaseHeight) · 65536 / HeightScale`` inside int16; ``None`` if impossible.
    """
    base = round(0.5 * (t_lo + t_hi))
    if abs(base) > _INT16_MAX:
        return None
    hs = max(1, math.ceil(t_hi - t_lo))
    # BaseHeight is an integer, so the range may sit up to half a unit off-centre: a few
    # increments at most.
    while hs <= _INT16_MAX:
        if (t_hi - base) * 65536.0 / hs <= _INT16_MAX and (base - t_lo) * 65536.0 / hs <= 32768:
            return hs, base
        hs += 1
    return None


def terragen_encoding(heights: np.ndarray, dx: float) -> tuple[float, int, int, np.ndarray]:
    """Choose ``(vertical_scale_m, HeightScale, BaseHeight, elevations)`` for ``heights``.

    Terragen (and GDAL's Terragen driver, which reads SCAL's y value as the one scale for
    ground *and* elevation) assume uniform voxels, so the vertical scale is the horizontal
    ``dx`` whenever that keeps the quantisation step ``HeightScale · scale / 65536`` within
    25 % of the ideal ``range / 65535`` (height range ≥ ~8 sample spacings, e.g. a 30 m DEM
    with ≥ 240 m of relief) and the mid-height fits BaseHeight's int16. Flatter maps (e.g.
    heights in [0, 1] on a 1 m grid) would lose most of the 16 bits that way, so a finer
    vertical unit ``max(range / 64, |mid| / 32000)`` is written instead: terrascape reads
    such files exactly, but Terragen/GDAL will show their heights scaled by ``dx / unit``.
    ``HeightScale`` is the smallest that fits (see ``_fit_int16``).
    """
    h = np.asarray(heights, dtype=np.float64)
    lo, hi = float(h.min()), float(h.max())
    span, mid = hi - lo, 0.5 * (lo + hi)
    # SCAL is stored as float32; encode with the stored value so decoding matches exactly.
    vz = float(np.float32(dx))
    fit = _fit_int16(lo / vz, hi / vz)
    ideal = span / 65535.0
    if fit is None or (span > 0 and fit[0] * vz / 65536.0 > 1.25 * ideal):
        vz = max(span / 64.0, abs(mid) / 32000.0) or float(dx)
        vz = float(np.float32(vz))
        fit = _fit_int16(lo / vz, hi / vz)
        if fit is None:  # unreachable for finite float32 heights; kept as a clear error
            raise InvalidParameterError(
                f"heights {lo:g}…{hi:g} cannot be encoded as Terragen int16 elevations"
            )
    height_scale, base = fit
    elev = np.rint((h / vz - base) * (65536.0 / height_scale))
    np.clip(elev, -32768, _INT16_MAX, out=elev)
    return vz, height_scale, base, elev.astype("<i2")


def write_terragen(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write a Terragen ``.ter`` (SIZE, XPTS, YPTS, SCAL, CRAD, CRVM, ALTW, EOF).

    SCAL = ``(dx, dz, vertical)`` with the vertical unit from :func:`terragen_encoding`;
    heights come back within half a step ``HeightScale · vertical / 65536``. Terragen itself
    only supports equal x/y/z scales (and GDAL uses the y value for all three), so maps with
    ``dx != dz`` or very low relief read back exactly only in terrascape.

    Raises
    ------
    HeightmapSizeError
        More than 32767 points on a side (SIZE/XPTS are 16-bit).
    """
    check_heightmap(heightmap)
    rows, cols = heightmap.shape
    if max(rows, cols) > _INT16_MAX:
        raise HeightmapSizeError(
            f"Terragen stores at most {_INT16_MAX} points per side, got {cols}×{rows}"
        )
    dx, dz = heightmap.spacing
    vz, height_scale, base, elev = terragen_encoding(heightmap.heights, dx)
    parts = [
        MAGIC,
        b"SIZE",
        struct.pack("<hxx", min(rows, cols) - 1),
        b"XPTS",
        struct.pack("<Hxx", cols),
        b"YPTS",
        struct.pack("<Hxx", rows),
        b"SCAL",
        struct.pack("<3f", dx, dz, vz),
        b"CRAD",
        struct.pack("<f", DEFAULT_RADIUS_KM),
        b"CRVM",
        struct.pack("<I", 0),
        b"ALTW",
        struct.pack("<hh", height_scale, base),
        elev[::-1].tobytes(order="C"),  # first stored row is the south edge
    ]
    if (rows * cols) % 2:
        parts.append(b"\x00\x00")  # keep the EOF marker 4-byte aligned
    parts.append(b"EOF ")
    with atomic_output(path, force=force) as tmp:
        tmp.write_bytes(b"".join(parts))
    return Path(path)
