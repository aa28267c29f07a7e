from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting import lambert, sun_direction


def test_flat_plane_is_sin_elevation():
    for el in (5.0, 30.0, 90.0):
        out = lambert(np.zeros((6, 7)), 123.0, el)
        assert out.dtype == np.float32 and out.shape == (6, 7)
        np.testing.assert_allclose(out, math.sin(math.radians(el)), atol=1e-6)


def test_tilted_plane_facing_and_away_from_the_sun():
    dx, dz = 2.0, 1.0
    _z, x = np.mgrid[0:8, 0:9].astype(np.float64)
    # Plane rising toward the west (-X) at 45°: its normal is (1, 1, 0)/√2, facing east.
    hm = Heightmap(-(x * dx), spacing=(dx, dz))
    np.testing.assert_allclose(lambert(hm, 90.0, 45.0), 1.0, atol=1e-6)  # sun along the normal
    # Sun in the west at 30°: N·L = cos(45°+... ) = (−cos30 + sin30)/√2 < 0 → clamped to 0
    np.testing.assert_allclose(lambert(hm, 270.0, 30.0), 0.0, atol=1e-7)
    # Sun in the south at 60°: N·L = sin60/√2
    expect = float(np.dot(np.array([1, 1, 0]) / math.sqrt(2), sun_direction(180.0, 60.0)))
    np.testing.assert_allclose(lambert(hm, 180.0, 60.0), expect, atol=1e-6)


def test_lambert_rejects_nan():
    with pytest.raises(InvalidParameterError):
        lambert(np.array([[0.0, np.nan], [1.0, 2.0]]), 0.0, 30.0)
    with pytest.raises(InvalidParameterError):
        lambert(np.zeros((3, 3)), 0.0, 120.0)
