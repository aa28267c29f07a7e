"""Exact CPU reference for relief mapping: per-pixel view-ray ∩ bilinear height field.

Geometry (shared by every relief shader, so results compare pixel by pixel):

* A :class:`ReliefQuad` is a parallelogram in world space: corner ``origin``, edges
  ``u_axis`` and ``v_axis``; texture coordinates run from ``(0, 0)`` at the origin to
  ``uv_scale`` at the far corner (``uv_scale > 1`` tiles the relief texture).
* The relief hangs *below* the polygon (Policarpo et al. 2005): a
  texel of depth ``d ∈ [0, 1]`` (``d = 1 - height``) lies ``d · depth`` UV units under the
  face that the camera sees. ``depth`` is in UV units (0.1 = a tenth of the texture width).
* Rays are expressed in *uvd* coordinates: ``(u, v)`` texture coordinates and ``d``
  normalised depth. A view ray entering the polygon at ``uv0`` is ``uv0 + s·ds`` at depth
  ``s``; ``ds`` (UV per unit depth) is all a tangent-space tracer needs.
* The height texture is sampled like a GL texture with ``GL_LINEAR`` + ``GL_REPEAT``: texel
  ``(row, col)`` centred at ``((col + 0.5)/W, (row + 0.5)/H)``, bilinear, periodic.
* Pixels follow ``glReadPixels``: row 0 is the *bottom* of the framebuffer.

:func:`trace_exact` walks the ray cell by cell (2-D DDA over the bilinear cells); inside a
cell ``s - depth(s)`` is a quadratic in ``s``, split at its extremum into monotone pieces,
and the first sign change is bisected to 1e-5 texel — an exact first hit, thin walls
included. :func:`shadow_exact` checks a light ray for *any* point under the surface using
the same per-cell quadratics (maximum of a quadratic on an interval is exact).

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.4.6–2.4.7.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import as_height_array, check_int, check_positive
from terrascape.errors import InvalidParameterError


def _vec3(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InvalidParameterError(f"{name} must be 3 finite numbers, got {value!r}")
    return v


@dataclass(frozen=True)
class ReliefQuad:
    """A relief-textured parallelogram in world space (see the module docstring).

    Parameters
    ----------
    origin
        World position of texture coordinate ``(0, 0)``.
    u_axis, v_axis
        World edge vectors along +u and +v (may be mirrored or rotated; not parallel).
    depth
        Relief depth in UV units (``> 0``).
    uv_scale
        Texture coordinates at the far corner, ``(su, sv)``; ``> 1`` tiles the texture.
    """

    origin: tuple[float, float, float] = (-0.5, 0.0, -0.5)
    u_axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    v_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    depth: float = 0.1
    uv_scale: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        o, a, b = _vec3(self.origin, "origin"), _vec3(self.u_axis, "u_axis"), _vec3(
            self.v_axis, "v_axis"
        )
        if np.linalg.norm(np.cross(a, b)) < 1e-12 * max(np.dot(a, a), np.dot(b, b), 1e-300):
            raise InvalidParameterError(
                f"u_axis and v_axis must span a plane, got {self.u_axis!r}, {self.v_axis!r}"
            )
        object.__setattr__(self, "origin", tuple(o))
        object.__setattr__(self, "u_axis", tuple(a))
        object.__setattr__(self, "v_axis", tuple(b))
        object.__setattr__(self, "depth", check_positive(self.depth, "depth (UV units)"))
        sc = np.asarray(self.uv_scale, dtype=np.float64).reshape(-1)
        if sc.shape != (2,) or not np.isfinite(sc).all() or (sc == 0).any():
            raise InvalidParameterError(
                f"uv_scale must be two finite non-zero numbers, got {self.uv_scale!r}"
            )
        object.__setattr__(self, "uv_scale", (float(sc[0]), float(sc[1])))

    @classmethod
    def centred(cls, size: float = 1.0, depth: float = 0.1, **kwargs) -> ReliefQuad:
        """A horizontal ``size × size`` quad centred at the world origin, +u = +X, +v = +Z
        (its face normal is −Y; the relief hangs below whichever side the camera sees)."""
        h = size / 2.0
        return cls((-h, 0.0, -h), (size, 0.0, 0.0), (0.0, 0.0, size), depth, **kwargs)

    @property
    def face_normal(self) -> np.ndarray:
        n = np.cross(self.u_axis, self.v_axis)
        return n / np.linalg.norm(n)

    def corners(self) -> np.ndarray:
        """World corners ``(4, 3)`` in order (0,0), (1,0), (1,1), (0,1)."""
        o, a, b = (np.asarray(x) for x in (self.origin, self.u_axis, self.v_axis))
        return np.array([o, o + a, o + a + b, o + b])

    def uv_unit_length(self) -> float:
        """World length of one UV unit (geometric mean of the two axes)."""
        la = np.linalg.norm(self.u_axis) / abs(self.uv_scale[0])
        lb = np.linalg.norm(self.v_axis) / abs(self.uv_scale[1])
        return float(math.sqrt(la * lb))

    def front_normal(self, eye) -> np.ndarray:
        """Unit normal of the side ``eye`` sees (the relief hangs on the other side)."""
        n = self.face_normal
        if np.dot(_vec3(eye, "eye") - np.asarray(self.origin), n) < 0:
            n = -n
        return n

    def uvd_basis(self, eye) -> np.ndarray:
        """3×3 matrix whose columns are the world vectors of +1 u, +1 v and +1 depth."""
        n = self.front_normal(eye)
        a = np.asarray(self.u_axis) / self.uv_scale[0]
        b = np.asarray(self.v_axis) / self.uv_scale[1]
        return np.column_stack([a, b, -n * self.depth * self.uv_unit_length()])

    def world_to_uvd(self, eye) -> np.ndarray:
        """Inverse of :meth:`uvd_basis`: world direction → uvd direction."""
        return np.linalg.inv(self.uvd_basis(eye))


def pixel_rays(camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """World ray origin ``(3,)`` and directions ``(H, W, 3)`` through pixel centres.

    Row 0 is the bottom row (``glReadPixels`` order).
    """
    w = check_int(width, "width (pixels)", minimum=1)
    h = check_int(height, "height (pixels)", minimum=1)
    inv = np.linalg.inv(camera.view_projection())
    x = (np.arange(w) + 0.5) / w * 2.0 - 1.0
    y = (np.arange(h) + 0.5) / h * 2.0 - 1.0
    xx, yy = np.meshgrid(x, y)
    ndc = np.stack([xx, yy, np.ones_like(xx), np.ones_like(xx)], axis=-1)
    far = ndc @ inv.T
    far = far[..., :3] / far[..., 3:4]
    eye = camera.eye
    return eye, far - eye


def quad_entry(quad: ReliefQuad, camera, width: int, height: int):
    """Where each pixel's view ray enters the quad, and its uvd slope.

    Returns
    -------
    uv0 : numpy.ndarray
        float64 ``(H, W, 2)`` texture coordinates on the polygon (NaN where the ray misses).
    ds : numpy.ndarray
        float64 ``(H, W, 2)`` UV offset per unit of normalised depth along the ray.
    valid : numpy.ndarray
        bool ``(H, W)``: the ray hits the quad in front of the camera.
    """
    eye, dirs = pixel_rays(camera, width, height)
    o = np.asarray(quad.origin)
    m_inv = quad.world_to_uvd(eye)
    rel = m_inv @ (eye - o)  # eye in uvd: (ue, ve, de), de < 0 (above the face)
    duvd = dirs @ m_inv.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -rel[2] / duvd[..., 2]
        uv0 = rel[:2] + t[..., None] * duvd[..., :2]
        ds = duvd[..., :2] / duvd[..., 2:3]
    su, sv = quad.uv_scale
    lo_u, hi_u = sorted((0.0, su))
    lo_v, hi_v = sorted((0.0, sv))
    valid = (
        (t > 0)
        & (duvd[..., 2] > 0)
        & (uv0[..., 0] >= lo_u)
        & (uv0[..., 0] <= hi_u)
        & (uv0[..., 1] >= lo_v)
        & (uv0[..., 1] <= hi_v)
    )
    uv0 = np.where(valid[..., None], uv0, np.nan)
    ds = np.where(valid[..., None], ds, np.nan)
    return uv0, ds, valid


# ----------------------------------------------------------------------------------------
# numba kernels
# ----------------------------------------------------------------------------------------


@njit(cache=CACHE, fastmath=FASTMATH)
def _corners(depth, ix, iy):
    rows, cols = depth.shape
    x0 = ix % cols
    y0 = iy % rows
    x1 = (x0 + 1) % cols
    y1 = (y0 + 1) % rows
    return depth[y0, x0], depth[y0, x1], depth[y1, x0], depth[y1, x1]


@njit(cache=CACHE, fastmath=FASTMATH)
def _cell_f(s, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, sign):
    # f(s) = sign·s + c0 − bilinear depth at the ray point; quadratic in s inside the cell.
    fx = x0 + s * dx - ix
    fy = y0 + s * dy - iy
    b = (d00 * (1.0 - fx) + d10 * fx) * (1.0 - fy) + (d01 * (1.0 - fx) + d11 * fx) * fy
    return sign * s - b


@njit(cache=CACHE, fastmath=FASTMATH)
def _extremum(s_a, s_b, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, sign):
    # Vertex of the quadratic f(s) (its s² coefficient is −(d00−d10−d01+d11)·dx·dy).
    k = d00 - d10 - d01 + d11
    a2 = -k * dx * dy
    if abs(a2) < 1e-300:
        return -1.0
    fx0 = x0 - ix
    fy0 = y0 - iy
    # d/ds of the bilinear term at s = 0.
    b1 = (d10 - d00) * dx + (d01 - d00) * dy + k * (fx0 * dy + fy0 * dx)
    s_m = -(sign - b1) / (2.0 * a2)
    if s_m > s_a and s_m < s_b:
        return s_m
    return -1.0


@njit(cache=CACHE, fastmath=FASTMATH)
def _trace_one(depth, x0, y0, dx, dy, tol_s):
    """First s in [0, 1] where the ray (x0 + s·dx, y0 + s·dy, s) reaches the surface."""
    ix = math.floor(x0)
    iy = math.floor(y0)
    step_x = 1 if dx > 0 else -1
    step_y = 1 if dy > 0 else -1
    s_a = 0.0
    for _ in range(1 << 20):
        if dx > 0:
            sx = (ix + 1 - x0) / dx
        elif dx < 0:
            sx = (ix - x0) / dx
        else:
            sx = 2.0
        if dy > 0:
            sy = (iy + 1 - y0) / dy
        elif dy < 0:
            sy = (iy - y0) / dy
        else:
            sy = 2.0
        s_b = min(sx, sy, 1.0)
        if s_b < s_a:
            s_b = s_a
        d00, d10, d01, d11 = _corners(depth, ix, iy)
        f_a = _cell_f(s_a, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, 1.0)
        if f_a >= 0.0:
            return s_a
        s_m = _extremum(s_a, s_b, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, 1.0)
        # Monotone pieces in order: [s_a, s_m], [s_m, s_b].
        lo = s_a
        for piece in range(2):
            if piece == 0:
                hi = s_m if s_m > 0.0 else s_b
            else:
                if s_m <= 0.0:
                    break
                hi = s_b
            f_hi = _cell_f(hi, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, 1.0)
            if f_hi >= 0.0:
                a = lo
                b = hi
                while b - a > tol_s:
                    mid = 0.5 * (a + b)
                    if _cell_f(mid, x0, y0, dx, dy, ix, iy, d00, d10, d01, d11, 1.0) >= 0.0:
                        b = mid
                    else:
                        a = mid
                return 0.5 * (a + b)
            lo = hi
        if s_b >= 1.0:
            return 1.0
        if sx <= sy:
            ix += step_x
        else:
            iy += step_y
        s_a = s_b
    return 1.0


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _trace_kernel(depth, x0, y0, dx, dy, out_s):
    n = x0.shape[0]
    for i in prange(n):
        if not (math.isfinite(x0[i]) and math.isfinite(dx[i])):
            out_s[i] = np.nan
            continue
        horiz = math.sqrt(dx[i] * dx[i] + dy[i] * dy[i])
        # Bisection stops at 1e-5 texel along the ray (and 1e-7 in depth).
        tol = 1e-5 / max(horiz, 100.0)
        out_s[i] = _trace_one(depth, x0[i], y0[i], dx[i], dy[i], tol)


@njit(cache=CACHE, fastmath=FASTMATH)
def _shadow_one(depth, x0, y0, s0, lx, ly, eps):
    """True if the light ray from (x0, y0, s0) going up (depth s0 − t, xy + t·l) passes
    under the surface for some t in (eps, s0]."""
    if s0 <= eps:
        return False
    # Parametrise by t (depth decrease): g(t) = (s0 − t) − depth(xy(t)); shadow iff g > 0.
    xs = x0 + eps * lx
    ys = y0 + eps * ly
    ix = math.floor(xs)
    iy = math.floor(ys)
    step_x = 1 if lx > 0 else -1
    step_y = 1 if ly > 0 else -1
    t_a = eps
    t_end = s0
    for _ in range(1 << 20):
        if lx > 0:
            tx = (ix + 1 - x0) / lx
        elif lx < 0:
            tx = (ix - x0) / lx
        else:
            tx = 1e30
        if ly > 0:
            ty = (iy + 1 - y0) / ly
        elif ly < 0:
            ty = (iy - y0) / ly
        else:
            ty = 1e30
        t_b = min(tx, ty, t_end)
        if t_b < t_a:
            t_b = t_a
        d00, d10, d01, d11 = _corners(depth, ix, iy)
        # g(t) = s0 − t − B = −(t − s0) − B: write it as sign = −1 with an offset.
        g_a = s0 + _cell_f(t_a, x0, y0, lx, ly, ix, iy, d00, d10, d01, d11, -1.0)
        g_b = s0 + _cell_f(t_b, x0, y0, lx, ly, ix, iy, d00, d10, d01, d11, -1.0)
        if g_a > 1e-6 or g_b > 1e-6:
            return True
        t_m = _extremum(t_a, t_b, x0, y0, lx, ly, ix, iy, d00, d10, d01, d11, -1.0)
        if t_m > 0.0:
            g_m = s0 + _cell_f(t_m, x0, y0, lx, ly, ix, iy, d00, d10, d01, d11, -1.0)
            if g_m > 1e-6:
                return True
        if t_b >= t_end:
            return False
        if tx <= ty:
            ix += step_x
        else:
            iy += step_y
        t_a = t_b
    return False


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _shadow_kernel(depth, x, y, s, lx, ly, eps, out):
    n = x.shape[0]
    for i in prange(n):
        if not (math.isfinite(x[i]) and math.isfinite(s[i])):
            out[i] = 0
            continue
        out[i] = 1 if _shadow_one(depth, x[i], y[i], s[i], lx[i], ly[i], eps) else 0


# ----------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------


def heights_to_depth(heights) -> np.ndarray:
    """Normalised depth ``1 - h`` (float64) of a height texture with values in [0, 1]."""
    h = as_height_array(heights, name="relief heights")
    if h.min() < 0.0 or h.max() > 1.0:
        raise InvalidParameterError(
            f"relief heights must lie in [0, 1], got [{h.min():.4g}, {h.max():.4g}]"
        )
    return 1.0 - h.astype(np.float64)


def trace_exact(heights, uv0, ds) -> tuple[np.ndarray, np.ndarray]:
    """Exact first intersection of rays ``uv0 + s·ds`` (s = depth ∈ [0, 1]) with the field.

    Parameters
    ----------
    heights
        ``(rows, cols)`` heights in [0, 1] (depth = 1 − h), sampled bilinear + periodic.
    uv0
        ``(..., 2)`` texture coordinates where the rays enter the polygon (NaN = no ray).
    ds
        ``(..., 2)`` UV offset per unit depth (same shape).

    Returns
    -------
    uv : numpy.ndarray
        ``(..., 2)`` hit texture coordinates (not wrapped: ``uv0 + s·ds``).
    s : numpy.ndarray
        ``(...)`` hit depth in [0, 1]; NaN where ``uv0`` is NaN.
    """
    depth = heights_to_depth(heights)
    rows, cols = depth.shape
    uv0 = np.asarray(uv0, dtype=np.float64)
    ds = np.asarray(ds, dtype=np.float64)
    if uv0.shape != ds.shape or uv0.shape[-1] != 2:
        raise InvalidParameterError(
            f"uv0 and ds must both have shape (..., 2), got {uv0.shape} and {ds.shape}"
        )
    flat_uv = uv0.reshape(-1, 2)
    flat_ds = ds.reshape(-1, 2)
    x0 = np.ascontiguousarray(flat_uv[:, 0] * cols - 0.5)
    y0 = np.ascontiguousarray(flat_uv[:, 1] * rows - 0.5)
    dx = np.ascontiguousarray(flat_ds[:, 0] * cols)
    dy = np.ascontiguousarray(flat_ds[:, 1] * rows)
    s = np.empty(x0.shape[0])
    _trace_kernel(depth, x0, y0, dx, dy, s)
    uv = flat_uv + s[:, None] * flat_ds
    return uv.reshape(uv0.shape), s.reshape(uv0.shape[:-1])


def shadow_exact(heights, uv, s, light_ds) -> np.ndarray:
    """Exact self-shadowing: does the light ray from each hit point pass under the surface?

    Parameters
    ----------
    heights
        ``(rows, cols)`` heights in [0, 1].
    uv, s
        Hit points ``(..., 2)`` and their depths ``(...)``.
    light_ds
        ``(..., 2)`` or ``(2,)``: UV offset per unit of depth *decrease* toward the light
        (see :func:`light_slope`).

    Returns
    -------
    numpy.ndarray
        bool ``(...)``: True where the point is in shadow (False where ``s`` is NaN).
    """
    depth = heights_to_depth(heights)
    rows, cols = depth.shape
    uv = np.asarray(uv, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    lds = np.broadcast_to(np.asarray(light_ds, dtype=np.float64), uv.shape)
    flat_uv = uv.reshape(-1, 2)
    flat_l = lds.reshape(-1, 2)
    x = np.ascontiguousarray(flat_uv[:, 0] * cols - 0.5)
    y = np.ascontiguousarray(flat_uv[:, 1] * rows - 0.5)
    lx = np.ascontiguousarray(flat_l[:, 0] * cols)
    ly = np.ascontiguousarray(flat_l[:, 1] * rows)
    out = np.empty(x.shape[0], dtype=np.uint8)
    # Start 1e-3 texel-equivalents up the light ray so the hit point does not shadow itself.
    _shadow_kernel(depth, x, y, np.ascontiguousarray(s.reshape(-1)), lx, ly, 1e-4, out)
    return out.reshape(s.shape).astype(bool)


def light_slope(quad: ReliefQuad, eye, light_dir) -> np.ndarray:
    """UV offset per unit depth *decrease* toward a directional light (world vector toward
    the light). Raises if the light is below the polygon (everything would be in shadow)."""
    m_inv = quad.world_to_uvd(eye)
    luvd = m_inv @ _vec3(light_dir, "light direction")
    if luvd[2] >= 0:
        raise InvalidParameterError(
            "the light must be above the relief face the camera sees, got a direction "
            f"{tuple(light_dir)} below it"
        )
    return luvd[:2] / -luvd[2]


@dataclass(frozen=True)
class ReferenceImage:
    """Per-pixel exact result (arrays ``(H, W)``; row 0 = bottom; NaN where no quad)."""

    uv0: np.ndarray
    ds: np.ndarray
    uv: np.ndarray
    depth: np.ndarray
    valid: np.ndarray
    shadow: np.ndarray | None = None


def reference_image(
    heights, quad: ReliefQuad, camera, width: int, height: int, *, light_dir=None
) -> ReferenceImage:
    """Exact hit UV (and optionally shadow) for every pixel of a ``width × height`` view.

    Examples
    --------
    >>> from terrascape.camera import Camera
    >>> import numpy as np
    >>> cam = Camera.look_at((0, 2, 0.001), (0, 0, 0), aspect=1.0)
    >>> ref = reference_image(np.ones((8, 8)), ReliefQuad(), cam, 4, 4)
    >>> bool(np.allclose(ref.depth[ref.valid], 0.0))
    True
    """
    uv0, ds, valid = quad_entry(quad, camera, width, height)
    uv, s = trace_exact(heights, uv0, ds)
    shadow = None
    if light_dir is not None:
        lds = light_slope(quad, camera.eye, light_dir)
        shadow = shadow_exact(heights, uv, s, lds) & valid
    return ReferenceImage(uv0, ds, uv, s, valid, shadow)


__all__ = [
    "ReferenceImage",
    "ReliefQuad",
    "heights_to_depth",
    "light_slope",
    "pixel_rays",
    "quad_entry",
    "reference_image",
    "shadow_exact",
    "trace_exact",
]
