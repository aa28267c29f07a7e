"""Deferred shading of the terrain: the surface attributes into a geometry buffer first, then
a technique's shading once per terrain pixel in a full-screen pass.

A software rasteriser (llvmpipe) shades pixels in SIMD vectors per triangle: a frame of
sub-pixel triangles wastes most lanes, and hidden surfaces are shaded too. Shaded from a
geometry buffer, every lane is a visible pixel. :class:`~terrascape.render.terrain.
TerrainRenderer` uses it for techniques marked ``deferred`` (heavy per-pixel shading: layer
blending, relief marches) when its ``deferred_shading`` is on.

The technique's own program is compiled a second time with ``#define DEFERRED 1``
(``common/terrain_fragment.glsl`` then reads the interpolated attributes from the geometry
buffer's textures instead of the vertex stage), so forward and deferred frames run the same
shading code on the same float32 values.

References
----------
- T. Saito and T. Takahashi, "Comprehensible rendering of 3-D shapes", SIGGRAPH 1990 (the
  geometry buffer).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from terrascape.errors import GLUnavailableError
from terrascape.render.shaders import load_program, set_uniforms
from terrascape.render.techniques import Technique

#: Texture units of the geometry buffer in the shading pass (below the renderer's spare
#: units, above the daylight look's).
GBUFFER_UNIT = 12
#: Texture types of the geometry buffer's attachments: world position, normal, tangent.
GBUFFER_DTYPES = ("f4", "f2", "f2")
#: Geometry buffers kept, one per target size (the viewer draws two: full and scaled).
KEPT_GBUFFERS = 2


class DeferredShading:
    """The geometry buffer of one context (resized with the target) and its passes."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        #: float16 normal and tangent, only the world position and depth cleared; False:
        #: every attachment float32 and cleared (``terrascape bench terrain_shading``)
        self.light_gbuffer = True
        # (fbo, textures, clear fbo) per target size, the last used last: two kept, so
        # the viewer's full-size and smaller moving frames do not reallocate at every
        # start and stop of the camera
        self._gbuffers: dict[tuple, tuple] = {}
        self._fullscreen_vaos: dict[int, Any] = {}

    def shading_program(self, technique: Technique, defines: dict | None = None):
        """The technique's shading as a full-screen pass over the geometry buffer, or None
        when this GL cannot build it (the frame is then drawn forward). ``defines``: the
        frame's program defines (default: the technique's own)."""
        defines = {**(technique.defines if defines is None else defines or {}), "DEFERRED": 1}
        try:
            return load_program(self.ctx, technique.program, defines)
        except GLUnavailableError:
            return None

    def _gbuffer_for(self, size):
        import moderngl

        key = (tuple(size), self.light_gbuffer)
        if key in self._gbuffers:
            self._gbuffers[key] = self._gbuffers.pop(key)  # the most recently used
            return self._gbuffers[key]
        while len(self._gbuffers) >= KEPT_GBUFFERS:
            self._release_gbuffer(next(iter(self._gbuffers)))
        ctx = self.ctx
        # World positions as float32 (the shading pass sees the values forward shading
        # interpolates); the normal and the tangent frame as float16 (unit vectors: 2⁻¹¹
        # relative, far below a display level), two thirds of the bytes written and read.
        dtypes = GBUFFER_DTYPES if self.light_gbuffer else ("f4",) * len(GBUFFER_DTYPES)
        colours = [ctx.texture(size, 4, dtype=dtype) for dtype in dtypes]
        depth = ctx.depth_texture(size)
        for tex in [*colours, depth]:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        fbo = ctx.framebuffer(color_attachments=colours, depth_attachment=depth)
        # Cleared per frame: only what is read where no terrain was drawn — the world
        # position's w (0: no terrain, common/terrain_fragment.glsl) and the depth. Every
        # terrain pixel overwrites the normal and tangent, and pixels without terrain never
        # read them for their own colour (the depth test rejects it).
        clear = (ctx.framebuffer(color_attachments=colours[:1], depth_attachment=depth)
                 if self.light_gbuffer else fbo)
        self._gbuffers[key] = (fbo, [*colours, depth], clear)
        return self._gbuffers[key]

    def _release_gbuffer(self, key) -> None:
        fbo, textures, clear = self._gbuffers.pop(key)
        if clear is not fbo:
            clear.release()
        fbo.release()
        for tex in textures:
            tex.release()

    def draw(self, fbo, shading, view_proj,
             draw_geometry: Callable[[Any], dict[str, int]]) -> dict[str, int]:
        """One deferred frame into ``fbo``.

        ``shading`` (from :meth:`shading_program`) already holds the frame's uniforms and
        samplers; ``draw_geometry(program)`` draws the terrain's triangles with a program
        and returns its statistics (the renderer's chunks, culling and skirts).
        """
        import moderngl

        ctx = self.ctx
        tangents = "u_gbuffer_tangent" in shading
        geometry = load_program(ctx, "terrain/gbuffer",
                                {"TERRAIN_TANGENTS": 1} if tangents else None)
        gbuf, (world, normal, tangent, depth), clear = self._gbuffer_for(fbo.size)
        # --- PASS 1: surface attributes of the nearest terrain per pixel
        clear.use()
        clear.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        gbuf.use()
        set_uniforms(geometry, u_view_proj=view_proj)
        stats = draw_geometry(geometry)
        # --- PASS 2: the geometry pass's depth into the target (colour masked off)
        fbo.use()
        ctx.disable(moderngl.CULL_FACE)
        copy = load_program(ctx, "terrain/gbuffer_depth")
        depth.use(location=GBUFFER_UNIT)
        copy["u_gbuffer_depth"].value = GBUFFER_UNIT
        ctx.depth_func = "1"
        fbo.color_mask = (False, False, False, False)
        fbo.use()  # moderngl applies a colour mask when the framebuffer is bound
        try:
            self.fullscreen(copy)
        finally:
            fbo.color_mask = (True, True, True, True)
            fbo.use()
        # --- PASS 3: the technique's shading, once per terrain pixel: drawn at depth 1 with
        # GL_GREATER and no depth writes, so sky pixels fail the early depth test
        units = {"u_gbuffer_world": world, "u_gbuffer_normal": normal,
                 "u_gbuffer_tangent": tangent}
        for unit, (name, tex) in enumerate(units.items(), start=GBUFFER_UNIT):
            if name in shading:
                tex.use(location=unit)
                shading[name].value = unit
        ctx.depth_func = ">"
        fbo.depth_mask = False
        try:
            self.fullscreen(shading)
        finally:
            fbo.depth_mask = True
            ctx.depth_func = "<"
        ctx.enable(moderngl.CULL_FACE)
        stats["deferred"] = 1
        return stats

    def fullscreen(self, program) -> None:
        """Draw one full-screen triangle with ``program`` (its vertex stage makes it)."""
        import moderngl

        vao = self._fullscreen_vaos.get(program.glo)
        if vao is None:
            vao = self._fullscreen_vaos[program.glo] = self.ctx.vertex_array(program, [])
        vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        for vao in self._fullscreen_vaos.values():
            vao.release()
        self._fullscreen_vaos.clear()
        for key in list(self._gbuffers):
            self._release_gbuffer(key)


__all__ = ["GBUFFER_DTYPES", "GBUFFER_UNIT", "DeferredShading"]
