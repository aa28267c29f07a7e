"""Per-vertex tangent space.

Every vertex carries three mutually perpendicular unit vectors — tangent ``T``, bitangent
(binormal) ``B`` and normal ``N`` — and an object-space vector ``O`` is taken to texture
(tangent) space by the matrix with rows ``T, B, N``::

    [Sx, Sy, Sz]^T = [[Tx, Ty, Tz], [Bx, By, Bz], [Nx, Ny, Nz]] · [Ox, Oy, Oz]^T

``T`` follows the direction in which texture coordinate ``u`` grows and ``B`` the direction of
``v``. Both come from the triangles (Lengyel's method: solve ``[E1 E2] = [T B]·[[du1 du2],
[dv1 dv2]]`` per triangle and sum over the triangles around a vertex), are then Gram-Schmidt
orthonormalised against ``N`` (``T' = normalize(T − N(N·T))``), and ``B`` is rebuilt as
``w · (N × T')`` with the handedness sign ``w = sign((N × T')·B)`` stored as the tangent's
fourth component, so a shader needs only ``N`` and ``(T', w)``.

For terrascape's height fields with planar mapping (u along +X, v along +Z, Y up) the frame is
left-handed in the ``T × B = N`` sense (``X × Z = −Y``), so ``w = −1`` everywhere; the sign is
still computed, never assumed.

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.5.
"""

from __future__ import annotations

import numpy as np

from terrascape.errors import InvalidParameterError


def _normalize(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    # Degenerate vectors (zero-area uv triangles) stay zero instead of becoming NaN.
    return np.divide(v, n, out=np.zeros_like(v), where=n > 1e-20)


def orthonormalize_frame(
    normals: np.ndarray, tangents: np.ndarray, bitangents: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Gram-Schmidt ``T`` against ``N``; rebuild ``B = w·(N × T)``.

    Parameters
    ----------
    normals, tangents, bitangents
        ``(n, 3)`` arrays; normals must be unit length, ``tangents``/``bitangents`` are the raw
        (unnormalised) ``∂P/∂u`` and ``∂P/∂v`` directions.

    Returns
    -------
    tangents4 : (n, 4) float32
        Unit tangent orthogonal to the normal, and the handedness sign ``w`` (±1).
    bitangents : (n, 3) float32
        ``w · (N × T)``: unit, orthogonal to both ``N`` and ``T``.
    """
    n = np.asarray(normals, dtype=np.float64)
    t = np.asarray(tangents, dtype=np.float64)
    b = np.asarray(bitangents, dtype=np.float64)
    if not (n.shape == t.shape == b.shape) or n.ndim != 2 or n.shape[1] != 3:
        raise InvalidParameterError(
            f"normals, tangents and bitangents must all be (n, 3), got "
            f"{n.shape}, {t.shape}, {b.shape}"
        )
    t = _normalize(t - n * np.sum(n * t, axis=1, keepdims=True))
    nxt = np.cross(n, t)
    w = np.where(np.sum(nxt * b, axis=1) < 0.0, -1.0, 1.0)
    bit = nxt * w[:, None]
    return (
        np.concatenate([t, w[:, None]], axis=1).astype(np.float32),
        bit.astype(np.float32),
    )


def tangent_frames(
    positions: np.ndarray, normals: np.ndarray, uvs: np.ndarray, triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per-vertex tangent frames of an arbitrary indexed triangle mesh (Lengyel 2001).

    For each triangle with edges ``E1 = P1 − P0``, ``E2 = P2 − P0`` and uv differences
    ``(du1, dv1)``, ``(du2, dv2)``::

        T = ( dv2·E1 − dv1·E2) / (du1·dv2 − du2·dv1)
        B = (−du2·E1 + du1·E2) / (du1·dv2 − du2·dv1)

    summed (area-weighted, because the un-normalised cross terms scale with the triangle) onto
    its three vertices, then orthonormalised by :func:`orthonormalize_frame`.

    Parameters
    ----------
    positions : (n, 3) float
    normals : (n, 3) float, unit
    uvs : (n, 2) float
    triangles : (m, 3) int, vertex indices

    Returns
    -------
    tangents4 : (n, 4) float32 — ``(Tx, Ty, Tz, w)``
    bitangents : (n, 3) float32
    """
    p = np.asarray(positions, dtype=np.float64)
    uv = np.asarray(uvs, dtype=np.float64)
    tri = np.asarray(triangles)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidParameterError(f"positions must be (n, 3), got {p.shape}")
    if uv.shape != (len(p), 2):
        raise InvalidParameterError(f"uvs must be ({len(p)}, 2), got {uv.shape}")
    if tri.ndim != 2 or tri.shape[1] != 3 or not np.issubdtype(tri.dtype, np.integer):
        raise InvalidParameterError(f"triangles must be an (m, 3) integer array, got {tri.shape}")
    if tri.size and (tri.min() < 0 or tri.max() >= len(p)):
        raise InvalidParameterError(f"triangle indices must be in [0, {len(p)}), got out of range")
    i0, i1, i2 = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = p[i1] - p[i0], p[i2] - p[i0]
    d1, d2 = uv[i1] - uv[i0], uv[i2] - uv[i0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    # Triangles with degenerate uvs contribute nothing (r = 0) rather than infinities.
    r = np.divide(1.0, det, out=np.zeros_like(det), where=np.abs(det) > 1e-30)
    t_tri = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r[:, None]
    b_tri = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r[:, None]
    n_vert = len(p)
    t_acc = np.zeros((n_vert, 3))
    b_acc = np.zeros((n_vert, 3))
    # bincount per component is an order of magnitude faster than np.add.at.
    for corner in (i0, i1, i2):
        for k in range(3):
            t_acc[:, k] += np.bincount(corner, weights=t_tri[:, k], minlength=n_vert)
            b_acc[:, k] += np.bincount(corner, weights=b_tri[:, k], minlength=n_vert)
    return orthonormalize_frame(normals, t_acc, b_acc)


def heightfield_tangent_frames(
    hx: np.ndarray, hz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tangent frames of a height field ``y = h(x, z)`` with planar mapping u ∝ x, v ∝ z.

    ``∂P/∂u ∝ (1, ∂h/∂x, 0)`` and ``∂P/∂v ∝ (0, ∂h/∂z, 1)``; the normal is
    ``normalize(−∂h/∂x, 1, −∂h/∂z)``. This is the continuous limit of :func:`tangent_frames`
    on the grid mesh, evaluated with the same gradients as the normals so ``T ⟂ N`` exactly.

    Parameters
    ----------
    hx, hz : (rows, cols) float
        Height gradients (world units per world unit), e.g. ``Heightmap.gradient()``.

    Returns
    -------
    normals : (rows·cols, 3) float32
    tangents4 : (rows·cols, 4) float32
    bitangents : (rows·cols, 3) float32
    """
    hx = np.asarray(hx, dtype=np.float64).reshape(-1)
    hz = np.asarray(hz, dtype=np.float64).reshape(-1)
    if hx.shape != hz.shape:
        raise InvalidParameterError(
            f"hx and hz must have the same shape, got {hx.shape}, {hz.shape}"
        )
    ones, zeros = np.ones_like(hx), np.zeros_like(hx)
    n = _normalize(np.stack([-hx, ones, -hz], axis=1))
    t = np.stack([ones, hx, zeros], axis=1)
    b = np.stack([zeros, hz, ones], axis=1)
    t4, bit = orthonormalize_frame(n, t, b)
    return n.astype(np.float32), t4, bit


__all__ = ["heightfield_tangent_frames", "orthonormalize_frame", "tangent_frames"]
