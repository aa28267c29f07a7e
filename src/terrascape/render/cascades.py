"""Cascaded shadow maps of the sun: where the view frustum is split and the orthographic
light box of each slice (plain numpy, no GL).

The view frustum between the near plane and the far end of the scene is cut into ``n``
slices by the practical split scheme (a blend of logarithmic and uniform splits); each slice
gets its own orthographic sun camera that encloses the slice's bounding sphere. The sphere's
radius does not change when the camera turns or moves, and the box's centre is snapped to
whole shadow-map texels in light space, so the shadow edges of a static scene stay put
under camera motion (no shimmering). The box reaches toward the sun over the whole scene, so
casters outside the slice still cast into it.

References
----------
Zhang, F., Sun, H., Xu, L. & Lun, L. K. (2006). Parallel-split shadow maps for large-scale
virtual environments. *Proc. ACM VRCIA*, 311-318.

Engel, W. (2006). Cascaded shadow maps. In *ShaderX5*, 197-206.

Valient, M. (2008). Stable rendering of cascaded shadow maps. In *ShaderX6*, 231-237.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._validate import check_int, check_range
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError

MAX_CASCADES = 4


def practical_splits(near: float, far: float, count: int, blend: float = 0.75) -> np.ndarray:
    """float64 ``(count + 1,)`` view distances of the slice boundaries, ``near`` … ``far``:
    ``z_i = blend·n·(f/n)^(i/N) + (1 − blend)·(n + (f − n)·i/N)`` (Zhang et al. 2006).

    ``blend`` 1 gives logarithmic splits (constant perspective aliasing), 0 uniform ones.
    """
    count = check_int(count, "cascade count", minimum=1, maximum=MAX_CASCADES)
    blend = check_range(blend, "cascade split blend", 0.0, 1.0)
    if not (math.isfinite(near) and math.isfinite(far) and 0.0 < near < far):
        raise InvalidParameterError(f"cascade splits need 0 < near < far, got {near}, {far}")
    i = np.arange(count + 1, dtype=np.float64) / count
    z = blend * near * (far / near) ** i + (1.0 - blend) * (near + (far - near) * i)
    z[0], z[-1] = near, far
    return z


def light_view(sun_dir: np.ndarray) -> np.ndarray:
    """World → light-eye matrix (4×4): the light looks along ``-sun_dir``, its up vector is
    world north-ish (any vector not parallel to the sun)."""
    d = np.asarray(sun_dir, np.float64)
    d = d / np.linalg.norm(d)
    forward = -d
    up = np.array([0.0, 0.0, -1.0]) if abs(d[1]) > 0.99 else np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = right, up, -forward
    return m


def _ortho(left, right, bottom, top, near, far) -> np.ndarray:
    m = np.eye(4)
    m[0, 0] = 2.0 / (right - left)
    m[1, 1] = 2.0 / (top - bottom)
    m[2, 2] = -2.0 / (far - near)
    m[0, 3] = -(right + left) / (right - left)
    m[1, 3] = -(top + bottom) / (top - bottom)
    m[2, 3] = -(far + near) / (far - near)
    return m


@dataclass(frozen=True)
class Cascades:
    """The sun's cascades for one camera.

    Attributes
    ----------
    matrices
        float64 ``(n, 4, 4)``: world → light clip space of each cascade (x, y, z in [-1, 1]).
    splits
        float64 ``(n + 1,)``: view distances (along the camera's forward axis) of the slice
        boundaries; cascade ``i`` covers ``splits[i]`` … ``splits[i + 1]``.
    texel_size
        float64 ``(n,)``: world size of one shadow-map texel of each cascade.
    depth_range
        float64 ``(n,)``: world distance the light's depth range spans (for depth biases).
    """

    matrices: np.ndarray
    splits: np.ndarray
    texel_size: np.ndarray
    depth_range: np.ndarray
    resolution: int

    def __len__(self) -> int:
        return len(self.matrices)


def _scene_distances(camera: Camera, corners: np.ndarray) -> tuple[float, float]:
    """Nearest and farthest view distance (along forward) of the scene box's corners."""
    d = (corners - camera.eye) @ camera.forward
    return float(d.min()), float(d.max())


def fit_cascades(
    camera: Camera,
    sun_dir,
    scene_lo,
    scene_hi,
    *,
    count: int = 3,
    resolution: int = 2048,
    blend: float = 0.75,
) -> Cascades:
    """Split ``camera``'s frustum and fit one texel-snapped orthographic sun box per slice.

    Parameters
    ----------
    camera
        The view camera; its frustum is cut only where the scene box ``scene_lo`` …
        ``scene_hi`` (world AABB of every caster and receiver) lies.
    sun_dir
        Unit vector toward the sun.
    count, resolution, blend
        Number of cascades (1-4), texels per side of each map, split blend
        (:func:`practical_splits`).
    """
    resolution = check_int(resolution, "cascade resolution", minimum=16, maximum=16384)
    lo = np.asarray(scene_lo, np.float64)
    hi = np.asarray(scene_hi, np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    d_near, d_far = _scene_distances(camera, corners)
    near = max(camera.near, d_near)
    far = min(camera.far, d_far)
    if far <= near * 1.001:  # the scene is behind the camera or in a sliver: one thin slice
        near, far = camera.near, max(camera.near * 2.0, min(camera.far, abs(d_far) + 1.0))
    splits = practical_splits(near, far, count, blend)
    view_l = light_view(sun_dir)
    tan_y = math.tan(math.radians(camera.fov_y) / 2.0)
    tan_x = tan_y * camera.aspect
    f = camera.forward
    scene_l = corners @ view_l[:3, :3].T + view_l[:3, 3]
    mats, texels, ranges = [], [], []
    for k in range(count):
        z0, z1 = splits[k], splits[k + 1]
        # Bounding sphere of the slice: centre on the view axis, equidistant from the near
        # and far corners where possible (the smallest sphere of a symmetric frustum slice).
        # Its radius depends only on the split distances and the field of view, never on
        # the camera's position or orientation: a constant texel size.
        k2 = tan_x * tan_x + tan_y * tan_y
        zc = 0.5 * (z0 + z1) * (1.0 + k2)
        zc = min(zc, z1)
        radius = math.sqrt((z1 - zc) ** 2 + (z1 * z1) * k2)
        radius = max(radius, math.sqrt((zc - z0) ** 2 + (z0 * z0) * k2))
        centre = camera.eye + f * zc
        c_l = view_l[:3, :3] @ centre + view_l[:3, 3]
        texel = 2.0 * radius / resolution
        # snap the box's corner to whole texels: moving the camera shifts the map by whole
        # texels, so each world point keeps its place in a texel's footprint
        cx = math.floor(c_l[0] / texel) * texel
        cy = math.floor(c_l[1] / texel) * texel
        # depth: from beyond the scene toward the sun to the far side of the slice's sphere
        z_near = -float(scene_l[:, 2].max()) - 1e-3 * radius  # light eye looks down -z
        z_far = max(-float(scene_l[:, 2].min()), -c_l[2] + radius) + 1e-3 * radius
        proj = _ortho(cx - radius, cx + radius, cy - radius, cy + radius, z_near, z_far)
        mats.append(proj @ view_l)
        texels.append(texel)
        ranges.append(z_far - z_near)
    return Cascades(np.array(mats), splits, np.array(texels), np.array(ranges), resolution)

__all__ = ["MAX_CASCADES", "Cascades", "fit_cascades", "light_view", "practical_splits"]
