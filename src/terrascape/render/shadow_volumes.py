"""Sun shadows of objects by stencil shadow volumes, the renderer's ``object_shadows =
"volumes"`` mode (the Doom 3 technique).

After the frame's surfaces are drawn (depth and lit colour), the shadow volumes of every
object (:func:`terrascape.objects.silhouette.shadow_volume`) are drawn into the stencil
buffer with z-fail counting (:func:`terrascape.render.stencil.zfail_counting`): the count
left at a pixel is the number of volumes its surface point lies in. The surfaces are then
drawn again, with the same program, only where the count is not zero and with the sun's
light switched off (its irradiance and the diffuse and specular terms of Phong lighting set
to 0), so sky light and bounce light remain. Whatever the scene's program shades — terrain
of any technique, objects — is shadowed this way without code of its own, and the sun can
move freely: the volumes are rebuilt on the CPU when it does. Volumes are built only for
the casters whose shadow can reach the view (shadow caster culling,
:func:`terrascape.objects.silhouette.casters_in_view`), which leaves the count unchanged.

A frame with volumes is drawn with Everitt & Kilgard's infinite far plane
(:attr:`terrascape.camera.Camera.infinite_far`): the volumes' points at infinity (w = 0)
land just inside the depth range, so no part of a volume is clipped by a far plane, and
the scene's surfaces use the same depth mapping the volumes are tested against.
GL_DEPTH_CLAMP stays on during the count as a belt to those braces.

References
----------
Everitt, C. & Kilgard, M. J. (2002). Practical and robust stenciled shadow volumes for
hardware-accelerated rendering. NVIDIA technical report (arXiv:cs/0301002).

Heidmann, T. (1991). Real shadows, real time. *Iris Universe* 18, 28-31.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.objects.model import Instances
from terrascape.objects.silhouette import casters_in_view, shadow_volume
from terrascape.render.objects import OBJECT_SHADOW_MODES, ObjectShadowFallbackWarning
from terrascape.render.shaders import load_program, set_uniforms
from terrascape.render.stencil import (
    clear_stencil,
    read_stencil,
    stencil_bits,
    stencil_replace,
    stencil_test,
    zfail_counting,
)

# The mode "volumes" falls back to when the target has no stencil buffer (or no PyOpenGL).
FALLBACK_MODE = "cascades"
# Uniform values that switch the sun's light off in every lighting model of the shaders
# (daylight: the sun's irradiance; Phong: its diffuse and specular terms; the lightmap and
# unlit modes: u_sun_blocked, common/lighting.glsl).
SUN_OFF = {"u_sun_irradiance": (0.0, 0.0, 0.0), "u_kd": 0.0, "u_ks": 0.0, "u_sun_blocked": 1}
# How far the silhouettes are extruded (ShadowVolumes.reach). "floor" by default: the same
# count as to infinity (z-fail needs points at infinity only where a far cap could be
# clipped; this one lies below every drawn surface, and a camera down there gets the
# infinite volumes), far less fill (terrascape bench shadows, docs/benchmarks.md).
VOLUME_REACH = ("floor", "infinite")
DEFAULT_REACH = "floor"
# Polygon offset (depth units) that pushes the volumes' near caps behind the sunlit faces
# they lie on (see terrascape.render.stencil.zfail_counting).
VOLUME_DEPTH_OFFSET = 2.0


class ShadowVolumeFallbackWarning(ObjectShadowFallbackWarning):
    """Stencil shadow volumes cannot run on this target; shadow maps are used instead."""


def object_shadow_mode(renderer, fbo, params: Mapping[str, Any]) -> dict[str, Any]:
    """``params`` with ``object_shadows`` checked; ``"volumes"`` on a target without a
    stencil buffer (or without PyOpenGL) becomes the shadow-map mode, with one warning per
    renderer."""
    p = dict(params)
    mode = p.get("object_shadows")
    if mode is not None and mode not in OBJECT_SHADOW_MODES:
        raise InvalidParameterError(
            f"object_shadows must be one of {', '.join(OBJECT_SHADOW_MODES)}, got {mode!r}")
    if mode != "volumes" or stencil_bits(fbo) > 0:
        return p
    fallen = renderer.__dict__.setdefault("_fallen_back", set())
    if "object_shadows=volumes" not in fallen:
        fallen.add("object_shadows=volumes")
        warnings.warn(
            "shadow volumes need a stencil buffer (and PyOpenGL), which this render target "
            f"does not have; object shadows use shadow maps ({FALLBACK_MODE!r}) instead",
            ShadowVolumeFallbackWarning, stacklevel=3)
    p["object_shadows"] = FALLBACK_MODE
    return p


class ShadowVolumes:
    """GL side of the volumes: the program, a vertex buffer of volume triangles and the
    stencil count. One per renderer (``ShadowVolumes.of(renderer)``)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = load_program(ctx, "shadow/volume")
        self._buffer = None
        self._capacity = 0
        self._vao = None
        self._count = 0
        self._key: Any = None
        self.build_seconds = 0.0  # CPU time of the last rebuild (silhouettes + upload)
        # keep_count: read the stencil count back after counting (tests, benchmarks)
        self.keep_count = False
        self.last_count: np.ndarray | None = None
        # cull: build volumes only for casters whose shadow can reach the view
        # (silhouette.casters_in_view); off for comparisons
        self.cull = True
        # reach: "floor" extrudes the silhouettes down to just below the lowest drawn
        # surface (silhouette.shadow_volume with a floor: the same count, far less fill), "infinite"
        # to points at infinity (Everitt & Kilgard's volumes, drawn with the infinite far
        # plane)
        self.reach = DEFAULT_REACH
        # the last rebuild's array, written into again by the next (a moving sun rebuilds
        # every frame; allocating and first touching tens of megabytes each time is waste)
        self._scratch: np.ndarray | None = None

    @classmethod
    def of(cls, renderer) -> ShadowVolumes:
        have = renderer.__dict__.get("_shadow_volumes")
        if have is None:
            have = renderer.__dict__["_shadow_volumes"] = cls(renderer.ctx)
        return have

    def set_triangles(self, triangles: np.ndarray, key: Any = None) -> int:
        """Upload float32 ``(M, 3, 4)`` volume triangles (kept until the next call); returns M."""
        import time

        t0 = time.perf_counter()
        tri = np.ascontiguousarray(triangles, dtype=np.float32)
        if tri.ndim != 3 or tri.shape[1:] != (3, 4):
            raise InvalidParameterError(f"volume triangles must be (M, 3, 4), got {tri.shape}")
        nbytes = tri.nbytes
        if nbytes > self._capacity:
            if self._buffer is not None:
                self._vao.release()
                self._buffer.release()
            self._capacity = max(nbytes + nbytes // 4, 48)
            self._buffer = self.ctx.buffer(reserve=self._capacity, dynamic=True)
            self._vao = self.ctx.vertex_array(self.program, [(self._buffer, "4f", "in_position")])
        if nbytes:
            # the array itself (buffer protocol): a bytes copy of tens of megabytes would
            # cost as much as the upload
            self._buffer.write(tri)
        self._count = len(tri)
        self._key = key
        self.build_seconds += time.perf_counter() - t0
        return self._count

    def set_casters(self, casters: Instances | None, sun_dir,
                    keep: np.ndarray | None = None, floor: float | None = None) -> int:
        """Volumes of ``casters`` (those ``keep`` marks: :func:`casters_in_view`) for the sun
        toward ``sun_dir``, extruded to infinity or, with ``floor``, down to that height
        (:func:`shadow_volume`); rebuilt only when any of these changed. Returns the number
        of volume triangles."""
        import time

        d = tuple(float(v) for v in np.asarray(sun_dir, np.float64).reshape(3))
        kept = None if keep is None else np.asarray(keep, bool).tobytes()
        key = (casters, 0 if casters is None else len(casters), d, kept, floor)
        if key == self._key:
            return self._count
        self.build_seconds = 0.0
        t0 = time.perf_counter()
        if casters is None or not len(casters):
            tri = np.zeros((0, 3, 4), np.float32)
        else:
            tri = shadow_volume(casters, d, keep, floor, out=self._scratch)
            self._scratch = tri if tri.base is None else tri.base
        self.build_seconds = time.perf_counter() - t0
        return self.set_triangles(tri, key)

    def count(self, fbo, view_proj: np.ndarray, *, depth_offset: float | None = None,
              depth_clamp: bool = True) -> None:
        """Clear ``fbo``'s stencil and count the uploaded volumes into it (z-fail) against
        the depth already in ``fbo`` (drawn with ``view_proj``)."""
        import moderngl

        clear_stencil(fbo)
        if not self._count:
            return
        set_uniforms(self.program, u_view_proj=view_proj)
        offset = VOLUME_DEPTH_OFFSET if depth_offset is None else depth_offset
        with zfail_counting(self.ctx, fbo, depth_offset=offset, depth_clamp=depth_clamp):
            self._vao.render(moderngl.TRIANGLES, vertices=3 * self._count)

    def release(self) -> None:
        if self._buffer is not None:
            self._vao.release()
            self._buffer.release()
            self._buffer = self._vao = None
            self._capacity = self._count = 0
        self._scratch = None
        self._key = None


def shade_shadow_volumes(renderer, fbo, camera, uniforms: Mapping[str, Any], *, program,
                         deferred: bool, plan) -> dict[str, int]:
    """The volumes mode of one frame, after its terrain and objects were drawn into
    ``fbo``: count the objects' volumes into the stencil, then draw the surfaces again
    without the sun where the count is not zero.

    ``program`` drew the terrain: forward, the technique's program (drawn again with
    ``plan``); ``deferred``, its full-screen shading pass over the geometry buffer. That pass
    cannot tell terrain from the objects in front of it, so the objects' pixels are taken
    out of the stencil (set to 0 under their own depth) before it runs.
    """
    import moderngl

    if stencil_bits(fbo) == 0:
        raise GLUnavailableError("shadow volumes need a render target with a stencil buffer")
    ctx = renderer.ctx
    volumes = ShadowVolumes.of(renderer)
    sun = np.asarray(uniforms["u_sun_dir"], np.float64)
    objects = renderer.objects
    casters = objects.instances if objects is not None else None
    if casters is not None and sun[1] > 0.0:
        keep = (casters_in_view(casters, camera.frustum_planes(), sun,
                                renderer.lowest_surface_height())
                if volumes.cull else np.ones(len(casters), bool))
    else:
        casters, keep = None, np.zeros(0, bool)
    floor = renderer.lowest_surface_height()
    if volumes.reach not in VOLUME_REACH:
        raise InvalidParameterError(
            f"volume reach must be one of {', '.join(VOLUME_REACH)}, got {volumes.reach!r}")
    # the cut lies a little below the lowest surface, never on a drawn one; z-fail needs
    # the far caps outside the near plane, so a camera down at the cut's height (its near
    # plane's corners within near · √(1 + tan²x + tan²y) of the eye) gets the volumes to
    # infinity
    cut = floor - 0.01 * max(renderer.mesh.extent) if volumes.reach == "floor" else None
    if cut is not None:
        tan_y = math.tan(math.radians(camera.fov_y) / 2.0)
        corner = camera.near * math.sqrt(1.0 + tan_y * tan_y * (1.0 + camera.aspect ** 2))
        if float(camera.eye[1]) - corner <= cut:
            cut = None
    n = volumes.set_casters(casters, sun, keep if casters is not None else None, cut)
    volumes.count(fbo, uniforms["u_view_proj"])
    volumes.last_count = read_stencil(fbo) if volumes.keep_count else None
    stats = {"shadow_volume_triangles": n, "shadow_volume_casters": int(keep.sum()),
             "shadow_volume_culled": int((~keep).sum())}
    if n == 0:
        return stats
    dark = {**uniforms, **SUN_OFF}
    saved = {k: uniforms[k] for k in SUN_OFF if k in uniforms}
    fbo.depth_mask = False
    fbo.use()
    try:
        ctx.depth_func = "<="
        if objects is not None:
            with stencil_test(nonzero=True):
                # not the impostors: a quad through the middle of its object lies inside
                # the object's own volume, and would be drawn all in shadow; they keep their
                # baked normals' shading and the terrain's shadow
                objects.draw(dark, impostors=False)
            if deferred:
                with stencil_replace(0):
                    fbo.color_mask = (False, False, False, False)
                    fbo.use()
                    try:
                        objects.draw(uniforms)
                    finally:
                        fbo.color_mask = (True, True, True, True)
                        fbo.use()
        set_uniforms(program, **SUN_OFF)
        with stencil_test(nonzero=True):
            if deferred:
                # the shading pass as drawn: at depth 1 where the terrain's depth is nearer
                ctx.disable(moderngl.CULL_FACE)
                ctx.depth_func = ">"
                renderer._fullscreen(program)
            else:
                ctx.enable(moderngl.CULL_FACE)
                renderer._draw_geometry(program, camera, fbo.size, plan)
    finally:
        set_uniforms(program, **saved)
        ctx.depth_func = "<"
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        fbo.depth_mask = True
        fbo.use()
    return stats


__all__ = [
    "FALLBACK_MODE",
    "SUN_OFF",
    "ShadowVolumeFallbackWarning",
    "ShadowVolumes",
    "object_shadow_mode",
    "shade_shadow_volumes",
]
