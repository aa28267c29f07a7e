"""Validation helpers shared by every public function (messages say expected vs received)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from terrascape.errors import HeightmapSizeError, InvalidParameterError


def as_height_array(heights: Any, *, name: str = "heights", allow_nan: bool = False) -> np.ndarray:
    """Return ``heights`` as a 2-D C-contiguous float32 array, or raise a clear error."""
    array = np.asarray(heights)
    if array.ndim != 2:
        raise InvalidParameterError(f"expected a 2-D {name} array, got shape {array.shape}")
    if array.shape[0] < 2 or array.shape[1] < 2:
        raise HeightmapSizeError(f"expected {name} of at least 2×2 samples, got {_wh(array)}")
    if not (np.issubdtype(array.dtype, np.number) or array.dtype == np.bool_):
        raise InvalidParameterError(f"expected numeric {name}, got dtype {array.dtype}")
    array = np.ascontiguousarray(array, dtype=np.float32)
    if not allow_nan and not np.isfinite(array).all():
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise InvalidParameterError(
            f"{name} contain {bad} NaN/infinite value(s); fill them first "
            "(terrascape.io.fill_nodata; files read by terrascape.io have NaN filled already)"
        )
    return array


def _wh(array: np.ndarray) -> str:
    return f"{array.shape[1]}×{array.shape[0]} (cols×rows)"


def is_pow2_plus1(n: int) -> bool:
    """True for 2**k + 1 with k >= 1 (3, 5, 9, 17, ...)."""
    m = n - 1
    return m >= 2 and (m & (m - 1)) == 0


def check_pow2_plus1_square(shape: tuple[int, ...], *, algorithm: str) -> int:
    """Return the side length of a square 2**n + 1 grid or raise :class:`HeightmapSizeError`."""
    rows, cols = int(shape[0]), int(shape[1])
    if rows != cols or not is_pow2_plus1(rows):
        raise HeightmapSizeError(
            f"{algorithm} needs a square (2**n + 1)-sized grid (e.g. 257, 513, 1025), "
            f"got {cols}×{rows}; pad or resample it first: Heightmap.to_pow2_plus1('pad'|"
            "'resample'), on the command line `--fit pad` or `--fit resample` (mesh) or "
            "`--pad` (view)"
        )
    return rows


def check_size_pow2_plus1(size: int, *, algorithm: str) -> int:
    """Validate a requested grid size of 2**n + 1."""
    if not isinstance(size, (int, np.integer)) or not is_pow2_plus1(int(size)):
        raise HeightmapSizeError(
            f"{algorithm} needs a size of 2**n + 1 (e.g. 129, 257, 513, 1025), got {size}"
        )
    return int(size)


def check_finite(value: float, name: str) -> float:
    """Return ``float(value)`` if finite, else raise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InvalidParameterError(f"{name} must be finite, got {value!r}")
    return v


def check_positive(value: float, name: str, *, allow_zero: bool = False) -> float:
    """Return ``float(value)`` if finite and > 0 (>= 0 with ``allow_zero``), else raise."""
    v = check_finite(value, name)
    if v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidParameterError(f"{name} must be {bound}, got {value!r}")
    return v


def check_range(value: float, name: str, lo: float, hi: float) -> float:
    """Return ``float(value)`` if lo <= value <= hi, else raise."""
    v = check_finite(value, name)
    if not lo <= v <= hi:
        raise InvalidParameterError(f"{name} must be in [{lo}, {hi}], got {value!r}")
    return v


def check_int(value: int, name: str, *, minimum: int = 0, maximum: int | None = None) -> int:
    """Return ``int(value)`` if it is an integer within bounds, else raise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidParameterError(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if v < minimum or (maximum is not None and v > maximum):
        upper = f" and <= {maximum}" if maximum is not None else ""
        raise InvalidParameterError(f"{name} must be >= {minimum}{upper}, got {v}")
    return v


def make_rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    """A numpy Generator from a seed. ``None`` means seed 0: every generator is deterministic."""
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None:
        seed = 0
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InvalidParameterError(f"seed must be a non-negative integer, got {seed!r}")
    return np.random.default_rng(int(seed))
