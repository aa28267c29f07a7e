"""Filling nodata holes in a heightmap from the nearest valid samples.

Used for GeoTIFF ``GDAL_NODATA`` samples (and NaN in float TIFFs): a DEM with voids must
become a complete float grid before any terrain algorithm can use it.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from terrascape.errors import InvalidParameterError


def fill_nodata(heights: np.ndarray, mask: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Replace invalid samples by the value of the nearest valid sample.

    Method: exact Euclidean distance transform of the invalid mask
    (:func:`scipy.ndimage.distance_transform_edt` with ``return_indices=True``), which gives
    for every sample the index of its nearest valid sample; invalid samples copy that value.
    Nearest fill never invents heights outside the valid range and is O(n), unlike iterative
    mean diffusion whose convergence on large voids is slow. Ties are broken by scipy's scan
    order, so the result is deterministic.

    Parameters
    ----------
    heights
        2-D numeric array.
    mask
        Boolean array of the same shape, ``True`` where a sample is invalid. ``None`` means
        "every non-finite sample".

    Returns
    -------
    (filled, count)
        ``filled`` is a new float32 array without invalid samples; ``count`` is how many
        samples were replaced.

    Raises
    ------
    InvalidParameterError
        Not 2-D, mask shape mismatch, or no valid sample at all.
    """
    h = np.asarray(heights)
    if h.ndim != 2:
        raise InvalidParameterError(f"expected a 2-D heights array, got shape {h.shape}")
    h = h.astype(np.float32, copy=True)
    invalid = ~np.isfinite(h)
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != h.shape:
            raise InvalidParameterError(
                f"mask shape must equal heights shape {h.shape}, got {mask.shape}"
            )
        invalid |= mask
    count = int(np.count_nonzero(invalid))
    if count == 0:
        return h, 0
    if count == h.size:
        raise InvalidParameterError(
            f"cannot fill nodata: all {h.size} samples are nodata, expected at least one valid"
        )
    # distance_transform_edt measures distance to the nearest zero, so valid samples are 0.
    indices = ndimage.distance_transform_edt(invalid, return_distances=False, return_indices=True)
    filled = h[indices[0], indices[1]]
    return np.ascontiguousarray(filled, dtype=np.float32), count


def fill_non_finite(heights: np.ndarray, where: str) -> tuple[np.ndarray, int]:
    """NaN/±inf samples of a float file are nodata: fill them from the nearest valid sample
    and warn with the count, the same in every float format (GeoTIFF, ``.npy``, ``.r32``).

    Returns ``(heights, number filled)``: the input unchanged when every sample is finite,
    else a filled float64 copy. A file with no finite sample at all is a
    :class:`~terrascape.errors.FileFormatError`.
    """
    import warnings

    from terrascape.errors import FileFormatError

    heights = np.asarray(heights)
    if not np.issubdtype(heights.dtype, np.floating) or np.isfinite(heights).all():
        return heights, 0
    invalid = ~np.isfinite(heights)
    count = int(np.count_nonzero(invalid))
    if count == heights.size:
        raise FileFormatError(f"{where}: all {heights.size} samples are NaN/infinite (nodata)")
    heights = heights.astype(np.float64)
    heights[invalid] = np.nan
    heights, count = fill_nodata(heights)
    warnings.warn(
        f"{where}: filled {count} NaN/infinite (nodata) sample(s) of {heights.size} from "
        "their nearest valid neighbours",
        stacklevel=3,
    )
    return heights, count
