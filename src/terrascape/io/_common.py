"""Helpers shared by the heightmap file readers/writers (private)."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from terrascape._validate import check_int, check_positive
from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap

#: Name of the PNG text chunk and the ``format`` field of RAW sidecars written by terrascape.
META_KEY = "terrascape"
META_VERSION = 1


def check_input_path(path: str | os.PathLike) -> Path:
    """Return ``Path(path)`` if it is an existing regular file, else :class:`FileFormatError`."""
    try:
        p = Path(path)
    except TypeError:
        raise InvalidParameterError(f"expected a file path, got {path!r}") from None
    if not p.exists():
        raise FileFormatError(f"file not found: {p}")
    if not p.is_file():
        raise FileFormatError(f"expected a regular file, got {p} (a directory or device)")
    return p


def check_heightmap(heightmap: object) -> None:
    """Writers take a :class:`~terrascape.heightmap.Heightmap`; anything else is a clear error."""
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(
            f"expected a terrascape.Heightmap, got {type(heightmap).__name__}"
        )


def normalise_spacing(spacing: Any) -> tuple[float, float] | None:
    """``None``, a number, or ``(dx, dz)`` → ``None`` or a validated ``(dx, dz)``."""
    if spacing is None:
        return None
    if np.isscalar(spacing):
        v = check_positive(spacing, "spacing")
        return (v, v)
    try:
        dx, dz = spacing
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"spacing must be a number or (dx, dz), got {spacing!r}"
        ) from None
    return (check_positive(dx, "spacing dx"), check_positive(dz, "spacing dz"))


def normalise_size(size: Any) -> tuple[int, int] | None:
    """``None``, an int (square side), or ``(cols, rows)`` → ``None`` or ``(cols, rows)``."""
    if size is None:
        return None
    if isinstance(size, (int, np.integer)) and not isinstance(size, bool):
        side = check_int(size, "size", minimum=2)
        return (side, side)
    try:
        cols, rows = size
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"size must be an int (square side) or (cols, rows), got {size!r}"
        ) from None
    return (check_int(cols, "size cols", minimum=2), check_int(rows, "size rows", minimum=2))


def check_vertical_scale(vertical_scale: float | None) -> float | None:
    """``None`` or a finite positive float."""
    if vertical_scale is None:
        return None
    return check_positive(vertical_scale, "vertical_scale")


def quantise(heights: np.ndarray, levels: int) -> tuple[np.ndarray, float, float]:
    """Map ``[min, max]`` linearly onto the integers ``0..levels``.

    Returns ``(codes, offset, scale)`` with ``heights ≈ offset + codes * scale``; the error is
    at most ``scale / 2`` (half a quantisation step). A flat map gives ``scale = 0``.
    Computed in float64 so the float32 input is not degraded before rounding.
    """
    h = np.asarray(heights)
    lo = float(h.min())
    span = float(h.max()) - lo
    dtype = np.uint8 if levels <= 255 else np.uint16
    codes = np.zeros(h.shape, dtype=dtype)
    if span == 0.0:
        return codes, lo, 0.0
    factor = levels / span
    # A block of rows at a time: the same float64 arithmetic, but the float64 temporaries
    # exist for one block, not for the whole map (16 bytes per sample on every write).
    flat = h.reshape(h.shape[0], -1) if h.ndim >= 2 else h.reshape(1, -1)
    out = codes.reshape(flat.shape)
    step = max(1, _QUANTISE_BLOCK // max(1, flat.shape[1]))
    for r in range(0, flat.shape[0], step):
        block = np.rint((flat[r:r + step].astype(np.float64) - lo) * factor)
        np.clip(block, 0, levels, out=block)
        out[r:r + step] = block
    return codes, lo, span / levels


#: Samples per block in :func:`quantise`.
_QUANTISE_BLOCK = 1 << 20


def dequantise(codes: np.ndarray, offset: float, scale: float) -> np.ndarray:
    """Inverse of :func:`quantise` (float64 arithmetic, float32 result)."""
    return (offset + codes.astype(np.float64) * scale).astype(np.float32)


def meta_json(**fields: Any) -> str:
    """The terrascape metadata record as compact JSON (floats keep all float64 digits)."""
    record = {"format": META_KEY, "version": META_VERSION, **fields}
    return json.dumps(record, separators=(",", ":"), allow_nan=False)


def parse_meta(text: str, *, where: str) -> dict[str, Any]:
    """Parse and validate a terrascape metadata record (PNG text chunk or RAW sidecar)."""
    try:
        record = json.loads(text)
    except (json.JSONDecodeError, TypeError) as exc:
        raise FileFormatError(f"corrupt terrascape metadata in {where}: {exc}") from None
    if not isinstance(record, dict) or record.get("format") != META_KEY:
        raise FileFormatError(
            f"expected a terrascape metadata record in {where}, got {str(text)[:80]!r}"
        )
    if record.get("version") != META_VERSION:
        raise FileFormatError(
            f"unsupported terrascape metadata version in {where}: expected {META_VERSION}, "
            f"got {record.get('version')!r}"
        )
    for key in ("offset", "scale"):
        if key in record:
            value = record[key]
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise FileFormatError(f"bad {key!r} in terrascape metadata of {where}: {value!r}")
    if "spacing" in record:
        sp = record["spacing"]
        ok = (
            isinstance(sp, list)
            and len(sp) == 2
            and all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in sp)
        )
        if not ok:
            raise FileFormatError(f"bad 'spacing' in terrascape metadata of {where}: {sp!r}")
        record["spacing"] = (float(sp[0]), float(sp[1]))
    return record


def file_metadata(
    path: Path, fmt: str, dtype: str, *, step: float = 0.0, filled: int = 0, **extra: Any
) -> dict[str, Any]:
    """The ``Heightmap.metadata`` every reader attaches (used by ``terrascape info``).

    ``step`` is the quantisation step in world units (0 for exact float formats); ``filled``
    the number of nodata samples that were filled from neighbours.
    """
    return {
        "source": str(path),
        "format": fmt,
        "dtype": dtype,
        "step": float(step),
        "filled": int(filled),
        **extra,
    }
