"""Sun (light) direction convention shared by CPU shading, shadows and the renderer.

World axes: X east (columns), Y up, Z south (rows grow southward, as in an image whose top
row is north). Azimuth is in degrees clockwise from north (0 = north = -Z, 90 = east = +X);
elevation in degrees above the horizon. The returned vector points *toward* the sun.
"""

from __future__ import annotations

import math

import numpy as np

from terrascape._validate import check_finite, check_range


def sun_direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Unit vector ``(x, y, z)`` toward the sun; float64 ``(3,)``.

    Examples
    --------
    >>> sun_direction(90, 0).round(6).tolist()
    [1.0, 0.0, 0.0]
    """
    az = math.radians(check_finite(azimuth_deg, "sun azimuth"))
    el = math.radians(check_range(elevation_deg, "sun elevation", -90.0, 90.0))
    return np.array(
        [math.sin(az) * math.cos(el), math.sin(el), -math.cos(az) * math.cos(el)],
        dtype=np.float64,
    )
