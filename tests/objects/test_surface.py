"""surface_height is the full-resolution mesh as drawn: checked against the mesh's own
triangles (mesh/terrain_mesh.py), not against a re-derivation of the same formula."""

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.errors import InvalidParameterError
from terrascape.mesh.terrain_mesh import terrain_mesh
from terrascape.objects import surface_height, surface_normal


def _mesh_height(mesh, x, z):
    """Height of the one mesh triangle whose x/z projection holds each point (barycentric)."""
    tri = mesh.positions[mesh.triangles].astype(np.float64)  # (T, 3, 3)
    dx, dz = mesh.spacing
    out = np.full(len(x), np.nan)
    for k, (px, pz) in enumerate(zip(x, z, strict=True)):
        c = min(int(px / dx), mesh.cols - 2)
        r = min(int(pz / dz), mesh.rows - 2)
        for t in tri[2 * (r * (mesh.cols - 1) + c) + np.arange(2)]:
            a, b, cc = t[:, [0, 2]]
            m = np.array([b - a, cc - a]).T
            u, v = np.linalg.solve(m, [px - a[0], pz - a[1]])
            if u >= -1e-9 and v >= -1e-9 and u + v <= 1 + 1e-9:
                out[k] = t[0, 1] + u * (t[1, 1] - t[0, 1]) + v * (t[2, 1] - t[0, 1])
                break
    return out


@pytest.mark.parametrize("exaggeration", [1.0, 3.0])
def test_matches_the_drawn_triangles(exaggeration):
    rng = np.random.default_rng(0)
    hm = Heightmap(rng.normal(0, 30, (17, 23)).astype(np.float32), (2.5, 4.0))
    mesh = terrain_mesh(hm, exaggeration=exaggeration)
    ex, ez = hm.extent
    x = rng.uniform(0, ex, 400)
    z = rng.uniform(0, ez, 400)
    # points on the cell diagonals and the grid lines too
    x = np.concatenate([x, [2.5, 5.0, 1.25, ex, 0.0]])
    z = np.concatenate([z, [4.0, 0.0, 2.0, ez, 0.0]])
    want = _mesh_height(mesh, x, z)
    got = surface_height(hm, x, z, exaggeration)
    assert np.abs(got - want).max() < 1e-4
    # at the samples the surface is the vertex height itself
    r, c = np.meshgrid(np.arange(17), np.arange(23), indexing="ij")
    at = surface_height(hm, c * 2.5, r * 4.0, exaggeration)
    np.testing.assert_allclose(at, mesh.positions[:, 1].reshape(17, 23), atol=1e-4)
    # and it is not the bilinear patch (which the mesh does not draw)
    centre = surface_height(hm, np.array([1.25]), np.array([2.0]))[0]
    h = hm.heights.astype(np.float64)
    assert abs(centre - h[:2, :2].mean()) > 1e-3


def test_outside_clamps_and_normal_faces_up():
    hm = Heightmap(np.array([[0, 1], [2, 3]], np.float32), 1.0)
    np.testing.assert_allclose(surface_height(hm, [-5.0, 9.0], [0.0, 9.0]), [0.0, 3.0])
    n = surface_normal(hm, np.array([0.2]), np.array([0.2]))[0]
    np.testing.assert_allclose(n, np.array([-1, 1, -2]) / np.sqrt(6), atol=1e-12)
    with pytest.raises(InvalidParameterError, match="same shape"):
        surface_height(hm, [0.0, 1.0], [0.0])
    with pytest.raises(InvalidParameterError, match="finite"):
        surface_height(hm, [np.nan], [0.0])
