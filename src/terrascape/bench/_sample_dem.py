"""The real DEM the benchmarks measure on: the Jacksboro fault DEM matplotlib ships."""

from __future__ import annotations

import math

import numpy as np

from terrascape.heightmap import Heightmap

#: Metres per degree of latitude (and of longitude at the equator).
METRES_PER_DEGREE = 111_320.0


def real_dem() -> Heightmap:
    """The Jacksboro fault DEM (matplotlib's sample data, 344 × 403 samples of 3″): heights
    in metres, spacing in metres, the east–west one at the map's centre latitude.

    The file's ``ymin`` is its northern edge and ``ymax`` its southern one (rows run
    south), so the centre is their mean."""
    from matplotlib import cbook

    with np.load(cbook.get_sample_data("jacksboro_fault_dem.npz", asfileobj=False)) as data:
        z = np.asarray(data["elevation"], dtype=np.float32)
        lat = math.radians(0.5 * (float(data["ymin"]) + float(data["ymax"])))
        dx = float(data["dx"]) * METRES_PER_DEGREE * math.cos(lat)
        dz = float(data["dy"]) * METRES_PER_DEGREE
    return Heightmap(z, (dx, dz))


__all__ = ["real_dem"]
