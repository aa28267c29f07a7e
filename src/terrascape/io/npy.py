"""NumPy ``.npy`` heightmaps: a 2-D numeric array of world heights (exact, float32 on write).

``.npy`` has no room for the spacing, so reading gives ``(1, 1)`` unless ``spacing`` is
passed. Pickled (object) arrays are refused: loading them could run arbitrary code.
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
    normalise_spacing,
)
from terrascape.io.atomic import atomic_output
from terrascape.io.fill import fill_non_finite


def read_npy(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a 2-D integer/float ``.npy`` array as world heights.

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
    md = file_metadata(p, "npy", str(array.dtype), step=0.0, filled=filled)
    # asarray: a float32 file is not copied again (the read peak stays at one map).
    return Heightmap(np.asarray(heights, dtype=np.float32), spacing_t or (1.0, 1.0), md)


def write_npy(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write the heights as a float32 ``.npy`` (exact; spacing is not stored)."""
    check_heightmap(heightmap)
    with atomic_output(path, force=force) as tmp, open(tmp, "wb") as fh:
        np.save(fh, np.ascontiguousarray(heightmap.heights, dtype=np.float32))
    return Path(path)
