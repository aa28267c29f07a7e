from __future__ import annotations

import math

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting import sky_view_factor


def _radius(n, centre):
    z, x = np.mgrid[0:n, 0:n].astype(np.float64)
    return np.hypot(x - centre, z - centre)


def test_flat_plane_and_summit_see_the_whole_sky():
    np.testing.assert_array_equal(sky_view_factor(np.zeros((12, 9))), 1.0)
    cone = np.maximum(0.0, 20.0 - _radius(41, 20))
    svf = sky_view_factor(cone)
    assert svf[20, 20] == 1.0
    assert svf.dtype == np.float32 and (svf >= 0).all() and (svf <= 1).all()


def test_bowl_centre_matches_horizon_angle():
    # Flat floor of radius 8, walls rising 1:1 to a rim at radius 28: from the centre the
    # horizon is the rim in every direction, tan φ = (28 - 8) / 28.
    r = _radius(81, 40)
    bowl = np.clip(r - 8.0, 0.0, 20.0)
    svf = sky_view_factor(bowl, directions=32)
    expect = 1.0 - math.sin(math.atan(20.0 / 28.0))
    assert abs(svf[40, 40] - expect) < 0.01
    # anisotropic spacing: the same bowl in world units
    hm = Heightmap(np.clip(_radius(81, 40) * 0.5 - 4.0, 0.0, 10.0), spacing=(0.5, 0.5))
    assert abs(sky_view_factor(hm, directions=32)[40, 40] - expect) < 0.01
    # a search radius inside the flat floor sees no walls
    assert sky_view_factor(bowl, max_distance=7.0)[40, 40] == 1.0


def test_trench_floor_matches_analytic_mean():
    # A V-trench along Z with walls of slope k: horizon tan φ(θ) = k·|sin θ| (unbounded walls).
    k, n = 0.8, 121
    _, x = np.mgrid[0:n, 0:n].astype(np.float64)
    trench = k * np.abs(x - 60)
    d = 36
    svf = sky_view_factor(trench, directions=d, max_distance=40.0)[60, 60]
    theta = np.radians(np.arange(d) * 360.0 / d)
    # within 40 units the walls reach 40·k·|sin θ|: the horizon is still k|sin θ| (linear wall)
    expect = 1.0 - np.mean(np.sin(np.arctan(k * np.abs(np.sin(theta)))))
    assert abs(svf - expect) < 0.01


def test_valley_is_darker_than_ridge(terrain):
    h = terrain(65, 5)
    svf = sky_view_factor(h, directions=8)
    lo = np.unravel_index(np.argmin(h), h.shape)
    hi = np.unravel_index(np.argmax(h), h.shape)
    assert svf[hi] == 1.0 and svf[lo] < 0.9


def test_bad_parameters():
    with pytest.raises(InvalidParameterError, match="directions"):
        sky_view_factor(np.zeros((4, 4)), directions=2)
    with pytest.raises(InvalidParameterError, match="max_distance"):
        sky_view_factor(np.zeros((4, 4)), max_distance=-1.0)
    with pytest.raises(InvalidParameterError):
        sky_view_factor(np.array([[np.nan, 0.0], [0.0, 0.0]]))


def test_the_kernel_told_to_stop_begins_no_more_rows():
    """The flag an interrupted caller sets: rows not yet begun are left as they were."""
    from terrascape.lighting.ambient_occlusion import _svf_kernel

    h = np.maximum(0.0, 20.0 - _radius(41, 20))
    dirs = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    for stop in (0, 1):
        out = np.full(h.shape, -1.0, np.float32)
        _svf_kernel(h, 1.0, 1.0, dirs, 100.0, float(h.max()), out, np.array([stop], np.uint8))
        assert (out == -1.0).all() == bool(stop)
        assert (out == -1.0).any() == bool(stop)
