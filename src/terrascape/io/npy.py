"""NumPy ``.npy`` heightmaps: a 2-D numeric array of world heights (exact, float32 on write).

``.npy`` has no room for the spacing, so it goes in a JSON sidecar next to the array, named
like the RAW formats' (``dem.npy`` → ``dem.npy.json``, ``{"spacing": [dx, dz], …}``): every
command reads it back through :func:`read_npy`, and ``np.load`` still reads the array alone.
Without a sidecar (an array saved by other tools) the spacing is ``(1, 1)`` unless
``spacing`` is passed. Pickled (object) arrays are refused: loading them could run code.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    file_metadata,
    meta_json,
    normalise_spacing,
    parse_meta,
)
from terrascape.io.atomic import atomic_outputs, check_output_path
from terrascape.io.fill import fill_non_finite


def npy_sidecar_path(path: str | os.PathLike) -> Path:
    """The JSON sidecar of a ``.npy`` heightmap: ``dem.npy`` → ``dem.npy.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def _sidecar_spacing(path: Path, shape: tuple[int, ...]) -> tuple[float, float] | None:
    side = npy_sidecar_path(path)
    if not side.is_file():
        return None
    try:
        text = side.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"cannot read sidecar {side}: {exc}") from None
    meta = parse_meta(text, where=str(side))
    if (meta.get("rows"), meta.get("cols")) != tuple(shape):
        raise FileFormatError(
            f"sidecar {side} describes a {meta.get('cols')}×{meta.get('rows')} grid but "
            f"{path.name} holds {shape[1]}×{shape[0]}; remove or rewrite the sidecar"
        )
    return normalise_spacing(meta.get("spacing"))


def read_npy(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a 2-D integer/float ``.npy`` array as world heights.

    The spacing comes from ``spacing``, else the ``.npy.json`` sidecar, else ``(1, 1)``;
    ``vertical_scale`` multiplies the heights.

    Raises
    ------
    FileFormatError
        Missing/truncated/corrupt file, pickled data, not 2-D, non-numeric dtype.

    NaN/infinite samples are nodata, as in every float format terrascape reads: they are
    filled from the nearest valid sample with a warning (``metadata["filled"]`` counts them).
    """
    p = check_input_path(path)
    spacing_t = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    try:
        array = np.load(p, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise FileFormatError(f"cannot read .npy file {p}: {exc}") from None
    if not isinstance(array, np.ndarray):  # an .npz archive saved as .npy
        raise FileFormatError(f"expected a single array in {p}, got {type(array).__name__}")
    if array.ndim != 2:
        raise FileFormatError(f"expected a 2-D array in {p}, got shape {array.shape}")
    if not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
        raise FileFormatError(f"expected integer or float heights in {p}, got dtype {array.dtype}")
    # NaN/inf are nodata, filled with a warning, as in GeoTIFF and .r32 files.
    heights, filled = fill_non_finite(array, p.name)
    if vscale is not None:
        heights = heights.astype(np.float64) * vscale
    file_spacing = _sidecar_spacing(p, array.shape)
    md = file_metadata(p, "npy", str(array.dtype), step=0.0, filled=filled,
                       spacing_restored=file_spacing is not None)
    # asarray: a float32 file is not copied again (the read peak stays at one map).
    return Heightmap(np.asarray(heights, dtype=np.float32),
                     spacing_t or file_spacing or (1.0, 1.0), md)


def write_npy(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write the heights as a float32 ``.npy`` (exact) and the spacing to ``<file>.json``.

    Both files are checked before either is written (``force`` covers both).
    """
    check_heightmap(heightmap)
    side = npy_sidecar_path(path)
    check_output_path(path, force=force)
    check_output_path(side, force=force)
    record = meta_json(rows=heightmap.rows, cols=heightmap.cols,
                       spacing=list(heightmap.spacing))
    # One unit: the heights and their spacing appear together or not at all.
    with atomic_outputs([side, path], force=force) as (tmp_side, tmp_npy):
        tmp_side.write_text(record + "\n", encoding="utf-8")
        with open(tmp_npy, "wb") as fh:
            np.save(fh, np.ascontiguousarray(heightmap.heights, dtype=np.float32))
    return Path(path)
