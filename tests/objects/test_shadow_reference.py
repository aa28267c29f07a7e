"""The CPU ray cast the shadow volumes and shadow maps are measured against."""

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.objects.shadow_reference import sun_occlusion


def _slab():
    """A 10 × 10 m square at y = 1 (two triangles, normal up) and one above it at y = 3,
    shifted so that it shadows the part of the lower square with x > 5."""
    lo = np.array([[[0, 1, 0], [0, 1, 10], [10, 1, 0]], [[10, 1, 0], [0, 1, 10], [10, 1, 10]]],
                  np.float64)
    hi = lo + np.array([8.0, 2.0, 0.0])
    return np.concatenate([lo, hi])


def test_a_point_just_under_a_face_the_sun_grazes_is_not_its_own_shadow():
    # sun 4° above the horizon, toward +x: N·L = 0.07 on the lower square's top face. Points
    # on that face read back from a depth buffer lie up to a fraction of a millimetre under
    # it; their rays leave through the face ~δ / N·L further on, beyond any start offset.
    el = np.radians(4.0)
    sun = np.array([np.cos(el), np.sin(el), 0.0])
    rng = np.random.default_rng(1)
    n = 400
    x = rng.uniform(0.5, 4.5, n)  # not under the upper square's shadow
    depth = rng.uniform(0.0, 3e-4, n)  # under the face, at most about one depth quantum
    pts = np.c_[x, 1.0 - depth, rng.uniform(0.5, 9.5, n)]
    tris = _slab()
    naive, _ = sun_occlusion(pts, sun, triangles=tris, start=1e-3)
    assert naive.mean() > 0.5  # the ray cast without a plane tolerance shadows them
    obj, _ = sun_occlusion(pts, sun, triangles=tris, start=1e-3, plane=3e-3)
    assert not obj.any()


def test_the_plane_tolerance_keeps_real_occluders():
    sun = np.array([0.0, 1.0, 0.0])  # straight above: x in (8, 10) under the upper square
    x = np.arange(40) * 0.25 + 0.125
    pts = np.c_[x, np.full_like(x, 1.0 - 1e-4), np.full_like(x, 5.0)]
    obj, _ = sun_occlusion(pts, sun, triangles=_slab(), start=1e-3, plane=3e-3)
    np.testing.assert_array_equal(obj, x > 8.0)


def test_bad_plane_tolerance():
    with pytest.raises(InvalidParameterError, match="plane"):
        sun_occlusion(np.zeros((1, 3)), (0.0, 45.0), triangles=_slab(), plane=-1.0)
