"""Render one relief-textured quad with any relief technique — the measurement renderer.

Every technique of Janković 2010 (§2.3–2.4: parallax, offset limiting, steep parallax, parallax
occlusion, relief, interval) and the two beyond it (cone step mapping, the exact min/max-mip
tracer) is the same program ``relief/quad.glsl`` compiled with ``#define TECHNIQUE n``. The
quad and the camera use the geometry of :mod:`terrascape.relief.reference`, so the hit
coordinates the shader writes (``output="hit"``: RGBA32F = hit u, hit v, hit depth,
texture fetches) compare pixel by pixel with the exact CPU reference.

If a technique's program fails to compile (or the GL lacks what it needs), the renderer
draws plain texturing instead, said once (:func:`terrascape.render.techniques.
choose_drawable`, the terrain renderer's decision too); :attr:`ReliefQuadRenderer.
drawn_technique` says which technique drew.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from terrascape._validate import check_int, check_positive
from terrascape.errors import InvalidParameterError
from terrascape.relief.fields import has_walls, sampled_heights
from terrascape.relief.reference import ReliefQuad, heights_to_depth
from terrascape.render.context import with_current_context
from terrascape.render.techniques import (
    RELIEF_TRACERS,
    TechniqueFallbackWarning,
    choose_drawable,
)

#: The relief tracers and their ids in the GLSL (``#define TECHNIQUE <id>``).
TECHNIQUES: dict[str, int] = RELIEF_TRACERS
# "auto" is not a shader technique: the renderer resolves it per texture (choose_technique).
AUTO = "auto"
OUTPUTS = {"colour": 0, "hit": 1, "shadow": 2}
MARCHES = {"fixed": 0, "angle": 1, "clearance": 2}  # u_adaptive
LINEAR_STEPS = 16  # ReliefSettings(linear_steps=None): the thesis's count (§2.4.7)
WALL_LINEAR_STEPS = 32  # ... for the clearance march over a field with walls
PROGRAM = "relief/quad"


class ReliefFallbackWarning(TechniqueFallbackWarning):
    """A relief technique could not be used; plain texturing is rendered instead."""


@dataclass(frozen=True)
class ReliefSettings:
    """Run-time parameters (uniforms) of the relief techniques.

    ``parallax_scale``/``parallax_bias`` default to ``depth``/``-depth``: the polygon is the
    top of the relief, as for the ray-marched techniques (so all are comparable).

    Where relief mapping's linear search puts its samples (``march``; Policarpo et al. 2005
    march equal steps, Janković 2010 §2.4.7):

    * ``"fixed"``: ``linear_steps`` equal steps from depth 0 to 1 (the thesis's relief 16+8
      with ``binary_steps=8``);
    * ``"angle"``: equal steps of ``step_texels`` texels of the ray's
      length, ``linear_steps`` … ``max_steps`` of them;
    * ``"clearance"`` (the default): at a sample the ray is ``g`` above the surface; the next
      step is ``g / (1 + clearance_slope · L)`` in depth (``L`` = ray length in texels from
      depth 0 to 1), the distance a surface of that slope (depth per texel) needs to reach
      the ray — the sphere-tracing bound with a typical rather than maximal slope — clamped
      to ``[min_step_texels texels, 1/linear_steps]``, at most ``max_steps`` steps. Long
      steps where the ray is far above the surface, short ones where it grazes crests, which
      equal steps skip. Then ``binary_steps`` binary steps as always.

    ``linear_steps=None`` (the default) is 16, except for the clearance march over a height
    field with walls (:func:`terrascape.relief.fields.has_walls`: neighbouring texels
    ``WALL_STEP`` or more of the depth range apart), where it is ``WALL_LINEAR_STEPS`` (32):
    a wall can be one texel thin, and the clearance next to it says nothing about it, so
    the longest step is halved (a denser search where the field needs it, the 16-step
    search where it does not; measured in ``terrascape bench relief``).

    Steep parallax, POM and interval mapping use equal steps (``"clearance"`` counts as
    ``"fixed"`` for them).
    """

    linear_steps: int | None = None
    binary_steps: int = 4
    step_texels: float = 2.0
    max_steps: int = 128
    march: str = "clearance"
    clearance_slope: float = 0.025
    min_step_texels: float = 1.5
    cone_steps: int = 32
    shadow_steps: int = 16
    shadow_step_texels: float = 1.0
    shadows: bool = False
    parallax_scale: float | None = None
    parallax_bias: float | None = None
    max_iterations: int = 1024
    dist_relief: float = 5.0
    dist_parallax: float = 20.0
    dist_band: float = 2.0

    def __post_init__(self) -> None:
        for name in ("linear_steps", "max_steps", "cone_steps", "shadow_steps"):
            if name == "linear_steps" and self.linear_steps is None:
                continue
            check_int(getattr(self, name), name, minimum=1, maximum=4096)
        check_int(self.binary_steps, "binary_steps", minimum=0, maximum=64)
        check_int(self.max_iterations, "max_iterations", minimum=1, maximum=1 << 20)
        check_positive(self.step_texels, "step_texels")
        check_positive(self.dist_band, "dist_band")
        if self.march not in MARCHES:
            raise InvalidParameterError(
                f"march must be one of {', '.join(MARCHES)}, got {self.march!r}")
        if not self.clearance_slope >= 0.0:
            raise InvalidParameterError(
                f"clearance_slope must be >= 0, got {self.clearance_slope!r}")
        check_positive(self.min_step_texels, "min_step_texels")
        check_positive(self.shadow_step_texels, "shadow_step_texels")

    def resolved_linear_steps(self, *, walls: bool = False) -> int:
        """The linear step count the shaders get: ``linear_steps``, or where it is ``None``
        16, or ``WALL_LINEAR_STEPS`` for the clearance march over a field with walls."""
        if self.linear_steps is not None:
            return self.linear_steps
        return WALL_LINEAR_STEPS if walls and self.march == "clearance" else LINEAR_STEPS

    def uniforms(self, depth: float, *, walls: bool = False) -> dict:
        """Uniform values; ``walls``: the height field has walls (``has_walls``)."""
        scale = depth if self.parallax_scale is None else self.parallax_scale
        bias = -scale if self.parallax_bias is None else self.parallax_bias
        return {
            "u_depth": depth,
            "u_parallax_scale": scale,
            "u_parallax_bias": bias,
            "u_linear_steps": self.resolved_linear_steps(walls=walls),
            "u_binary_steps": self.binary_steps,
            "u_adaptive": MARCHES[self.march],
            "u_clearance_slope": self.clearance_slope,
            "u_min_step_texels": self.min_step_texels,
            "u_step_texels": self.step_texels,
            "u_max_steps": self.max_steps,
            "u_cone_steps": self.cone_steps,
            "u_shadow_steps": self.shadow_steps,
            "u_shadow_step_texels": self.shadow_step_texels,
            "u_shadows": int(self.shadows),
            "u_max_iterations": self.max_iterations,
            "u_dist_relief": self.dist_relief,
            "u_dist_parallax": self.dist_parallax,
            "u_dist_band": self.dist_band,
        }

    def with_(self, **changes) -> ReliefSettings:
        return replace(self, **changes)


def choose_technique(heights) -> str:
    """The technique that holds on this relief texture: the exact min/max tracer where the
    texture allows it (square, power of two), relief mapping's clearance march otherwise.

    Measured on natural fields at several roughness exponents, cities and one-texel fences
    at 8/16-bit and float precision (``terrascape bench relief``, precision table), the
    clearance march skips thin walls on a third of the pixels at grazing angles and leaves
    up to 4 % of pixels more than a texel off on rough natural fields at 80°; the tracer is
    exact on all of them at 0.8–1.4× relief 16+8's time. Its pyramid needs a square
    power-of-two texture.
    """
    h = np.asarray(heights)
    rows, cols = h.shape[:2]
    if rows == cols and rows & (rows - 1) == 0:
        return "minmax"
    return "relief"


def technique_id(technique: str) -> int:
    if technique not in TECHNIQUES:
        raise InvalidParameterError(
            f"unknown relief technique {technique!r}; expected one of {', '.join(TECHNIQUES)}"
        )
    return TECHNIQUES[technique]


def load_relief_program(ctx, technique: str, *, program: str = PROGRAM, defines=None):
    """Compile ``program`` for ``technique``; on failure warn once and fall back to plain.

    Returns
    -------
    (moderngl.Program, str)
        The program and the technique actually used (``"plain"`` after a fallback).

    Raises
    ------
    GLUnavailableError
        Only if even the plain program cannot be compiled.
    """
    from terrascape.render.shaders import load_program

    technique_id(technique)  # an unknown name is a usage error, not a fallback
    extra = dict(defines or {})

    def build(name: str):
        # the fallback without the defines that exist to make the requested program fail
        own = extra if name == technique else {
            k: v for k, v in extra.items() if k != "RELIEF_FORCE_COMPILE_ERROR"}
        return load_program(ctx, program, {"TECHNIQUE": technique_id(name), **own})

    prog, drawn = choose_drawable(
        ctx, technique, build, fallback="plain", what="relief technique",
        key=(program, technique, tuple(sorted(extra))), category=ReliefFallbackWarning)
    return prog, drawn.name


def relief_texture_data(heights, *, depth: float, bits: int = 32) -> np.ndarray:
    """RGBA ``(rows, cols, 4)`` data of the relief texture: tangent-space normal + height.

    ``bits`` 8 or 16 use :func:`terrascape.lighting.normals.pack_normal_height` (uint8 /
    uint16); 32 keeps float32 (exact heights, used by the quality benchmark).
    """
    from terrascape.lighting.normals import pack_normal_height, tangent_space_normals

    h = 1.0 - heights_to_depth(heights)  # validates [0, 1]
    rows, cols = h.shape
    # Heights span depth·(UV unit) over one texel of 1/cols UV: slope scale depth·cols.
    scale = float(depth) * cols
    if bits in (8, 16):
        return pack_normal_height(h.astype(np.float32), height_scale=scale, bits=bits)
    if bits != 32:
        raise InvalidParameterError(f"bits must be 8, 16 or 32, got {bits!r}")
    n = tangent_space_normals(h.astype(np.float32), height_scale=scale)
    out = np.empty((rows, cols, 4), dtype=np.float32)
    out[..., :3] = n * 0.5 + 0.5
    out[..., 3] = h
    return out


class ReliefQuadRenderer:
    """Off-screen renderer of one :class:`~terrascape.relief.reference.ReliefQuad`.

    Parameters
    ----------
    ctx
        A moderngl context (:func:`terrascape.render.context.create_headless_context`).
    heights
        ``(rows, cols)`` relief heights in [0, 1] (tileable).
    size
        Framebuffer ``(width, height)`` in pixels.
    bits
        Precision of the relief texture: 8, 16 (packed like ``pack_normal_height``) or 32.
    colour
        Optional ``(rows, cols, 3)`` float colour texture in [0, 1].
    """

    @with_current_context
    def __init__(self, ctx, heights, *, size=(256, 256), bits: int = 32, colour=None,
                 depth_hint: float = 0.1):
        import moderngl

        self.ctx = ctx
        # The surface as the texture samples it: the min/max pyramid, the cone map and the
        # wall test are built from these values, so the exact tracer is exact on the
        # surface it shades at every texture precision.
        self.heights = sampled_heights(1.0 - heights_to_depth(heights), bits)
        # Fixed per texture: decides the default linear step count (ReliefSettings).
        self.has_walls = has_walls(self.heights)
        self.auto_technique = choose_technique(self.heights)
        w = check_int(size[0], "framebuffer width", minimum=1, maximum=16384)
        h = check_int(size[1], "framebuffer height", minimum=1, maximum=16384)
        self.size = (w, h)
        self.bits = bits
        self._depth_for_normals = float(depth_hint)
        self._relief_tex = self._make_relief_texture(depth_hint)
        self._colour_tex = None
        if colour is not None:
            c = np.ascontiguousarray(np.asarray(colour, dtype=np.float32)[..., :3])
            if c.shape[:2] != self.heights.shape:
                raise InvalidParameterError(
                    f"colour must be {self.heights.shape} × 3, got {np.shape(colour)}"
                )
            self._colour_tex = ctx.texture(c.shape[1::-1], 3, c.tobytes(), dtype="f4")
            self._colour_tex.repeat_x = self._colour_tex.repeat_y = True
        self._cone_tex = None
        self._minmax_tex = None
        self._minmax_levels = 0
        self._colour_target = ctx.texture(self.size, 4, dtype="f4")
        self._depth_rb = ctx.depth_renderbuffer(self.size)
        self.fbo = ctx.framebuffer([self._colour_target], self._depth_rb)
        self._vbo = ctx.buffer(reserve=4 * 5 * 4)
        self._vaos: dict = {}
        self._moderngl = moderngl
        self.drawn_technique: str | None = None  # what the last draw used (see draw)

    # --- textures -------------------------------------------------------------------------
    def _make_relief_texture(self, depth):
        data = relief_texture_data(self.heights, depth=depth, bits=self.bits)
        dtype = {8: "f1", 16: "nu2", 32: "f4"}[self.bits]
        rows, cols = self.heights.shape
        tex = self.ctx.texture((cols, rows), 4, np.ascontiguousarray(data).tobytes(),
                               dtype=dtype)
        tex.repeat_x = tex.repeat_y = True
        tex.filter = (self._mgl().LINEAR, self._mgl().LINEAR)
        return tex

    @staticmethod
    def _mgl():
        import moderngl

        return moderngl

    def _ensure_cone(self):
        if self._cone_tex is None:
            from terrascape.relief.cone_map import footprint_cone_map

            data = np.ascontiguousarray(footprint_cone_map(self.heights))
            rows, cols = self.heights.shape
            self._cone_tex = self.ctx.texture((cols, rows), 2, data.tobytes(), dtype="f4")
            self._cone_tex.repeat_x = self._cone_tex.repeat_y = True
            mgl = self._mgl()
            self._cone_tex.filter = (mgl.NEAREST, mgl.NEAREST)
        return self._cone_tex

    def _ensure_minmax(self):
        if self._minmax_tex is None:
            from terrascape.relief.minmax_mip import packed_minmax_mip

            # One RGBA chain (level 0 = cell corners): the tracer reads one texel per node
            # (relief/common/heightfield.glsl).
            levels = packed_minmax_mip(self.heights)
            n = levels[0].shape[0]
            tex = self.ctx.texture((n, n), 4, levels[0].tobytes(), dtype="f4")
            tex.build_mipmaps(0, len(levels) - 1)  # allocates the chain; overwritten below
            for k, lv in enumerate(levels[1:], start=1):
                tex.write(np.ascontiguousarray(lv).tobytes(), level=k)
            mgl = self._mgl()
            tex.filter = (mgl.NEAREST_MIPMAP_NEAREST, mgl.NEAREST)
            self._minmax_tex = tex
            self._minmax_levels = len(levels)
        return self._minmax_tex

    # --- rendering ------------------------------------------------------------------------
    def _vao(self, program):
        key = id(program)
        if key not in self._vaos:
            self._vaos[key] = self.ctx.vertex_array(
                program, [(self._vbo, "3f 2f", "in_position", "in_uv")]
            )
        return self._vaos[key]

    @with_current_context
    def render(self, quad: ReliefQuad, camera, technique: str = AUTO, *,
               settings: ReliefSettings | None = None, output: str = "hit",
               light_dir=(0.3, 0.8, 0.2), defines=None) -> np.ndarray:
        """Draw the quad; return the framebuffer as float32 ``(H, W, 4)`` (row 0 = bottom).

        ``technique="auto"`` (the default) draws :func:`choose_technique`'s pick for this
        texture; :attr:`drawn_technique` says which technique drew.

        ``output="hit"``: (u, v, depth, fetches); ``"shadow"``: (shadow, depth, fetches, 1);
        ``"colour"``: shaded RGBA. Pixels off the quad are 0 with alpha 0 — use
        :func:`terrascape.relief.reference.quad_entry`'s mask, or alpha for ``"colour"``.
        """
        if output not in OUTPUTS:
            raise InvalidParameterError(f"output must be one of {list(OUTPUTS)}, got {output!r}")
        settings = settings or ReliefSettings()
        self.draw(quad, camera, technique, settings=settings, output=output,
                  light_dir=light_dir, defines=defines)
        raw = self.fbo.read(components=4, dtype="f4")
        return np.frombuffer(raw, dtype=np.float32).reshape(self.size[1], self.size[0], 4)

    @with_current_context
    def draw(self, quad, camera, technique=AUTO, *, settings=None, output="colour",
             light_dir=(0.3, 0.8, 0.2), defines=None):
        """Draw without reading back (for timing); call ``ctx.finish()`` to wait."""
        from terrascape.render.shaders import set_uniforms

        if technique == AUTO:
            technique = self.auto_technique
        settings = settings or ReliefSettings()
        program, used = load_relief_program(self.ctx, technique, defines=defines)
        self.drawn_technique = used
        if abs(quad.depth - self._depth_for_normals) > 1e-12:
            self._relief_tex.release()
            self._depth_for_normals = quad.depth
            self._relief_tex = self._make_relief_texture(quad.depth)
        eye = camera.eye
        corners = quad.corners()
        su, sv = quad.uv_scale
        uvs = np.array([[0, 0], [su, 0], [su, sv], [0, sv]], dtype=np.float64)
        verts = np.concatenate([corners, uvs], axis=1)[[0, 1, 3, 2]].astype(np.float32)
        self._vbo.write(verts.tobytes())
        a = np.asarray(quad.u_axis)
        b = np.asarray(quad.v_axis)
        n = quad.front_normal(eye)
        to_ts = np.array([a / np.linalg.norm(a), b / np.linalg.norm(b), n])
        set_uniforms(
            program,
            u_mvp=camera.view_projection(),
            u_eye=eye,
            u_world_to_uvd=quad.world_to_uvd(eye),
            u_world_to_ts=to_ts,
            u_light_dir=np.asarray(light_dir, dtype=np.float64),
            u_output=OUTPUTS[output],
            u_has_colour=int(self._colour_tex is not None),
            u_ambient=(0.25, 0.25, 0.25),
            u_diffuse=(0.75, 0.75, 0.75),
            u_specular=(0.15, 0.15, 0.15),
            u_shininess=24.0,
            u_minmax_levels=self._minmax_levels or 1,
            # Only relief mapping marches clearance steps (steep/POM/interval: equal ones).
            **settings.uniforms(quad.depth, walls=self.has_walls and used == "relief"),
        )
        units = {"u_relief": self._relief_tex}
        if used == "cone":
            units["u_cone"] = self._ensure_cone()
        if used == "minmax":
            units["u_minmax"] = self._ensure_minmax()
            set_uniforms(program, u_minmax_levels=self._minmax_levels)
        if self._colour_tex is not None:
            units["u_colour"] = self._colour_tex
        for unit, (name, tex) in enumerate(units.items()):
            tex.use(unit)
            if name in program:
                program[name].value = unit
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        self.ctx.disable(self._mgl().CULL_FACE)
        self._vao(program).render(self._mgl().TRIANGLE_STRIP)

    @property
    def last_technique(self) -> str | None:
        """Same as :attr:`drawn_technique`."""
        return self.drawn_technique

    @with_current_context
    def release(self) -> None:
        for obj in (self._relief_tex, self._colour_tex, self._cone_tex, self._minmax_tex,
                    self._colour_target, self._depth_rb, self.fbo, self._vbo,
                    *self._vaos.values()):
            if obj is not None:
                obj.release()
        self._vaos.clear()


__all__ = [
    "LINEAR_STEPS",
    "OUTPUTS",
    "TECHNIQUES",
    "WALL_LINEAR_STEPS",
    "ReliefFallbackWarning",
    "ReliefQuadRenderer",
    "ReliefSettings",
    "load_relief_program",
    "relief_texture_data",
    "technique_id",
]
