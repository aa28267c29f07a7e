"""Slope (Lambert) shading: the first shadow component of the thesis.

The thesis (§3.2.2) splits terrain shadowing into shading by the slope relative to the light
("ordinary shading", identical to OpenGL's built-in lighting) and self-shadowing; this
module is the first part, ``max(0, N·L)``.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §3.2.2.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from terrascape.lighting._common import as_heightmap
from terrascape.lighting.normals import normal_map
from terrascape.lighting.sun import sun_direction


def lambert(heightmap: Any, sun_azimuth: float, sun_elevation: float) -> np.ndarray:
    """Lambert term ``max(0, N·L)`` per sample.

    Parameters
    ----------
    heightmap
        Heightmap (spacing used) or 2-D array (spacing 1).
    sun_azimuth, sun_elevation
        Degrees; see :func:`terrascape.lighting.sun.sun_direction` (elevation in [-90, 90]).

    Returns
    -------
    numpy.ndarray
        float32 ``(rows, cols)`` in ``[0, 1]``.
    """
    hm = as_heightmap(heightmap)
    light = sun_direction(sun_azimuth, sun_elevation)
    return _lambert_from_normals(normal_map(hm), light)


def _lambert_from_normals(normals: np.ndarray, light: np.ndarray) -> np.ndarray:
    # float32 matmul over the last axis: (rows, cols, 3) @ (3,) -> (rows, cols)
    ndotl = normals @ light.astype(np.float32)
    return np.maximum(ndotl, np.float32(0.0)).astype(np.float32, copy=False)


__all__ = ["lambert"]
