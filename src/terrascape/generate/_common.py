"""Small validation helpers shared by the generators (private)."""

from __future__ import annotations

from collections.abc import Sequence

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
