from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting import (
    normal_map,
    pack_normal_height,
    tangent_space_normals,
    unpack_normals,
)


def _grid(rows, cols, dx, dz):
    z, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    return x * dx, z * dz


@pytest.mark.parametrize("scale", [1.0, 2.5, -0.5])
def test_tilted_plane_exact_with_spacing_and_scale(scale):
    dx, dz = 2.0, 0.5
    x, z = _grid(9, 13, dx, dz)
    a, b = 0.3, -0.7
    hm = Heightmap(a * x + b * z, spacing=(dx, dz))
    n = normal_map(hm, height_scale=scale)
    expect = np.array([-scale * a, 1.0, -scale * b])
    expect /= np.linalg.norm(expect)
    assert n.shape == (9, 13, 3) and n.dtype == np.float32
    np.testing.assert_allclose(n, np.broadcast_to(expect, n.shape), atol=2e-6)
    t = tangent_space_normals(hm, height_scale=scale)
    np.testing.assert_allclose(t, np.broadcast_to(expect[[0, 2, 1]], t.shape), atol=2e-6)


def test_paraboloid_exact_everywhere_including_border():
    dx, dz = 0.5, 1.5
    x, z = _grid(17, 21, dx, dz)
    x0, z0, c = 4.0, 12.0, 0.2
    hm = Heightmap(c * ((x - x0) ** 2 + (z - z0) ** 2), spacing=(dx, dz))
    n = normal_map(hm, height_scale=1.0)
    hx, hz = 2 * c * (x - x0), 2 * c * (z - z0)
    expect = np.stack([-hx, np.ones_like(hx), -hz], axis=-1)
    expect /= np.linalg.norm(expect, axis=-1, keepdims=True)
    # float32 heights: the stencils are exact, the tolerance is the storage rounding only
    np.testing.assert_allclose(n, expect, atol=5e-5)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-6)
    # the apex is flat and normals point away from it
    assert np.allclose(n[8, 8], [0, 1, 0], atol=1e-6)
    # h grows away from the apex, so normals lean back toward it: at x < x0, z < z0 both > 0
    assert n[0, 0, 0] > 0 and n[0, 0, 2] > 0


def test_matches_heightmap_normals_inside_and_accepts_plain_arrays(rng):
    h = rng.random((20, 30)).astype(np.float32)
    ours = normal_map(h)
    theirs = Heightmap(h).normals()
    np.testing.assert_allclose(ours[1:-1, 1:-1], theirs[1:-1, 1:-1], atol=1e-5)


def test_two_by_two_map_and_zero_scale():
    n = normal_map(np.array([[0.0, 1.0], [0.0, 1.0]]))
    expect = np.array([-1.0, 1.0, 0.0]) / np.sqrt(2)
    np.testing.assert_allclose(n, np.broadcast_to(expect, n.shape), atol=1e-6)
    flat = normal_map(np.array([[0.0, 5.0], [3.0, 1.0]]), height_scale=0.0)
    np.testing.assert_allclose(flat, np.broadcast_to([0, 1, 0], flat.shape))


def test_pack_flat_and_ramp_8_and_16_bits():
    flat = pack_normal_height(np.zeros((4, 5)), bits=8)
    assert flat.dtype == np.uint8 and flat.shape == (4, 5, 4)
    assert (flat[..., 0] == 128).all() and (flat[..., 1] == 128).all()
    assert (flat[..., 2] == 255).all() and (flat[..., 3] == 0).all()

    x, _ = _grid(6, 11, 1.0, 1.0)
    p16 = pack_normal_height(Heightmap(x * 0.25), bits=16)
    assert p16.dtype == np.uint16
    assert p16[0, 0, 3] == 0 and p16[0, -1, 3] == 65535
    np.testing.assert_array_equal(p16[..., 3], np.rint(x / 10 * 65535).astype(np.uint16))
    # normal leans toward -x (height grows along +x): R below mid-grey, G exactly mid
    assert (p16[..., 0] < 32767).all() and (p16[..., 1] == 32768).all()
    back = unpack_normals(p16)
    np.testing.assert_allclose(back, tangent_space_normals(Heightmap(x * 0.25)), atol=1e-4)


def test_pack_roundtrip_8bit(rng):
    h = rng.random((16, 16)).astype(np.float32)
    packed = pack_normal_height(h, height_scale=0.5)
    back = unpack_normals(packed)
    np.testing.assert_allclose(back, tangent_space_normals(h, height_scale=0.5), atol=1.5 / 127)


@pytest.mark.parametrize(
    "bad",
    [np.array([[0.0, np.nan], [0.0, 1.0]]), np.zeros(5), np.zeros((1, 5)), None],
)
def test_bad_heights_raise(bad):
    with pytest.raises(InvalidParameterError):
        normal_map(bad)


def test_bad_bits_and_scale():
    with pytest.raises(InvalidParameterError, match="bits"):
        pack_normal_height(np.zeros((3, 3)), bits=12)
    with pytest.raises(InvalidParameterError, match="height_scale"):
        normal_map(np.zeros((3, 3)), height_scale=float("nan"))
