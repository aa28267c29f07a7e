"""Small validation helpers shared by the generators (private)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from terrascape._validate import check_int
from terrascape.errors import HeightmapSizeError, InvalidParameterError

MAX_SIDE = 1 << 16


def grid_shape(size_or_shape: int | Sequence[int], *, algorithm: str) -> tuple[int, int]:
    """``n`` → ``(n, n)``; ``(rows, cols)`` → itself; each side in ``[2, 65536]``."""
    if isinstance(size_or_shape, (int, np.integer)) and not isinstance(size_or_shape, bool):
        dims = (int(size_or_shape), int(size_or_shape))
    elif isinstance(size_or_shape, Sequence) and len(size_or_shape) == 2:
        dims = tuple(check_int(v, f"{algorithm} shape entry") for v in size_or_shape)
    else:
        raise InvalidParameterError(
            f"{algorithm} needs a size N or a shape (rows, cols), got {size_or_shape!r}"
        )
    if min(dims) < 2 or max(dims) > MAX_SIDE:
        raise HeightmapSizeError(
            f"{algorithm} needs 2..{MAX_SIDE} samples per side, got {dims[1]}×{dims[0]} "
            "(cols×rows)"
        )
    return dims  # type: ignore[return-value]


def spacing_pair(spacing: float | Sequence[float]) -> tuple[float, float]:
    """Scalar spacing → ``(dx, dz)``; Heightmap validates the values."""
    if np.isscalar(spacing):
        return (spacing, spacing)  # type: ignore[return-value]
    return tuple(spacing)  # type: ignore[return-value]


def seed_meta(seed: object) -> int | None:
    """The seed as stored in metadata (``None`` for a Generator)."""
    if seed is None:
        return 0
    return int(seed) if isinstance(seed, (int, np.integer)) else None


#: Samples of float64 accumulator a generator keeps at a time (1 MiB): the map is built in
#: blocks of rows, each summed in float64 and stored as float32, so the peak is the float32
#: result plus one block instead of a float64 copy of the whole map.
ACCUMULATOR_SAMPLES = 1 << 17


def accumulate_in_row_blocks(
    shape: tuple[int, int],
    n_items: int,
    chunk: int,
    add: Callable[[np.ndarray, int, int, int], None],
    progress: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """A float32 ``shape`` map whose every block of rows is the float64 sum of ``n_items``
    contributions, added ``chunk`` at a time in item order by ``add(block, z0, lo, hi)``
    (``block`` holds rows ``z0 …``). Each sample sees the same additions in the same order
    as one whole-map accumulator would, so the values are those of the whole-map sum.
    ``progress(done, n_items)`` is called after every chunk, ``done`` growing to
    ``n_items``."""
    rows, cols = shape
    out = np.empty(shape, dtype=np.float32)
    # At most a sixteenth of the map in float64 (an eighth of the result's bytes).
    step = max(1, min(rows // 16, ACCUMULATOR_SAMPLES // max(1, cols)))
    starts = range(0, rows, step)
    chunks = range(0, n_items, chunk)
    total = len(starts) * len(chunks)
    done = 0
    for z0 in starts:
        block = np.zeros((min(step, rows - z0), cols), dtype=np.float64)
        for lo in chunks:
            add(block, z0, lo, min(lo + chunk, n_items))
            done += 1
            if progress is not None:
                progress(n_items * done // total, n_items)
        out[z0:z0 + block.shape[0]] = block
    return out
