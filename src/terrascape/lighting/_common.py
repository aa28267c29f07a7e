"""Input handling shared by the lighting modules (private)."""

from __future__ import annotations

from typing import Any

import numpy as np

from terrascape._validate import check_finite
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.sun import sun_direction


def as_heightmap(obj: Any, *, name: str = "heightmap") -> Heightmap:
    """Accept a :class:`Heightmap` or a 2-D array (taken with spacing ``(1, 1)``).

    Validation (2-D, >= 2×2, finite) is done by :class:`Heightmap` itself, so NaN heights
    raise :class:`~terrascape.errors.InvalidParameterError` here too.
    """
    if isinstance(obj, Heightmap):
        return obj
    if obj is None:
        raise InvalidParameterError(f"{name} must be a Heightmap or a 2-D array, got None")
    return Heightmap(np.asarray(obj))


def sun_above_horizon(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Sun direction for shadowing; elevation must be in (0, 90] degrees.

    A light at or below the horizon shadows everything (or nothing, at the map border),
    which is never what a caller means, so it is rejected.
    """
    el = check_finite(elevation_deg, "sun elevation (degrees)")
    if not 0.0 < el <= 90.0:
        raise InvalidParameterError(
            f"sun elevation must be in (0, 90] degrees (above the horizon), got {elevation_deg!r}"
        )
    return sun_direction(azimuth_deg, el)
