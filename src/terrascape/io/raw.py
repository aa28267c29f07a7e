"""Headerless RAW heightmaps: 16-bit unsigned (``.r16``/``.raw``) and float32 (``.r32``).

Both are little-endian, row-major ``[row(z), col(x)]`` with no header (the layout used by
World Machine, Unity and Unreal). Without a header the grid size comes from ``size`` or, for
a square grid, from the file length. A plain 16-bit file reads as ``value / 65535 *
vertical_scale`` (default 1.0); a float32 file holds world heights.

terrascape also writes a small JSON **sidecar** ``<file>.json`` (e.g. ``dem.r16.json``)
holding cols/rows, the height ``offset``/``scale`` of the 16-bit quantisation and the
spacing; when present next to a RAW file it is used to restore size, world units and
spacing, plus the SHA-256 of the RAW bytes it describes. The two files are committed as one
unit (:func:`terrascape.io.atomic.atomic_outputs`); a reader that finds a sidecar whose hash
does not match the RAW bytes (a pair mixed by another program, a RAW file edited after the
fact) refuses it with a clear error instead of reading wrong heights. Other tools simply
ignore the sidecar.
"""

from __future__ import annotations

import hashlib
import math
import os
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    dequantise,
    file_metadata,
    meta_json,
    normalise_size,
    normalise_spacing,
    parse_meta,
    quantise,
)
from terrascape.io.atomic import atomic_outputs, check_output_path, commit_lock
from terrascape.io.fill import fill_non_finite

_DTYPES = {"r16": np.dtype("<u2"), "r32": np.dtype("<f4")}


def sidecar_path(path: str | os.PathLike) -> Path:
    """The JSON sidecar of a RAW file: ``dem.r16`` → ``dem.r16.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def _read_sidecar(path: Path, kind: str) -> dict | None:
    side = sidecar_path(path)
    if not side.is_file():
        return None
    try:
        text = side.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"cannot read sidecar {side}: {exc}") from None
    meta = parse_meta(text, where=str(side))
    if meta.get("dtype") != _DTYPES[kind].str:
        raise FileFormatError(
            f"sidecar {side} describes dtype {meta.get('dtype')!r}, expected "
            f"{_DTYPES[kind].str!r} for a {path.suffix} file"
        )
    digest = meta.get("sha256")
    hexdigits = "0123456789abcdef"
    if digest is not None and not (
        isinstance(digest, str) and len(digest) == 64 and all(c in hexdigits for c in digest)
    ):
        raise FileFormatError(f"bad 'sha256' in sidecar {side}: {str(digest)[:80]!r}")
    for key in ("cols", "rows"):
        if key in meta and (isinstance(meta[key], bool) or not isinstance(meta[key], int)
                            or meta[key] < 2):
            raise FileFormatError(f"bad {key!r} in sidecar {side}: {meta[key]!r}")
    return meta


def _grid_shape(
    path: Path, nbytes: int, itemsize: int, size: tuple[int, int] | None, meta: dict | None
) -> tuple[int, int]:
    """``(rows, cols)`` from explicit size, sidecar, or a square file length."""
    bits = itemsize * 8
    if nbytes == 0:
        raise FileFormatError(f"{path} is empty")
    if nbytes % itemsize:
        raise FileFormatError(
            f"{path} has {nbytes} bytes, not a multiple of {itemsize} ({bits}-bit samples); "
            "the file is truncated or not a RAW heightmap"
        )
    n = nbytes // itemsize
    source = "size"
    if size is None and meta is not None and "cols" in meta and "rows" in meta:
        size = (int(meta["cols"]), int(meta["rows"]))
        source = f"sidecar {sidecar_path(path).name}"
    if size is not None:
        cols, rows = size
        if cols * rows != n:
            raise FileFormatError(
                f"{source} {cols}×{rows} (cols×rows) needs {cols * rows * itemsize} bytes of "
                f"{bits}-bit samples, but {path} has {nbytes} bytes ({n} samples)"
            )
        return rows, cols
    side = math.isqrt(n)
    if side * side != n:
        raise FileFormatError(
            f"cannot infer the size of {path}: {n} {bits}-bit samples is not a square grid; "
            "pass size=(cols, rows) (CLI: --size COLSxROWS)"
        )
    return side, side


def _read_raw(
    path: str | os.PathLike,
    kind: str,
    size: int | tuple[int, int] | None,
    spacing: float | tuple[float, float] | None,
    vertical_scale: float | None,
) -> Heightmap:
    p = check_input_path(path)
    size_t = normalise_size(size)
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    dtype = _DTYPES[kind]
    # A shared lock of the folder: a terrascape writer commits RAW + sidecar under the
    # exclusive lock, so the two are never read half-way through a commit.
    with commit_lock([p.parent], shared=True):
        meta = _read_sidecar(p, kind)
        try:
            data = p.read_bytes()
        except OSError as exc:
            raise FileFormatError(f"cannot read {p}: {exc.strerror or exc}") from None
    if meta is not None and "sha256" in meta:
        digest = hashlib.sha256(data).hexdigest()
        if digest != meta["sha256"]:
            raise FileFormatError(
                f"{p} does not match its sidecar {sidecar_path(p).name} (the sidecar was "
                "written for other data: SHA-256 differs); the pair was mixed or the RAW file "
                "changed. Write both again, or delete the sidecar to read the RAW file alone"
            )
    rows, cols = _grid_shape(p, len(data), dtype.itemsize, size_t, meta)
    values = np.frombuffer(data, dtype=dtype).reshape(rows, cols)

    units = meta is not None and "offset" in meta and "scale" in meta
    filled = 0
    if kind == "r16":
        if units:
            scale = float(meta["scale"])
            heights = dequantise(values, float(meta["offset"]), scale)
            step = scale
            if vscale is not None:
                heights = heights * np.float32(vscale)
                step *= vscale
        else:
            v = 1.0 if vscale is None else vscale
            heights = (values.astype(np.float64) * (v / 65535.0)).astype(np.float32)
            step = v / 65535.0
    else:
        # NaN/inf are nodata, filled with a warning, as in GeoTIFF and .npy files.
        heights, filled = fill_non_finite(values, p.name)
        heights = heights.astype(np.float32)
        if vscale is not None:
            heights = heights * np.float32(vscale)
        step = 0.0
    file_spacing = meta.get("spacing") if meta else None
    sp = spacing_t or file_spacing or (1.0, 1.0)
    md = file_metadata(
        p,
        kind,
        f"{dtype.name} little-endian",
        step=step,
        filled=filled,
        units_restored=units,
        sidecar=str(sidecar_path(p)) if meta else None,
    )
    return Heightmap(heights, sp, md)


def read_raw16(
    path: str | os.PathLike,
    *,
    size: int | tuple[int, int] | None = None,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a little-endian unsigned 16-bit RAW heightmap (``.r16``/``.raw``).

    Parameters
    ----------
    size
        Side of a square grid or ``(cols, rows)``. Default: from the sidecar, else the
        square root of the sample count (a non-square count is an error).
    spacing
        Override ``(dx, dz)``; default from the sidecar, else ``(1, 1)``.
    vertical_scale
        Without sidecar: world height of code 65535 (default 1.0). With sidecar: multiplier.

    Raises
    ------
    FileFormatError
        Missing/empty file, odd byte count, length not matching ``size``, non-square length
        without ``size``, corrupt sidecar.
    """
    return _read_raw(path, "r16", size, spacing, vertical_scale)


