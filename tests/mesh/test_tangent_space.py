"""Tangent frames: orthonormality, handedness, analytic planes and h = sin(x)·cos(z)."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.mesh import tangent_frames, terrain_mesh
from terrascape.mesh.tangent_space import orthonormalize_frame


def _grid_heightmap(fn, n=33, extent=4.0):
    d = extent / (n - 1)
    x = np.arange(n) * d
    z = np.arange(n) * d
    h = fn(x[None, :], z[:, None])
    return Heightmap(np.asarray(h, dtype=np.float32), (d, d)), x, z


def _frame(mesh):
    n = mesh.normals.astype(np.float64)
    t = mesh.tangents[:, :3].astype(np.float64)
    w = mesh.tangents[:, 3].astype(np.float64)
    b = mesh.bitangents.astype(np.float64)
    return n, t, w, b


def test_tilted_plane_matches_analytic_frame():
    a, c = 0.3, -0.7  # h = a·x + c·z
    hm, _, _ = _grid_heightmap(lambda x, z: a * x + c * z + 0 * x * z, n=9)
    mesh = terrain_mesh(hm)
    n, t, w, b = _frame(mesh)
    n_exp = np.array([-a, 1.0, -c]) / np.linalg.norm([-a, 1.0, -c])
    t_exp = np.array([1.0, a, 0.0]) / np.linalg.norm([1.0, a, 0.0])
    np.testing.assert_allclose(n, np.broadcast_to(n_exp, n.shape), atol=1e-6)
    np.testing.assert_allclose(t, np.broadcast_to(t_exp, t.shape), atol=1e-6)
    # B is the unit vector ⟂ T, N that points along +v (+Z side)
    b_exp = -np.cross(n_exp, t_exp)
    assert b_exp[2] > 0
    np.testing.assert_allclose(b, np.broadcast_to(b_exp, b.shape), atol=1e-6)
    # planar mapping: u along +x, v along +z ⇒ T·B = N·(−1): left-handed, w = −1
    np.testing.assert_array_equal(w, -1.0)


def test_sin_cos_surface_matches_analytic_frame():
    hm, x, z = _grid_heightmap(lambda x, z: np.sin(x) * np.cos(z), n=129, extent=4.0)
    mesh = terrain_mesh(hm)
    n, t, _w, b = _frame(mesh)
    X, Z = np.meshgrid(x, z)
    hx = (np.cos(X) * np.cos(Z)).ravel()
    hz = (-np.sin(X) * np.sin(Z)).ravel()
    n_exp = np.stack([-hx, np.ones_like(hx), -hz], 1)
    n_exp /= np.linalg.norm(n_exp, axis=1, keepdims=True)
    t_exp = np.stack([np.ones_like(hx), hx, np.zeros_like(hx)], 1)
    t_exp /= np.linalg.norm(t_exp, axis=1, keepdims=True)
    inner = np.zeros((129, 129), bool)
    inner[1:-1, 1:-1] = True
    inner = inner.ravel()  # central differences are O(d²) inside; the border is one-sided
    np.testing.assert_allclose(n[inner], n_exp[inner], atol=2e-3)
    np.testing.assert_allclose(t[inner], t_exp[inner], atol=2e-3)
    np.testing.assert_allclose(b[inner], -np.cross(n_exp, t_exp)[inner], atol=3e-3)


def test_frames_are_orthonormal_and_sign_consistent(rng):
    hm = Heightmap(rng.normal(size=(17, 23)).astype(np.float32) * 3, (0.5, 2.0))
    mesh = terrain_mesh(hm, exaggeration=2.0)
    n, t, w, b = _frame(mesh)
    for v in (n, t, b):
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(np.sum(n * t, 1), 0.0, atol=1e-5)
    np.testing.assert_allclose(np.sum(n * b, 1), 0.0, atol=1e-5)
    np.testing.assert_allclose(np.sum(t * b, 1), 0.0, atol=1e-5)
    # B = w·(N × T) and B keeps pointing to +Z, T to +X
    np.testing.assert_allclose(b, np.cross(n, t) * w[:, None], atol=1e-5)
    assert (t[:, 0] > 0).all() and (b[:, 2] > 0).all() and (n[:, 1] > 0).all()


def test_generic_lengyel_agrees_with_heightfield_frames():
    hm, _, _ = _grid_heightmap(lambda x, z: np.sin(x) * np.cos(z), n=65, extent=4.0)
    mesh = terrain_mesh(hm, uv_scale=3.0)
    t4, b = tangent_frames(mesh.positions, mesh.normals, mesh.uvs, mesh.triangles)
    inner = np.zeros((65, 65), bool)
    inner[2:-2, 2:-2] = True
    inner = inner.ravel()
    np.testing.assert_allclose(t4[inner, :3], mesh.tangents[inner, :3], atol=5e-3)
    np.testing.assert_array_equal(t4[:, 3], mesh.tangents[:, 3])
    np.testing.assert_allclose(b[inner], mesh.bitangents[inner], atol=5e-3)


def test_mirrored_uvs_flip_handedness():
    # A flat quad whose v runs toward −Z has a right-handed frame: w = +1.
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1]], float)
    nrm = np.tile([0.0, 1.0, 0.0], (4, 1))
    tri = np.array([[0, 2, 1], [1, 2, 3]])
    uv_normal = p[:, [0, 2]]
    uv_mirror = np.c_[p[:, 0], 1 - p[:, 2]]
    t_a, _ = tangent_frames(p, nrm, uv_normal, tri)
    t_b, b_b = tangent_frames(p, nrm, uv_mirror, tri)
    np.testing.assert_array_equal(t_a[:, 3], -1.0)
    np.testing.assert_array_equal(t_b[:, 3], 1.0)
    np.testing.assert_allclose(b_b, np.tile([0.0, 0.0, -1.0], (4, 1)), atol=1e-7)


def test_bad_inputs():
    with pytest.raises(InvalidParameterError):
        orthonormalize_frame(np.zeros((3, 3)), np.zeros((2, 3)), np.zeros((3, 3)))
    p = np.zeros((3, 3))
    with pytest.raises(InvalidParameterError, match="out of range"):
        tangent_frames(p, p, np.zeros((3, 2)), np.array([[0, 1, 5]]))
    with pytest.raises(InvalidParameterError, match="uvs"):
        tangent_frames(p, p, np.zeros((2, 2)), np.array([[0, 1, 2]]))
