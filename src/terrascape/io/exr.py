"""OpenEXR heightmaps (the OpenEXR Python bindings): one channel, half or float, real heights.

Game engines (Godot's HTerrain/Terrain3D, Unreal, Houdini) read EXR heightmaps as the heights
themselves, in world units, so no normalisation happens here. A file written by terrascape has
one ``Y`` channel and a ``terrascape`` string attribute with the spacing (and origin/CRS), so it
round-trips; any other scanline or tiled EXR with one channel — or with a ``Y``, ``R`` or ``Z``
channel among several — reads too.

Half floats have an 11-bit mantissa: a height ``h`` is stored within half a unit in the last
place, ``2**(floor(log2|h|) − 11)`` (0.25 m at 1000 m); :func:`write_exr` refuses heights beyond
half's largest finite value, 65504.
"""

from __future__ import annotations

import errno
import json
import math
import os
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    file_metadata,
    normalise_spacing,
)
from terrascape.io.atomic import atomic_output

__all__ = ["HALF_MAX", "half_step", "read_exr", "write_exr"]

#: Largest finite IEEE half float.
HALF_MAX = 65504.0
_META_ATTRIBUTE = "terrascape"
_PREFERRED_CHANNELS = ("Y", "R", "Z", "height")


def _openexr():
    try:
        import OpenEXR
    except ImportError:
        raise InvalidParameterError(
            "EXR files need the OpenEXR bindings: pip install 'terrascape[exr]'"
        ) from None
    return OpenEXR


def half_step(max_abs_height: float) -> float:
    """Largest rounding error (half a unit in the last place) of a half float near
    ``max_abs_height``."""
    if max_abs_height <= 0:
        return 0.0
    exponent = max(math.floor(math.log2(max_abs_height)), -14)
    return 2.0 ** (exponent - 10) / 2.0


def write_exr(
    heightmap: Heightmap,
    path: str | os.PathLike,
    *,
    force: bool = False,
    half: bool = False,
) -> Path:
    """Write one ``Y`` channel of float32 (default) or half heights, ZIP-compressed, atomically.

    Raises
    ------
    InvalidParameterError
        ``half=True`` with heights beyond ±65504.
    """
    check_heightmap(heightmap)
    openexr = _openexr()
    if half and max(abs(heightmap.min), abs(heightmap.max)) > HALF_MAX:
        raise InvalidParameterError(
            f"heights {heightmap.min:.6g} … {heightmap.max:.6g} do not fit a half-float EXR "
            f"(±{HALF_MAX:g}); write float EXR instead"
        )
    pixels = np.ascontiguousarray(heightmap.heights, np.float16 if half else np.float32)
    record = {"spacing": list(heightmap.spacing), "origin": list(heightmap.origin)}
    if heightmap.crs is not None:
        record["crs"] = heightmap.crs
    header = {
        "compression": openexr.ZIP_COMPRESSION,
        "type": openexr.scanlineimage,
        _META_ATTRIBUTE: json.dumps(record, separators=(",", ":")),
    }
    with atomic_output(path, force=force) as tmp, openexr.File(header, {"Y": pixels}) as exr:
        try:
            exr.write(str(tmp))
        except RuntimeError as exc:
            raise _write_failure(exc, tmp) from None
    return Path(path)


#: What a failed write can tell: OpenEXR raises RuntimeError with the system's reason in
#: its text ("Failed to write pixel data to image file "…". File too large."), no errno.
_WRITE_ERRNOS = (errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES,
                 errno.EPERM, errno.EIO)


def _write_failure(exc: RuntimeError, tmp: Path) -> OSError:
    """The OSError behind OpenEXR's failed write, found by its reason's text (the atomic
    writer turns it into one line naming the output), or EIO with OpenEXR's text."""
    text = str(exc)
    for number in _WRITE_ERRNOS:
        if os.strerror(number) in text:
            return OSError(number, os.strerror(number), str(tmp))
    return OSError(errno.EIO, f"OpenEXR could not write it ({text})", str(tmp))


def write_exr_half(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """:func:`write_exr` with ``half=True`` (the ``exr16`` format name)."""
    return write_exr(heightmap, path, force=force, half=True)


def _pick_channel(channels: dict, p: Path) -> tuple[str, np.ndarray]:
    names = list(channels)
    if len(names) == 1:
        name = names[0]
    else:
        name = next((c for c in _PREFERRED_CHANNELS if c in channels), None)
        if name is None:
            raise FileFormatError(
                f"{p.name} has channels {', '.join(names)}; expected one channel or one "
                f"named {', '.join(_PREFERRED_CHANNELS)}"
            )
    data = np.asarray(channels[name].pixels)
    if data.ndim != 2:
        raise FileFormatError(f"channel {name!r} of {p.name} is not 2-D: shape {data.shape}")
    return name, data


def read_exr(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a one-channel (or ``Y``/``R``/``Z``) EXR as world heights (float32).

    Raises
    ------
    FileFormatError
        Unreadable file, no usable channel, non-finite samples.
    """
    p = check_input_path(path)
    openexr = _openexr()
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    try:
        with openexr.File(str(p), separate_channels=True) as exr:
            header = dict(exr.header())
            name, data = _pick_channel(exr.channels(), p)
            data = np.array(data)
    except FileFormatError:
        raise
    except Exception as exc:  # the bindings raise plain Exception/RuntimeError on bad files
        raise FileFormatError(f"cannot read EXR {p}: {exc}") from None
    if not np.issubdtype(data.dtype, np.floating) and not np.issubdtype(data.dtype, np.integer):
        raise FileFormatError(f"unsupported EXR sample type {data.dtype} in {p.name}")
    if not np.isfinite(data.astype(np.float64)).all():
        raise FileFormatError(f"{p.name}: channel {name!r} has NaN or infinite heights")
    record: dict = {}
    if _META_ATTRIBUTE in header:
        try:
            record = json.loads(header[_META_ATTRIBUTE])
        except (TypeError, json.JSONDecodeError):
            record = {}
    heights = data.astype(np.float64)
    if vscale is not None:
        heights = heights * vscale
    file_spacing = None
    if isinstance(record.get("spacing"), list) and len(record["spacing"]) == 2:
        file_spacing = (float(record["spacing"][0]), float(record["spacing"][1]))
    sp = spacing_t or file_spacing or (1.0, 1.0)
    step = half_step(float(np.abs(heights).max())) if data.dtype == np.float16 else 0.0
    md = file_metadata(p, "exr", str(data.dtype), step=step, channel=name)
    origin = tuple(record.get("origin", (0.0, 0.0)))
    return Heightmap(heights.astype(np.float32), sp, md, origin=origin,
                     crs=record.get("crs"))