def read_raw32(
    path: str | os.PathLike,
    *,
    size: int | tuple[int, int] | None = None,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a little-endian float32 RAW heightmap (``.r32``); heights are world units.

    ``vertical_scale`` multiplies the heights. NaN/infinite samples are nodata: filled from
    the nearest valid sample with a warning, as in GeoTIFF and ``.npy``. Size/spacing rules
    as :func:`read_raw16`.
    """
    return _read_raw(path, "r32", size, spacing, vertical_scale)


def _write_raw(
    heightmap: Heightmap, path: str | os.PathLike, kind: str, force: bool, sidecar: bool
) -> Path:
    check_heightmap(heightmap)
    dtype = _DTYPES[kind]
    # Check both targets before writing anything, so a refused sidecar leaves no RAW behind.
    check_output_path(path, force=force)
    side = sidecar_path(path)
    # A sidecar from an earlier write would be trusted by the reader, so it is checked (and,
    # with sidecar=False, removed) even when no new one is written.
    if sidecar or side.exists():
        check_output_path(side, force=force)
    if kind == "r16":
        codes, offset, scale = quantise(heightmap.heights, 65535)  # a block at a time
        data = codes.astype(dtype, copy=False)  # no copy on little-endian machines
    else:
        data = np.ascontiguousarray(heightmap.heights, dtype=dtype)  # no copy when float32
        offset, scale = 0.0, 1.0
    if not sidecar:
        with atomic_outputs([path], force=force) as (tmp,):
            tmp.write_bytes(data)
        if side.exists():
            with commit_lock([side.parent]):
                side.unlink(missing_ok=True)
        return Path(path)
    record = meta_json(
        dtype=dtype.str,
        cols=heightmap.cols,
        rows=heightmap.rows,
        offset=offset,
        scale=scale,
        spacing=list(heightmap.spacing),
        sha256=hashlib.sha256(data).hexdigest(),
    )
    # Sidecar first: a reader that does not lock (another program) between the two renames
    # sees the new sidecar with the old RAW bytes, which the hash check refuses, never new
    # RAW bytes with an old (or no) sidecar, which would read as wrong heights.
    with atomic_outputs([side, path], force=force) as (tmp_side, tmp_raw):
        tmp_side.write_text(record + "\n", encoding="utf-8")
        tmp_raw.write_bytes(data)
    return Path(path)


def write_raw16(
    heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False, sidecar: bool = True
) -> Path:
    """Write little-endian uint16 RAW: ``[min, max]`` → ``[0, 65535]``, plus ``<file>.json``.

    The sidecar (``sidecar=True``) stores size, offset, scale and spacing so
    :func:`read_raw16` restores world heights within half a step ``(max − min) / 65535``.
    """
    return _write_raw(heightmap, path, "r16", force, sidecar)


def write_raw32(
    heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False, sidecar: bool = True
) -> Path:
    """Write little-endian float32 RAW (exact), plus a ``<file>.json`` sidecar (size, spacing)."""
    return _write_raw(heightmap, path, "r32", force, sidecar)
