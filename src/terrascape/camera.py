"""Perspective camera: position + yaw/pitch (an FPS camera), look-at and orbit
constructors, view/projection matrices and frustum planes. Pure numpy, no OpenGL.

Conventions: X east, Y up, Z south (see :mod:`terrascape.lighting.sun`). ``yaw`` is degrees
clockwise from north (0 looks toward -Z, 90 toward +X); ``pitch`` is degrees above the
horizon, clamped to ±89.9 so looking straight up/down never yields a NaN matrix.

Matrices are float64 ``(4, 4)`` for column vectors (``clip = P @ V @ [x, y, z, 1]``), the
OpenGL convention; upload them to GL as ``M.T.astype("f4").tobytes()`` (column-major).

``infinite_far=True`` gives the projection with its far plane at infinity of Everitt &
Kilgard (2002), which stencil shadow volumes draw with: points at infinity (w = 0) land at
window depth 1 − ε/2, inside the depth range, so nothing of a volume is clipped by a far
plane. ``far`` still bounds what the camera is said to see (culling, cascade splits).

References
----------
- C. Everitt and M. J. Kilgard, "Practical and robust stenciled shadow volumes for
  hardware-accelerated rendering", NVIDIA technical report, 2002 (arXiv:cs/0301002), §4.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.6.4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from terrascape._validate import check_finite, check_positive, check_range
from terrascape.errors import InvalidParameterError

PITCH_LIMIT = 89.9
# ε of the infinite-far projection (Everitt & Kilgard 2002, §4): points at infinity go to
# NDC depth 1 − ε, two steps of a 24-bit depth buffer in front of the far plane.
INFINITE_FAR_EPSILON = 2.0 ** -22


def _vec3(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,):
        raise InvalidParameterError(f"{name} must be 3 numbers (x, y, z), got {value!r}")
    if not np.isfinite(v).all():
        raise InvalidParameterError(f"{name} must be finite, got {value!r}")
    return v


def direction_from_angles(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Unit forward vector for a yaw (clockwise from north) and pitch (above horizon)."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
    return np.array(
        [math.sin(yaw) * math.cos(pitch), math.sin(pitch), -math.cos(yaw) * math.cos(pitch)]
    )


def angles_from_direction(direction) -> tuple[float, float]:
    """(yaw, pitch) in degrees of a non-zero direction vector; yaw is 0 for vertical vectors."""
    d = _vec3(direction, "direction")
    norm = np.linalg.norm(d)
    if norm == 0:
        raise InvalidParameterError("direction must be non-zero (camera position equals target)")
    d = d / norm
    horizontal = math.hypot(d[0], d[2])
    yaw = math.degrees(math.atan2(d[0], -d[2])) if horizontal > 1e-12 else 0.0
    pitch = math.degrees(math.atan2(d[1], horizontal))
    return yaw, pitch


@dataclass(frozen=True)
class Camera:
    """An immutable perspective camera; ``with_*`` / :func:`dataclasses.replace` make new ones."""

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    pitch: float = 0.0
    fov_y: float = 60.0
    aspect: float = 16 / 9
    near: float = 0.1
    far: float = 10_000.0
    infinite_far: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", tuple(_vec3(self.position, "camera position")))
        object.__setattr__(self, "yaw", check_finite(self.yaw, "yaw") % 360.0)
        pitch = check_finite(self.pitch, "pitch")
        object.__setattr__(self, "pitch", max(-PITCH_LIMIT, min(PITCH_LIMIT, pitch)))
        check_range(self.fov_y, "fov_y (degrees)", 1e-3, 179.0)
        check_positive(self.aspect, "aspect")
        near = check_positive(self.near, "near")
        far = check_positive(self.far, "far")
        if far <= near:
            raise InvalidParameterError(f"far ({far}) must be greater than near ({near})")
        object.__setattr__(self, "infinite_far", bool(self.infinite_far))

    # --- constructors ------------------------------------------------------------------
    @classmethod
    def look_at(cls, position, target, **kwargs) -> Camera:
        """Camera at ``position`` looking at ``target``."""
        p, t = _vec3(position, "camera position"), _vec3(target, "camera target")
        yaw, pitch = angles_from_direction(t - p)
        return cls(position=tuple(p), yaw=yaw, pitch=pitch, **kwargs)

    @classmethod
    def orbit(cls, target, azimuth: float, elevation: float, distance: float, **kwargs) -> Camera:
        """Camera on a sphere around ``target``: seen from ``azimuth`` (clockwise from north)
        and ``elevation`` (degrees above the horizon) at ``distance``, looking at ``target``."""
        t = _vec3(target, "orbit target")
        dist = check_positive(distance, "orbit distance")
        check_range(elevation, "orbit elevation", -PITCH_LIMIT, PITCH_LIMIT)
        offset = direction_from_angles(check_finite(azimuth, "orbit azimuth"), elevation) * dist
        return cls.look_at(t + offset, t, **kwargs)

    # --- frame ---------------------------------------------------------------------------
    @property
    def eye(self) -> np.ndarray:
        return np.asarray(self.position, dtype=np.float64)

    @property
    def forward(self) -> np.ndarray:
        return direction_from_angles(self.yaw, self.pitch)

    @property
    def right(self) -> np.ndarray:
        yaw = math.radians(self.yaw)
        return np.array([math.cos(yaw), 0.0, math.sin(yaw)])

    @property
    def up(self) -> np.ndarray:
        return np.cross(self.right, self.forward)

    def moved(self, offset) -> Camera:
        """Camera translated by ``offset`` (world units)."""
        return replace(self, position=tuple(self.eye + _vec3(offset, "offset")))

    def turned(self, d_yaw: float, d_pitch: float) -> Camera:
        """Camera rotated by yaw/pitch increments (degrees); pitch stays clamped."""
        return replace(self, yaw=self.yaw + d_yaw, pitch=self.pitch + d_pitch)

    # --- matrices ------------------------------------------------------------------------
    def view_matrix(self) -> np.ndarray:
        """World → eye (OpenGL: eye looks down -Z, Y up)."""
        f, r, u = self.forward, self.right, self.up
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ self.eye
        return m

    def projection_matrix(self) -> np.ndarray:
        """Eye → clip, OpenGL perspective with depth in [-1, 1]."""
        f = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
        n, fa = self.near, self.far
        m = np.zeros((4, 4))
        m[0, 0] = f / self.aspect
        m[1, 1] = f
        if self.infinite_far:
            # the limit far → ∞, pulled in by ε so w = 0 points are not on the far plane
            eps = INFINITE_FAR_EPSILON
            m[2, 2] = eps - 1.0
            m[2, 3] = n * (eps - 2.0)
        else:
            m[2, 2] = (fa + n) / (n - fa)
            m[2, 3] = 2.0 * fa * n / (n - fa)
        m[3, 2] = -1.0
        return m

    def view_projection(self) -> np.ndarray:
        return self.projection_matrix() @ self.view_matrix()

    def eye_distance(self, window_depth) -> np.ndarray:
        """Distance along the view axis (eye-space −z) of window depths in [0, 1] drawn with
        this camera's projection; depth 1 (nothing drawn) gives inf."""
        d = np.asarray(window_depth, dtype=np.float64)
        ndc = d * 2.0 - 1.0
        n, fa = self.near, self.far
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.infinite_far:
                eps = INFINITE_FAR_EPSILON
                s = n * (2.0 - eps) / ((1.0 - eps) - ndc)
            else:
                s = 2.0 * fa * n / ((fa + n) - ndc * (fa - n))
        return np.where((d >= 1.0) | (s <= 0.0), np.inf, s)

    def window_depth(self, eye_distance) -> np.ndarray:
        """Window depth in [0, 1] of points at ``eye_distance`` along the view axis (the
        inverse of :meth:`eye_distance`); inf gives 1."""
        s = np.asarray(eye_distance, dtype=np.float64)
        n, fa = self.near, self.far
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.infinite_far:
                eps = INFINITE_FAR_EPSILON
                ndc = (1.0 - eps) - n * (2.0 - eps) / s
            else:
                ndc = ((fa + n) - 2.0 * fa * n / s) / (fa - n)
        return np.where(np.isfinite(s), ndc * 0.5 + 0.5, 1.0)

    def frustum_planes(self) -> np.ndarray:
        """Six planes ``(a, b, c, d)`` (left, right, bottom, top, near, far), unit normals
        pointing inward: a point is inside when ``a·x + b·y + c·z + d >= 0`` for all six
        (Gribb & Hartmann's extraction from the view-projection matrix)."""
        m = self.view_projection()
        planes = np.array(
            [m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]]
        )
        planes /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
        return planes

    def project(self, points, viewport: tuple[int, int]) -> np.ndarray:
        """World points ``(N, 3)`` → ``(N, 3)``: pixel x, pixel y (row 0 at the top) and
        eye-space distance along the view axis (negative = behind the camera)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        h = np.c_[pts, np.ones(len(pts))]
        clip = h @ self.view_projection().T
        eye_depth = -(h @ self.view_matrix().T)[:, 2]
        w = np.where(np.abs(clip[:, 3]) < 1e-12, 1e-12, clip[:, 3])
        ndc = clip[:, :3] / w[:, None]
        width, height = viewport
        px = (ndc[:, 0] * 0.5 + 0.5) * width
        py = (0.5 - ndc[:, 1] * 0.5) * height
        return np.c_[px, py, eye_depth]

    def pixels_per_radian(self, viewport_height: int) -> float:
        """Screen pixels per radian at the view centre: ``v_res / (2·tan(fov/2))``."""
        return viewport_height / (2.0 * math.tan(math.radians(self.fov_y) / 2.0))


def frame_terrain(
    extent: tuple[float, float],
    height_range: tuple[float, float],
    *,
    azimuth: float = 210.0,
    elevation: float = 35.0,
    fov_y: float = 45.0,
    aspect: float = 16 / 9,
) -> Camera:
    """A default camera that sees the whole terrain (any size, any spacing).

    The terrain occupies ``x ∈ [0, extent[0]]``, ``z ∈ [0, extent[1]]``,
    ``y ∈ height_range``; the camera orbits its centre at a distance at which the bounding
    sphere fits the narrower field of view.
    """
    w, d = (check_positive(e, "terrain extent") for e in extent)
    lo, hi = (check_finite(v, "height") for v in height_range)
    centre = np.array([w / 2.0, (lo + hi) / 2.0, d / 2.0])
    radius = 0.5 * math.sqrt(w * w + d * d + (hi - lo) ** 2)
    tan_y = math.tan(math.radians(fov_y) / 2.0)
    tan_x = tan_y * aspect
    # Fit the eight bounding-box corners, not the bounding sphere: a corner at offset
    # (x, y, z) in the camera basis (z towards the eye) stays inside the view when the eye is
    # at least z + |x|/tan_x (resp. |y|/tan_y) away from the centre. The sphere fit leaves a
    # low-relief terrain filling a fifth of the frame.
    probe = Camera.orbit(centre, azimuth, elevation, 1.0, fov_y=fov_y, aspect=aspect)
    corners = np.array([[x, y, z] for x in (0.0, w) for y in (lo, hi) for z in (0.0, d)])
    rel = corners - centre
    along = rel @ -probe.forward
    need = np.maximum(np.abs(rel @ probe.right) / tan_x, np.abs(rel @ probe.up) / tan_y)
    distance = max(float(np.max(along + need)) * 1.04, radius * 1e-3)
    near = max(distance - radius * 1.5, distance * 1e-3)
    far = distance + radius * 2.0
    return Camera.orbit(
        centre, azimuth, elevation, distance, fov_y=fov_y, aspect=aspect, near=near, far=far
    )


def frame_landscape(
    extent: tuple[float, float],
    height_range: tuple[float, float],
    *,
    azimuth: float = 210.0,
    fov_y: float = 45.0,
    aspect: float = 16 / 9,
    horizon: float = 0.25,
    height: float = 0.22,
    edge_height: float | None = None,
) -> Camera:
    """A landscape-photo camera: over the terrain's near edge, looking across it, with the
    horizon ``horizon`` (fraction of the image height) below the top edge.

    Seen from ``azimuth`` (clockwise from north, as in :func:`frame_terrain`), the eye stands
    ``height`` × the terrain's depth along the view above its mid height (at least half
    that above its highest point), pitched so that the horizon sits at ``horizon``; it is
    moved along the view until the bottom edge of the image crosses the near edge at
    ``edge_height`` (the highest height of the terrain's border; default the highest of the
    terrain), so no ray passes under the terrain's edge (the mesh has no side walls).
    The terrain then fills the image from the bottom up to its far edge just below the
    horizon — the renderer's surround (sea, plane or haze) continues it to the horizon —
    instead of a small tile floating in an empty frame.
    """
    w, d = (check_positive(e, "terrain extent") for e in extent)
    lo, hi = (check_finite(v, "height") for v in height_range)
    check_range(horizon, "horizon (fraction of the image height)", 0.01, 0.5)
    check_positive(height, "height (share of the terrain's depth)")
    tan_y = math.tan(math.radians(fov_y) / 2.0)
    pitch = -math.degrees(math.atan((1.0 - 2.0 * horizon) * tan_y))
    bottom = math.radians(fov_y / 2.0 - pitch)  # depression of the image's bottom edge
    yaw = (check_finite(azimuth, "azimuth") + 180.0) % 360.0
    fwd = direction_from_angles(yaw, 0.0)
    centre = np.array([w / 2.0, (lo + hi) / 2.0, d / 2.0])
    corners = np.array([[x, z] for x in (0.0, w) for z in (0.0, d)]) - centre[[0, 2]]
    along = corners @ fwd[[0, 2]]
    depth = float(along.max() - along.min())
    mid = centre[1]
    cross = hi if edge_height is None else min(check_finite(edge_height, "edge height"), hi)
    eye_y = max(mid + height * depth, cross + 0.5 * height * depth)
    back = (eye_y - cross) / math.tan(bottom)
    eye_h = centre[[0, 2]] + fwd[[0, 2]] * (float(along.min()) + 0.02 * depth - back)
    eye = np.array([eye_h[0], eye_y, eye_h[1]])
    far_pts = np.array([[x, y, z] for x in (0.0, w) for y in (lo, hi) for z in (0.0, d)])
    far = float(np.linalg.norm(far_pts - eye, axis=1).max()) * 1.1
    return Camera(position=tuple(eye), yaw=yaw, pitch=pitch, fov_y=fov_y, aspect=aspect,
                  near=max(far * 2e-4, 1e-3), far=far)
