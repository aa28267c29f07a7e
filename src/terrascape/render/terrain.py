"""GPU terrain renderer: owns the vertex/index buffers and textures of one heightmap and draws
it with a registered technique (Janković 2010 §2.6.4: mesh with tangents, shader constants set per
frame, sky box; Filipović 2008 §4.2: terrain drawn as tiles).

* The full-resolution mesh is drawn as chunks of ``chunk_size`` vertices per side, each with
  its own bounding box culled against the view frustum. Their vertices (position, normal,
  tangent+w; 40 bytes per vertex) are uploaded once, chunk after chunk, and each chunk's
  triangles are indexed in the band order of
  :func:`~terrascape.mesh.terrain_mesh.banded_grid_triangles`, which shades each vertex
  about once in a small vertex cache (llvmpipe's front end, the bottleneck of a full
  1025² frame, re-shaded 2 vertices per triangle with grid-order indices).
* :meth:`TerrainRenderer.set_indices` replaces them with an index list of grid vertices
  ``row·cols + col`` (a LOD algorithm's per-frame triangulation); ``None`` goes back. The
  grid-order vertex buffers it indexes are uploaded on its first call.
* Textures are built on demand from the technique's :class:`~terrascape.render.techniques.
  TextureSlot` builders (or set explicitly with :meth:`set_texture`) and cached.
* What is particular to a technique (its textures, uniforms, CPU-side parameters, deferred
  shading and fallback) is read from its :class:`~terrascape.render.techniques.Technique`
  entry; the renderer has no branch per technique. Deferred shading is
  :mod:`terrascape.render.deferred`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from terrascape._validate import check_int, check_positive
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lighting.sun import sun_direction
from terrascape.mesh import DEFAULT_BAND, terrain_mesh
from terrascape.mesh.small_triangles import cull_small_triangles
from terrascape.render.context import describe_context, with_current_context
from terrascape.render.deferred import DeferredShading
from terrascape.render.shaders import load_program, set_uniforms
from terrascape.render.techniques import (
    LIGHTING_MODES,
    DrawnTechnique,
    Technique,
    TechniqueFallbackWarning,
    TextureData,
    choose_drawable,
    get_technique,
    parameter_uniforms,
)

_DTYPES = {np.dtype(np.uint8): "f1", np.dtype(np.float32): "f4"}
# GL sampler types (float, int, uint; 1D/2D/3D/cube/array/shadow/rect/buffer variants).
_SAMPLER_TYPES = frozenset(
    [*range(0x8B5D, 0x8B65), 0x8DC0, 0x8DC1, 0x8DC3, 0x8DC4, 0x8DC5, *range(0x8DC9, 0x8DD9)]
)
# Samplers a technique does not feed get their own units from here up, so no two samplers
# of different types share unit 0 (a draw-time GL_INVALID_OPERATION that drops the draw).
_SPARE_UNIT = 16
# Texture units of the daylight look's own textures (terrain shadows + sky view, heights).
_SUN_SKY_UNIT = 10
_HEIGHT_UNIT = 11
_SKY_LUT_UNIT = 15  # after the G-buffer units 12-14 (render.deferred.GBUFFER_UNIT)
_NORMAL_UNIT = 24  # per-pixel surface normals, above the spare units
_GROUND_UNIT = 12  # the plane surround's ground; the sky pass runs after the G-buffer's use
# Full-resolution chunk side: 129² vertices keep the band-ordered indices cache-friendly
# (129 ≢ 0, ±1 mod 256, llvmpipe's vertex-cache hash) with few draw calls (64 at 1025²).
RENDER_CHUNK = 129
# Small-triangle culling (terrascape.mesh.small_triangles) on chunks whose cells project to
# at most this many pixels at the chunk's nearest point: there most triangles hold no pixel
# centre; on larger triangles the test would cost more than it saves.
CULL_CELL_PX = 1.0
# The skirts closing the terrain's sides reach this share of its relief below its lowest point.
SKIRT_DEPTH = 0.05
_SOFTWARE_RASTERISERS = ("llvmpipe", "softpipe", "swrast", "swiftshader")


def _vec(value: Any, n: int, name: str) -> tuple[float, ...]:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.size != n or not np.isfinite(arr).all():
        raise InvalidParameterError(f"{name} must be {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def _check_finite(name: str, value: Any) -> None:
    """A numeric technique parameter must be finite, also when this frame's program does
    not read it (its lighting mode compiled the branch out, so no upload would check it)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return  # not numeric: the uniform upload reports it
    if not np.isfinite(arr).all():
        raise InvalidParameterError(f"{name} must be finite, got {value!r}")


def as_texture_data(value: Any, *, name: str = "texture") -> TextureData:
    """Accept a :class:`TextureData` or a bare array (2-D texture, repeat) and validate it."""
    tex = value if isinstance(value, TextureData) else TextureData(np.asarray(value))
    data = np.asarray(tex.data)
    if tex.kind not in ("2d", "3d", "array"):
        raise InvalidParameterError(f"{name}: kind must be 2d, 3d or array, got {tex.kind!r}")
    base = 2 if tex.kind == "2d" else 3
    if data.ndim not in (base, base + 1):
        raise InvalidParameterError(
            f"{name}: a {tex.kind} texture needs {base} or {base + 1} dimensions "
            f"({'H, W[, C]' if base == 2 else 'L, H, W[, C]'}), got shape {data.shape}"
        )
    if data.ndim == base:
        data = data[..., None]
    if not 1 <= data.shape[-1] <= 4:
        raise InvalidParameterError(f"{name}: 1 to 4 channels expected, got {data.shape[-1]}")
    if min(data.shape[:-1]) < 1:
        raise InvalidParameterError(f"{name}: texture has a zero-size dimension {data.shape}")
    if data.dtype == np.uint16:
        data = data.astype(np.float32) / np.float32(65535.0)
    elif data.dtype == np.float64:
        data = data.astype(np.float32)
    if data.dtype not in _DTYPES:
        raise InvalidParameterError(
            f"{name}: dtype must be uint8, uint16 or float32, got {data.dtype}"
        )
    if data.dtype == np.float32 and not np.isfinite(data).all():
        raise InvalidParameterError(f"{name}: texture contains NaN/inf")
    levels = tuple(np.ascontiguousarray(lv) for lv in tex.levels)
    if levels:
        if tex.kind != "2d":
            raise InvalidParameterError(f"{name}: an explicit mip chain needs a 2d texture")
        h, w = data.shape[:2]
        for k, lv in enumerate(levels, start=1):
            want = (max(h >> k, 1), max(w >> k, 1))
            if lv.shape[:2] != want or lv.dtype != data.dtype or lv.shape[2:] != data.shape[2:]:
                raise InvalidParameterError(
                    f"{name}: mip level {k} must be {want[1]}×{want[0]} {data.dtype} with "
                    f"{data.shape[2:] or 1} channel(s), got {lv.shape} {lv.dtype}"
                )
    return TextureData(np.ascontiguousarray(data), tex.kind, bool(tex.repeat), bool(tex.mipmaps),
                       bool(tex.nearest), levels, bool(tex.mip_blend))


def _texture_spec(tex: TextureData) -> tuple | None:
    """What a texture made by :func:`upload_texture` must share with ``tex`` to take its
    pixels in place (size, channels, type, filtering); None when it cannot (3-D, arrays,
    explicit mip chains, nearest filtering)."""
    if tex.kind != "2d" or tex.levels or tex.nearest:
        return None
    return (tex.data.shape, tex.data.dtype.str, bool(tex.repeat), bool(tex.mipmaps),
            bool(tex.mip_blend))


def upload_texture(ctx, tex: TextureData, *, name: str = "texture", limits: dict | None = None):
    """Create a moderngl texture from validated :class:`TextureData` (checked against the
    context's size limits)."""
    import moderngl

    tex = as_texture_data(tex, name=name)
    limits = limits or describe_context(ctx)
    data = tex.data
    comps = data.shape[-1]
    dtype = _DTYPES[data.dtype]
    if tex.kind == "2d":
        h, w = data.shape[:2]
        limit = limits["max_texture_size"]
        if max(h, w) > limit:
            raise InvalidParameterError(f"{name}: {w}×{h} exceeds GL_MAX_TEXTURE_SIZE {limit}")
        gl_tex = ctx.texture((w, h), comps, data.tobytes(), dtype=dtype)
    else:
        n_layers, h, w = data.shape[:3]
        if tex.kind == "3d":
            limit = limits["max_3d_texture_size"]
            if max(h, w, n_layers) > limit:
                raise InvalidParameterError(
                    f"{name}: {w}×{h}×{n_layers} exceeds GL_MAX_3D_TEXTURE_SIZE {limit}"
                )
            gl_tex = ctx.texture3d((w, h, n_layers), comps, data.tobytes(), dtype=dtype)
            gl_tex.repeat_z = False
        else:
            if max(h, w) > limits["max_texture_size"] or (
                n_layers > limits["max_array_texture_layers"]
            ):
                raise InvalidParameterError(
                    f"{name}: {w}×{h}×{n_layers} exceeds the texture array limits "
                    f"({limits['max_texture_size']}, {limits['max_array_texture_layers']} layers)"
                )
            gl_tex = ctx.texture_array((w, h, n_layers), comps, data.tobytes(), dtype=dtype)
    gl_tex.repeat_x = tex.repeat
    gl_tex.repeat_y = tex.repeat
    if tex.levels:
        gl_tex.build_mipmaps(0, len(tex.levels))  # allocates the chain; overwritten below
        for k, lv in enumerate(tex.levels, start=1):
            gl_tex.write(lv.tobytes(), level=k)
        gl_tex.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
    elif tex.nearest:
        gl_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    elif tex.mipmaps and tex.kind != "3d":
        gl_tex.build_mipmaps()
        gl_tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR if tex.mip_blend
                         else moderngl.LINEAR_MIPMAP_NEAREST, moderngl.LINEAR)
        # No anisotropic filtering: on llvmpipe it costs 2-4× the frame time of a technique.
    else:
        gl_tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    if comps == 1:
        gl_tex.swizzle = "RRR1"
    return gl_tex


def _aabb_visible(planes: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """False when the box lies entirely outside one frustum plane (p-vertex test)."""
    p = np.where(planes[:, :3] >= 0, hi, lo)
    return bool(np.all(np.einsum("ij,ij->i", planes[:, :3], p) + planes[:, 3] >= 0))


class TerrainRenderer:
    """Draws one heightmap on a moderngl context.

    Parameters
    ----------
    ctx
        moderngl context (e.g. :func:`~terrascape.render.context.create_headless_context`).
    heightmap
        The terrain (any size; spacing is real world units).
    exaggeration
        Vertical scale baked into the vertex buffer (> 0).
    chunk_size
        Vertices per chunk side (2**k + 1) of the full-resolution mesh.
    small_triangle_cull
        Before drawing a full-resolution chunk whose cells are sub-pixel, leave out its
        triangles that hold no pixel centre (they draw nothing;
        :func:`~terrascape.mesh.small_triangles.cull_small_triangles`, on the CPU cores).
        ``None`` (default): on for software rasterisers (llvmpipe), where triangle setup on
        one thread is the cost of a far view; off on GPUs, which reject such triangles in
        hardware.
    deferred_shading
        For techniques marked ``deferred`` (heavy per-pixel shading: layer blending, relief
        marches): draw the surface attributes into a geometry buffer first and run the
        technique's shading once per terrain pixel in a full-screen pass
        (common/terrain_fragment.glsl). A CPU rasteriser shades pixels in SIMD vectors per
        triangle, so small triangles waste most lanes and hidden surfaces are shaded too;
        shaded full-screen, every lane is a visible pixel. ``None`` (default): on for
        software rasterisers (as ``small_triangle_cull``), off on GPUs.
    """

    @with_current_context
    def __init__(
        self,
        ctx,
        heightmap: Heightmap,
        *,
        exaggeration: float = 1.0,
        chunk_size: int = RENDER_CHUNK,
        small_triangle_cull: bool | None = None,
        deferred_shading: bool | None = None,
    ) -> None:
        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(
                f"TerrainRenderer expects a Heightmap, got {type(heightmap).__name__}"
            )
        self.ctx = ctx
        self.heightmap = heightmap
        self.exaggeration = check_positive(exaggeration, "exaggeration")
        self.limits = describe_context(ctx)
        if small_triangle_cull is None:
            renderer = str(self.limits.get("renderer", "")).lower()
            small_triangle_cull = any(name in renderer for name in _SOFTWARE_RASTERISERS)
        self.small_triangle_cull = bool(small_triangle_cull)
        if deferred_shading is None:
            deferred_shading = self.small_triangle_cull
        self.deferred_shading = bool(deferred_shading)
        self._deferred = DeferredShading(ctx)
        # chunk -> (vertex positions (rows, cols, 3), index scratch, index buffer of the kept
        # triangles), made on the chunk's first culled frame
        self._cull_state: dict[int, tuple[np.ndarray, np.ndarray, Any]] = {}
        self.mesh = mesh = terrain_mesh(heightmap, exaggeration=self.exaggeration)
        # The terrain as drawn (heights × exaggeration): shadows and water depths use it.
        self.world = heightmap if self.exaggeration == 1.0 else heightmap.scaled(
            self.exaggeration)
        self._env: dict[str, tuple[Any, Any]] = {}  # daylight textures: name -> (tex, key)
        self._env_spec: dict[str, tuple | None] = {}  # their _texture_spec
        # Sun/sky visibility as an 8-bit texture (llvmpipe filters unorm8 on its fast path);
        # False uploads float32 (the exact values, for comparisons: bench terrain_shading).
        self.visibility_8bit = True
        self._sky_visibility: np.ndarray | None = None
        # a render.sun_shadows.MovingSunShadows for a sun that moves (the viewer's clock)
        self.moving_sun_shadows = None
        self._edge_albedo: dict[int, np.ndarray] = {}
        self._ground_gain = (1.0, 1.0, 1.0)  # the plane's texture mean → its edge albedo
        self._water_vao = None
        self._water_buf = None
        self._lake: tuple | None = None  # (key, vertex array, buffers) of the lakes' surface
        self._skirt_buffers: list[Any] | None = None
        self.draw_skirts = False  # set per frame: daylight frames close the terrain's sides
        self.chunks = mesh.chunks(chunk_size)
        self._chunk_vbos, self._chunk_ibos = self._upload_chunks()
        self._grid_vbos: list[Any] | None = None  # for set_indices, uploaded on first use
        self._bbox = [(np.array(c.bbox_min), np.array(c.bbox_max)) for c in self.chunks]
        self._custom_ibo = None
        self._custom_count = 0
        self._target_pixels = 0
        self._custom_capacity = 0
        self._vaos: dict[tuple, Any] = {}
        self._textures: dict[str, tuple[Any, Any]] = {}  # uniform -> (gl texture, key)
        self._pinned: set[str] = set()
        self._sky_vao = None
        self._wire_prog = None
        self.last_stats: dict[str, int] = {}
        self._default_regions = None
        self._fallen_back: set[str] = set()  # object-shadow modes already warned about
        self._mip_levels: dict[str, int] = {}  # sampler -> levels, for "<sampler>_levels"
        self.drawn: DrawnTechnique | None = None  # what the last frame really drew, and why
        # Where the one note of a technique's fallback goes (None: a TechniqueFallbackWarning)
        self.warn = None
        # the camera the last frame was drawn with (with an infinite far plane under
        # shadow volumes): the one its depth buffer is in
        self.last_camera: Camera | None = None
        self._objects = None  # terrascape.render.objects.ObjectRenderer, set_objects()
        # streamed tiles drawn instead of this heightmap's mesh (render.tiled_terrain): the
        # heightmap then only feeds the textures, shadows, sky and water
        self.geometry = None

    # --- geometry ------------------------------------------------------------------------
    def _upload_chunks(self):
        """Per chunk: its own vertex buffers (borders duplicated) and an index buffer in band
        order, 16-bit where the chunk has at most 65,536 vertices (llvmpipe then also skips a
        per-draw pass over 32-bit indices: 6 % of a full 1025² frame's front-end work)."""
        mesh = self.mesh
        grids = [
            a.reshape(mesh.rows, mesh.cols, a.shape[-1])
            for a in (mesh.positions, mesh.normals, mesh.tangents)
        ]
        vbos, ibos = [], []
        for c in self.chunks:
            vbos.append([
                self.ctx.buffer(np.ascontiguousarray(g[c.rows_slice, c.cols_slice]).tobytes())
                for g in grids
            ])
            idx = c.local_indices()
            small = c.rows * c.cols <= 1 << 16
            ibos.append((self.ctx.buffer(idx.astype(np.uint16 if small else np.uint32)
                                         .tobytes()), 2 if small else 4))
        return vbos, ibos

    def _grid_buffers(self) -> list[Any]:
        if self._grid_vbos is None:
            m = self.mesh
            self._grid_vbos = [
                self.ctx.buffer(a.tobytes()) for a in (m.positions, m.normals, m.tangents)
            ]
        return self._grid_vbos

    @with_current_context
    def set_indices(self, indices: np.ndarray | None) -> None:
        """Draw these triangles (grid-vertex indices ``row·cols + col``) instead of the full
        mesh, until called with ``None``. ``(m, 3)`` or flat with a length multiple of 3."""
        if indices is None:
            self._custom_count = 0
            return
        idx = np.asarray(indices)
        if not np.issubdtype(idx.dtype, np.integer):
            raise InvalidParameterError(f"indices must be integers, got dtype {idx.dtype}")
        idx = idx.reshape(-1)
        if idx.size % 3:
            raise InvalidParameterError(
                f"indices must hold whole triangles (a multiple of 3), got {idx.size}"
            )
        n = self.mesh.n_vertices
        if idx.size and (int(idx.min()) < 0 or int(idx.max()) >= n):
            raise InvalidParameterError(
                f"indices must be in [0, {n}) (rows·cols of the grid), got "
                f"[{int(idx.min())}, {int(idx.max())}]"
            )
        data = idx.astype(np.uint32, copy=False).tobytes()
        if len(data) > self._custom_capacity or self._custom_ibo is None:
            if self._custom_ibo is not None:
                self._custom_ibo.release()
                self._vaos = {k: v for k, v in self._vaos.items() if k[1] != "custom"}
            self._custom_capacity = max(len(data) + len(data) // 2, 12)
            self._custom_ibo = self.ctx.buffer(reserve=self._custom_capacity, dynamic=True)
        if data:
            self._custom_ibo.write(data)
        self._custom_count = idx.size
        if idx.size == 0:
            self._custom_count = -1  # explicit empty triangulation: draw nothing

    def _vao(self, program, which, *, culled: bool = False):
        key = (program.glo, which, culled)
        vao = self._vaos.get(key)
        if vao is None:
            if which == "custom":
                (ibo, index_size), vbos = (self._custom_ibo, 4), self._grid_buffers()
            else:
                (ibo, index_size), vbos = self._chunk_ibos[which], self._chunk_vbos[which]
                if culled:
                    ibo = self._cull_state[which][2]
            content = [
                (vbos[0], "3f", "in_position"),
                (vbos[1], "3f", "in_normal"),
                (vbos[2], "4f", "in_tangent"),
            ]
            # Programs may not use every attribute (e.g. the wireframe pass): skip_errors.
            vao = self.ctx.vertex_array(program, content, ibo, index_size, skip_errors=True)
            self._vaos[key] = vao
        return vao

    # --- objects on the terrain --------------------------------------------------------
    @with_current_context
    def set_objects(self, instances) -> None:
        """Draw these :class:`~terrascape.objects.model.Instances` on the terrain in every
        frame (instanced, impostors far away, the sun's shadows per ``object_shadows``;
        :mod:`terrascape.render.objects`); ``None`` removes them."""
        from terrascape.render.objects import ObjectRenderer

        if self._objects is not None:
            self._objects.release()
            self._objects = None
        if instances is not None:
            self._objects = ObjectRenderer(self, instances)

    @property
    def objects(self):
        """The :class:`~terrascape.render.objects.ObjectRenderer` of :meth:`set_objects`."""
        return self._objects

    # --- textures ------------------------------------------------------------------------
    @with_current_context
    def set_texture(self, uniform: str, texture: Any) -> None:
        """Use ``texture`` (array or :class:`TextureData`) for sampler ``uniform`` in every
        technique, instead of the built default."""
        gl_tex = upload_texture(self.ctx, texture, name=uniform, limits=self.limits)
        old = self._textures.pop(uniform, None)
        if old is not None:
            old[0].release()
        self._textures[uniform] = (gl_tex, None)
        self._mip_levels[uniform] = 1 + len(as_texture_data(texture, name=uniform).levels)
        self._pinned.add(uniform)

    def _ensure_textures(self, tech: Technique, params: Mapping[str, Any]) -> list[str]:
        names = []
        for slot in tech.active_slots(params):
            names.append(slot.uniform)
            if slot.uniform in self._pinned:
                continue
            key = (slot.builder, tuple(repr(params.get(d)) for d in slot.depends))
            have = self._textures.get(slot.uniform)
            if have is not None and have[1] == key:
                continue
            data = as_texture_data(slot.builder(self.heightmap, params), name=slot.uniform)
            gl_tex = upload_texture(self.ctx, data, name=slot.uniform, limits=self.limits)
            self._mip_levels[slot.uniform] = 1 + len(data.levels)
            if have is not None:
                have[0].release()
            self._textures[slot.uniform] = (gl_tex, key)
        return names

    @property
    def drawn_technique(self) -> str | None:
        """The technique the last frame drew: the one asked for, or its fallback."""
        return None if self.drawn is None else self.drawn.name

    @property
    def last_technique(self) -> str | None:
        """Same as :attr:`drawn_technique`."""
        return self.drawn_technique

    # --- uniforms ------------------------------------------------------------------------
    def tile_size(self, params: Mapping[str, Any]) -> float:
        """World units per material repeat: ``tile_size``, or 32 × the largest spacing."""
        value = params["tile_size"]
        if value is None:
            return 32.0 * max(self.heightmap.spacing)
        return check_positive(value, "tile size")

    def frame_uniforms(self, camera: Camera, params: Mapping[str, Any],
                       technique: Technique | None = None) -> dict[str, Any]:
        """Every uniform value of one frame (the thesis's per-frame shader constant callback):
        the renderer's, the ``technique``'s parameters and its ``uniforms`` hook."""
        az, el = _vec(params["sun"], 2, "sun (azimuth, elevation)")
        ex, ez = self.mesh.extent
        lo, hi = self.heightmap.min, self.heightmap.max
        fog = params["fog_density"]
        if fog is None:
            # Visibility exp(-(d·k)²) ≈ 0.9 across the terrain diagonal: a distance cue
            # without hiding the far side.
            fog = 0.3 / math.hypot(ex, ez)
        fog = check_positive(fog, "fog_density", allow_zero=True)
        horizon = _vec(params["horizon_color"], 3, "horizon_color")
        fog_color = (
            horizon if params["fog_color"] is None else _vec(params["fog_color"], 3, "fog_color")
        )
        tile = self.tile_size(params)
        u: dict[str, Any] = {
            "u_view_proj": camera.view_projection(),
            "u_inv_view_proj": np.linalg.inv(camera.view_projection()),
            "u_camera_pos": camera.eye,
            "u_extent": (ex, ez),
            "u_spacing": self.heightmap.spacing,
            "u_grid_size": (self.mesh.cols, self.mesh.rows),
            "u_exaggeration": self.exaggeration,
            "u_height_range": (lo * self.exaggeration, hi * self.exaggeration),
            "u_sun_dir": sun_direction(az, el),
            "u_lighting": LIGHTING_MODES[params["lighting"]],
            "u_fog_density": fog,
            "u_fog_color": fog_color,
            "u_tile_size": tile,
            # the shadow-volume pass sets it to 1 (terrascape.render.shadow_volumes.SUN_OFF)
            "u_sun_blocked": 0,
            "u_lightmap_ambient": float(params.get("lightmap_ambient", 0.2)),
        }
        from_params = (parameter_uniforms(params) if technique is None
                       else technique.parameter_uniforms(params))
        for key, value in from_params.items():
            _check_finite(key[2:], value)
        u.update(from_params)
        if params["lighting"] == "daylight":
            from terrascape.render.atmosphere import daylight_uniforms

            seed = int(params.get("seed", 0))
            if seed not in self._edge_albedo:
                from terrascape.texture.terrain_material import lowest_ground_albedo

                # the ground beyond the edge: the material the terrain's lowest ground has
                self._edge_albedo[seed] = lowest_ground_albedo(self.heightmap, seed=seed)
            u.update(daylight_uniforms(self.world, params, edge_albedo=self._edge_albedo[seed],
                                       exaggeration=self.exaggeration))
        if technique is not None and technique.uniforms is not None:
            u.update(technique.uniforms(self, params))
        return u

    def regions(self, params: Mapping[str, Any]) -> list:
        """The height regions of ``params`` (``None``: the default regions of this terrain)."""
        regions = params.get("regions")
        if regions is not None:
            return list(regions)
        if self._default_regions is None:
            from terrascape.texture import default_regions

            self._default_regions = default_regions(self.heightmap)
        return self._default_regions

    # --- drawing -------------------------------------------------------------------------
    @with_current_context
    def render(
        self,
        fbo,
        camera: Camera,
        technique: str | Technique = "plain",
        params: Mapping[str, Any] | None = None,
    ) -> dict[str, int]:
        """Draw sky + terrain (+ wireframe overlay) into ``fbo``.

        Parameters
        ----------
        fbo
            moderngl framebuffer with a depth attachment; it is cleared.
        camera
            :class:`~terrascape.camera.Camera`; its aspect should match ``fbo`` (not forced).
        technique
            Registered technique name (:func:`~terrascape.render.techniques.technique_names`).
        params
            Technique parameters (see ``Technique.parameters()``); ``textures`` may map
            sampler names to arrays to override defaults for this renderer.

        Returns
        -------
        dict
            ``triangles`` drawn and ``chunks`` drawn / ``chunks_culled``.
        """
        import moderngl

        if not isinstance(camera, Camera):
            raise InvalidParameterError(f"camera must be a Camera, got {type(camera).__name__}")
        requested = get_technique(technique)
        self._target_pixels = fbo.size[0] * fbo.size[1]  # for _haze_per_vertex
        objects = self._objects if self._objects is not None and self._objects.enabled else None
        requested_params = requested.resolve(params)

        def build(name: str):
            if name == requested.name:
                tech, p = requested, requested_params
            else:
                tech = get_technique(name)
                # Carry over what the caller set (sun, fog, ...), not the failed technique's
                # own defaults, so the frame is exactly what the fallback draws.
                known = tech.parameters()
                p = tech.resolve({k: v for k, v in (params or {}).items() if k in known})
            return (tech, p, *self._prepare(tech, p, objects is not None))

        # A technique this GL cannot run (compile or link failure, missing feature) draws
        # its fallback, decided once per context and said once.
        (tech, p, samplers, program), self.drawn = choose_drawable(
            self.ctx, requested.name, build, fallback=requested.fallback,
            key=(requested.name, requested.program, repr(sorted(requested.defines.items()))),
            warn=self.warn)
        if p["object_shadows"] == "volumes":
            from terrascape.render.shadow_volumes import object_shadow_mode

            p = object_shadow_mode(self, fbo, p)  # no stencil: shadow maps, warned once
        ctx = self.ctx
        if objects is not None and p["object_shadows"] == "volumes":
            # Everitt & Kilgard's infinite far plane: the volumes' points at infinity stay
            # inside the depth range; the whole frame is drawn with it so the volumes' depth
            # test compares against the same depth mapping.
            camera = replace(camera, infinite_far=True)
        self.last_camera = camera
        uniforms = self.frame_uniforms(camera, p, tech)
        # Objects: the sun's shadow maps first (their own framebuffer), read by the terrain.
        uniforms.update(objects.begin_frame(camera, fbo.size, p, uniforms["u_sun_dir"])
                        if objects is not None else {"u_cascade_count": 0})
        fbo.use()
        ctx.viewport = (0, 0, *fbo.size)
        horizon = uniforms["u_fog_color"]
        fbo.clear(*horizon, 1.0, depth=1.0)
        plan = self._chunk_plan(camera, fbo.size)
        # Heavy techniques on a software rasteriser: shaded once per pixel (deferred).
        deferred = (self._deferred.shading_program(
                        tech, self._shading_defines(tech, p, objects is not None))
                    if tech.deferred and self.deferred_shading else None)
        for unit, name in enumerate(samplers):
            self._textures[name][0].use(location=unit)
        self._bind(deferred or program, uniforms, samplers)
        daylight = p["lighting"] == "daylight"
        # Daylight frames show the world beyond the terrain: close its sides with skirts.
        self.draw_skirts = daylight
        if daylight:
            self._bind_environment(deferred or program, p)
        if "u_surface_normal" in (deferred or program):
            self._bind_surface_normals(deferred or program)
        if objects is not None:
            objects.bind_receiver(deferred or program)
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.front_face = "ccw"
        wire = bool(p["wireframe"])
        if wire:
            # Push the filled surface back so the overlay lines win the depth test.
            ctx.polygon_offset = (1.0, 1.0)
        if deferred is None:
            stats = self._draw_geometry(program, camera, fbo.size, plan)
        else:
            stats = self._deferred.draw(
                fbo, deferred, uniforms["u_view_proj"],
                lambda geometry: self._draw_geometry(geometry, camera, fbo.size, plan))
        ctx.polygon_offset = (0.0, 0.0)
        if wire:
            wp = self._wire_prog or load_program(ctx, "debug/solid")
            self._wire_prog = wp
            set_uniforms(
                wp,
                u_view_proj=uniforms["u_view_proj"],
                u_color=_vec(p["wireframe_color"], 4, "wireframe_color"),
            )
            ctx.wireframe = True
            try:
                # every visible chunk whole: lines of small triangles still draw pixels
                self._draw_geometry(wp, camera, fbo.size, plan and (plan[0], []))
            finally:
                ctx.wireframe = False
        ctx.disable(moderngl.CULL_FACE)
        if objects is not None:
            stats = {**stats, **objects.draw(uniforms)}
        if objects is not None and objects.mode == "volumes":
            from terrascape.render.shadow_volumes import shade_shadow_volumes

            stats.update(shade_shadow_volumes(self, fbo, camera, uniforms, plan=plan,
                                              program=deferred or program,
                                              deferred=deferred is not None))
        if daylight and (p["sea_level"] is not None or p["water_depth"] is not None):
            self._draw_water(fbo, uniforms, p)
        if p["sky"]:
            # Drawn last at depth 1.0 with LEQUAL: only pixels no terrain covered are shaded,
            # instead of a full-screen pass that the terrain then overdraws.
            self._draw_sky(uniforms, p)
        ctx.disable(moderngl.DEPTH_TEST)
        self.last_stats = stats
        return stats

    def _bind(self, program, uniforms: Mapping[str, Any], samplers: list[str]) -> None:
        """Frame uniforms and texture units of one program."""
        set_uniforms(program, **uniforms)
        for unit, name in enumerate(samplers):
            set_uniforms(program, **{name: unit})
            if f"{name}_levels" in program:
                set_uniforms(program, **{f"{name}_levels": self._mip_levels.get(name, 1)})
        spare = _SPARE_UNIT
        for name in program:
            member = program[name]
            if getattr(member, "gl_type", None) in _SAMPLER_TYPES and name not in samplers:
                member.value = spare
                spare += 1

    def _cull_chunks(self, chunks: list[int], camera: Camera, viewport) -> dict[int, int]:
        """Upload, for each of ``chunks``, the index list of its triangles that can draw in
        this view; returns chunk -> number of indices (16-bit chunks only)."""
        vp = camera.view_projection()
        grid = self.mesh.positions.reshape(self.mesh.rows, self.mesh.cols, 3)
        counts = {}
        for i in chunks:
            if self._chunk_ibos[i][1] != 2:
                continue
            state = self._cull_state.get(i)
            if state is None:
                c = self.chunks[i]
                tile = np.ascontiguousarray(grid[c.rows_slice, c.cols_slice])
                scratch = np.empty(3 * c.n_triangles, dtype=np.uint16)
                state = (tile, scratch, self.ctx.buffer(reserve=scratch.nbytes))
                self._cull_state[i] = state
            tile, scratch, ibo = state
            kept = cull_small_triangles(tile, vp, viewport, band=DEFAULT_BAND, out=scratch)
            if kept.size:
                ibo.write(kept.tobytes())
            counts[i] = kept.size
        return counts

    def _shading_defines(self, tech: Technique, p: Mapping[str, Any], cascades: bool) -> dict:
        """The technique's defines plus the frame's lighting mode and whether the objects'
        shadow cascades are read (common/terrain_fragment.glsl): one program per
        combination, each holding only its own branches (on a software rasteriser every
        branch of a shader costs every pixel); daylight frames' haze per vertex
        (common/terrain_vertex.glsl) when a level-of-detail triangulation is drawn."""
        # a technique's own defines win (TERRAIN_LIGHTING="u_lighting" compiles every mode)
        mode = LIGHTING_MODES[p["lighting"]]
        return {"TERRAIN_LIGHTING": mode, "TERRAIN_CASCADES": int(cascades),
                "TERRAIN_VERTEX_HAZE": int(mode == LIGHTING_MODES["daylight"]
                                           and self._haze_per_vertex()),
                **(tech.defines or {})}

    def _haze_per_vertex(self) -> bool:
        """Whether this frame's mesh is cheaper hazed per vertex than per pixel: one with
        fewer vertices than the target has pixels — a level-of-detail triangulation
        (set_indices, a world's tiles), or a grid no larger than the frame. A software
        rasteriser runs the vertex stage on one thread but the pixels on all of them, and a
        larger grid puts many vertices in every far pixel."""
        if self._custom_count or self.geometry is not None:
            return True
        return self.mesh.rows * self.mesh.cols <= self._target_pixels

    def _prepare(self, tech: Technique, p: Mapping[str, Any], cascades: bool = False):
        """Textures and compiled program of ``tech`` for this frame's lighting (raises
        GLUnavailableError if this GL cannot run it). ``cascades``: objects are drawn, so
        the terrain may read their shadow cascades."""
        for name, tex in (p.get("textures") or {}).items():
            self.set_texture(name, tex)
        samplers = self._ensure_textures(tech, p)
        program = load_program(self.ctx, tech.program, self._shading_defines(tech, p, cascades))
        return samplers, program

    def _chunk_plan(self, camera: Camera, viewport) -> tuple[list[int], list[int]] | None:
        """Visible chunks front to back, and those of them whose cells are sub-pixel (to be
        culled for small triangles); None when a custom triangulation is drawn."""
        if self._custom_count or self.geometry is not None:
            return None
        planes = camera.frustum_planes()
        eye = camera.eye
        dist = [float(np.linalg.norm(np.clip(eye, *self._bbox[k]) - eye))
                for k in range(len(self.chunks))]
        # Front to back, so the depth test rejects hidden fragments before shading them.
        order = sorted(range(len(self.chunks)), key=dist.__getitem__)
        visible = [i for i in order if _aabb_visible(planes, *self._bbox[i])]
        small = []
        if self.small_triangle_cull:
            # Projected size of one cell at a chunk's nearest point; cells further in are
            # smaller still.
            cell = max(self.heightmap.spacing) * camera.pixels_per_radian(viewport[1])
            small = [i for i in visible if cell <= CULL_CELL_PX * dist[i]]
        return visible, small

    def _draw_geometry(self, program, camera: Camera, viewport, plan) -> dict[str, int]:
        """Draw the current triangulation with ``program``: the custom one, or the chunks of
        ``plan`` (:meth:`_chunk_plan`), its sub-pixel ones culled for small triangles."""
        import moderngl

        if self.geometry is not None:
            stats = self.geometry.draw(program, camera, viewport)
            if self.draw_skirts:
                self._draw_skirts(program)
            return stats
        if self._custom_count:
            if self._custom_count > 0:
                self._vao(program, "custom").render(moderngl.TRIANGLES, vertices=self._custom_count)
            n = max(self._custom_count, 0) // 3
            return {"triangles": n, "triangles_drawn": n, "chunks": 1, "chunks_culled": 0,
                    "chunks_small_cull": 0}
        visible, small = plan
        small_counts = self._cull_chunks(small, camera, viewport)
        tris = drawn = 0
        for i in visible:
            n = self.chunks[i].n_triangles
            tris += n
            if i in small_counts:
                n = small_counts[i] // 3
                if n:
                    self._vao(program, i, culled=True).render(moderngl.TRIANGLES, vertices=3 * n)
            else:
                self._vao(program, i).render(moderngl.TRIANGLES)
            drawn += n
        if self.draw_skirts:
            self._draw_skirts(program)
        return {"triangles": tris, "triangles_drawn": drawn, "chunks": len(visible),
                "chunks_culled": len(self.chunks) - len(visible),
                "chunks_small_cull": len(small_counts)}

    def _fullscreen(self, program) -> None:
        """One full-screen triangle with ``program`` (the deferred passes' geometry)."""
        self._deferred.fullscreen(program)

    # --- daylight: terrain shadows, sky view, water ------------------------------------
    def lowest_surface_height(self) -> float:
        """The lowest height any drawn terrain surface has: the skirts' bottom, a little
        below the terrain's lowest point (shadow caster culling sweeps down to it)."""
        y = self.mesh.positions.reshape(-1, 3)[:, 1]
        low = float(y.min())
        return low - SKIRT_DEPTH * max(float(y.max()) - low, 1e-6)

    def _skirt_geometry(self) -> list[np.ndarray]:
        """Vertical walls from the terrain's border down below its lowest point (positions,
        outward normals, tangents; triangles as a flat list), so a view from beyond the edge
        meets the terrain's side instead of looking under it."""
        m = self.mesh
        rows, cols = m.rows, m.cols
        grid = m.positions.reshape(rows, cols, 3)
        r = np.r_[np.zeros(cols - 1, int), np.arange(rows - 1), np.full(cols - 1, rows - 1),
                  np.arange(rows - 1, 0, -1)]
        c = np.r_[np.arange(cols - 1), np.full(rows - 1, cols - 1), np.arange(cols - 1, 0, -1),
                  np.zeros(rows - 1, int)]
        top = grid[r, c].astype(np.float32)
        ex, ez = m.extent
        rel = top[:, [0, 2]] - np.array([ex / 2, ez / 2], np.float32)
        normal = np.zeros_like(top)
        along_x = np.abs(rel[:, 0] / max(ex, 1e-9)) >= np.abs(rel[:, 1] / max(ez, 1e-9))
        normal[along_x, 0] = np.sign(rel[along_x, 0])
        normal[~along_x, 2] = np.sign(rel[~along_x, 1])
        bottom = top.copy()
        bottom[:, 1] = self.lowest_surface_height()
        n = len(top)
        a = np.arange(n)
        b = (a + 1) % n
        # top vertices 0..n-1, bottom n..2n-1; two triangles per border segment
        tris = np.stack([a, a + n, b, b, a + n, b + n], axis=1).reshape(-1)
        pos = np.concatenate([top, bottom])
        nor = np.concatenate([normal, normal])
        tan = np.zeros((2 * n, 4), np.float32)
        tan[:, :3] = np.cross(nor, np.array([0.0, 1.0, 0.0], np.float32))
        tan[:, 3] = 1.0
        return [pos.astype(np.float32), nor.astype(np.float32), tan, tris.astype(np.uint32)]

    def _draw_skirts(self, program) -> None:
        import moderngl

        if self._skirt_buffers is None:
            pos, nor, tan, tris = self._skirt_geometry()
            self._skirt_buffers = [self.ctx.buffer(a.tobytes()) for a in (pos, nor, tan, tris)]
        key = (program.glo, "skirt", False)
        vao = self._vaos.get(key)
        if vao is None:
            pos, nor, tan, ibo = self._skirt_buffers
            vao = self.ctx.vertex_array(
                program, [(pos, "3f", "in_position"), (nor, "3f", "in_normal"),
                          (tan, "4f", "in_tangent")], ibo, 4, skip_errors=True)
            self._vaos[key] = vao
        self.ctx.disable(moderngl.CULL_FACE)  # seen from outside only; either winding
        try:
            vao.render(moderngl.TRIANGLES)
        finally:
            self.ctx.enable(moderngl.CULL_FACE)

    def _env_texture(self, name: str, key: Any, build) -> Any:
        have = self._env.get(name)
        if have is not None and have[1] == key:
            return have[0]
        data = as_texture_data(build(), name=name)
        spec = _texture_spec(data)
        if have is not None and spec is not None and self._env_spec.get(name) == spec:
            # a moving sun changes the visibility map every frame: write into the texture
            # it already has instead of allocating a new one (and its sampler state)
            tex = have[0]
            tex.write(data.data.tobytes())
            if data.mipmaps:
                tex.build_mipmaps()
        else:
            tex = upload_texture(self.ctx, data, name=name, limits=self.limits)
            if have is not None:
                have[0].release()
        self._env[name] = (tex, key)
        self._env_spec[name] = spec
        return tex

    def sun_sky_visibility(self, params: Mapping[str, Any]) -> np.ndarray:
        """float32 ``(rows, cols, 2)``: visible share of the sun's disc (soft terrain
        shadows, :func:`~terrascape.lighting.soft_shadow` on the exaggerated terrain) and
        the sky-view factor, the per-vertex texture the daylight model samples per pixel."""
        from terrascape.lighting.daylight import local_sky_visibility
        from terrascape.lighting.shadows import soft_shadow
        from terrascape.render.atmosphere import key_light

        # the light that casts the shadows: the sun, or the moon at night
        az, el = key_light(params)
        if self._sky_visibility is None:
            self._sky_visibility = local_sky_visibility(self.world).astype(np.float32)
        if not params["shadows"]:
            sun = np.ones(self.world.shape, np.float32)
        elif el <= 0.0:
            sun = np.zeros(self.world.shape, np.float32)
        else:
            sun = soft_shadow(self.world, az, el, sun_radius_deg=float(params["sun_radius"]),
                              samples=int(params["shadow_samples"]))
        return np.ascontiguousarray(np.stack([sun, self._sky_visibility], axis=-1))

    def _with_sky_view(self, sun: np.ndarray) -> np.ndarray:
        """(sun, sky-view) texture data for a sun visibility map of any subsampled size."""
        from terrascape.lighting.daylight import local_sky_visibility

        if self._sky_visibility is None:
            self._sky_visibility = local_sky_visibility(self.world).astype(np.float32)
        step = max(1, round((self._sky_visibility.shape[0] - 1) / max(sun.shape[0] - 1, 1)))
        sky = self._sky_visibility[::step, ::step][: sun.shape[0], : sun.shape[1]]
        return np.ascontiguousarray(np.stack([sun, sky], axis=-1), dtype=np.float32)

    def _bind_environment(self, program, params: Mapping[str, Any]) -> None:
        from terrascape.render.atmosphere import key_light

        key = (tuple(round(v, 6) for v in key_light(params)),
               *(repr(params[k]) for k in ("shadows", "sun_radius", "shadow_samples")))
        self._use_sky_lut(program, params)
        moving = self.moving_sun_shadows

        # 8-bit: llvmpipe filters unorm8 on its fast path, float textures on a slow one
        # (a tenth of a plain daylight frame); visibility needs no more precision.
        def texture_of(vis):
            if self.visibility_8bit:
                vis = np.round(np.clip(vis, 0.0, 1.0) * 255.0).astype(np.uint8)
            return TextureData(vis, repeat=False)

        if "u_sun_sky" in program and moving is not None and params["shadows"] and key[0][1] > 0:
            # the viewer's moving sun: a coarse map at once, the exact one when it is ready
            vis_key, vis = moving.visibility(*key[0])
            key = (vis_key, *key[1:])
            tex = self._env_texture("u_sun_sky", (*key, self.visibility_8bit),
                                    lambda: texture_of(self._with_sky_view(vis)))
        elif "u_sun_sky" in program:
            tex = self._env_texture("u_sun_sky", (*key, self.visibility_8bit),
                                    lambda: texture_of(self.sun_sky_visibility(params)))
        if "u_sun_sky" in program:
            tex.use(location=_SUN_SKY_UNIT)
            program["u_sun_sky"].value = _SUN_SKY_UNIT
        self._env_texture(
            "u_height", "heights",
            lambda: TextureData(np.ascontiguousarray(self.world.heights, np.float32),
                                repeat=False, mipmaps=False))

    def _use_sky_lut(self, program, params: Mapping[str, Any]) -> None:
        """Bind the frame's sky radiance table (``render.atmosphere.sky_lut``), rebuilt
        only when the sky changes."""
        if "u_sky_lut" not in program:
            return
        from terrascape.render.atmosphere import sky_lut, sky_lut_key

        tex = self._env_texture(
            "u_sky_lut", sky_lut_key(params),
            lambda: TextureData(sky_lut(params), repeat=True, mipmaps=False))
        tex.use(location=_SKY_LUT_UNIT)
        program["u_sky_lut"].value = _SKY_LUT_UNIT

    def _water_geometry(self, params: Mapping[str, Any]) -> list[tuple[Any, Any]]:
        """(vertex array, vertex count or None) of the sea quad and the lakes' surface."""
        prog = load_program(self.ctx, "water")
        out = []
        if params["sea_level"] is not None:
            ex, ez = self.mesh.extent
            y = float(params["sea_level"]) * self.exaggeration
            # the terrain and a margin of sea around it: underwater terrain seen from beyond
            # its edge is under this water too
            m = 4.0 * math.hypot(ex, ez)
            x0, z0, x1, z1 = -m, -m, ex + m, ez + m
            quad = np.array([[x0, y, z0], [x0, y, z1], [x1, y, z0], [x1, y, z0], [x0, y, z1],
                             [x1, y, z1]], dtype=np.float32)
            if self._water_buf is None:
                self._water_buf = self.ctx.buffer(reserve=quad.nbytes)
                self._water_vao = self.ctx.vertex_array(
                    prog, [(self._water_buf, "3f", "in_position")])
            self._water_buf.write(quad.tobytes())
            out.append(self._water_vao)
        if params["water_depth"] is not None:
            out.append(self._lake_vao(prog, params["water_depth"]))
        return [vao for vao in out if vao is not None]

    def _lake_vao(self, prog, depth: Any):
        """The surface of lakes: grid cells with water at a corner, at terrain + depth."""
        d = np.asarray(depth, dtype=np.float32)
        if d.shape != self.heightmap.shape or not np.isfinite(d).all():
            raise InvalidParameterError(
                f"water_depth must be a finite float array of shape {self.heightmap.shape}, "
                f"got {d.dtype} {d.shape}")
        key = (d.shape, hash(d.tobytes()))
        if self._lake is not None and self._lake[0] == key:
            return self._lake[1]
        self._release_lake()
        wet = d > 0
        cell = wet[:-1, :-1] | wet[1:, :-1] | wet[:-1, 1:] | wet[1:, 1:]
        r, c = np.nonzero(cell)
        if r.size == 0:
            self._lake = (key, None, [])
            return None
        cols = self.heightmap.cols
        a = r * cols + c
        b, e, f = a + cols, a + 1, a + cols + 1
        idx = np.stack([a, b, e, e, b, f], axis=1).astype(np.uint32)
        pos = self.mesh.positions.reshape(-1, 3).copy()
        pos[:, 1] += d.reshape(-1) * np.float32(self.exaggeration)
        vbo = self.ctx.buffer(pos.astype(np.float32).tobytes())
        ibo = self.ctx.buffer(idx.tobytes())
        vao = self.ctx.vertex_array(prog, [(vbo, "3f", "in_position")], ibo, 4)
        self._lake = (key, vao, [vbo, ibo])
        return vao

    def _release_lake(self) -> None:
        if self._lake is not None:
            if self._lake[1] is not None:
                self._lake[1].release()
            for buf in self._lake[2]:
                buf.release()
            self._lake = None

    def _draw_water(self, fbo, uniforms: Mapping[str, Any], params: Mapping[str, Any]) -> None:
        """Sea quad and lakes: depth-tested against the terrain, alpha-blended over it."""
        import moderngl

        prog = load_program(self.ctx, "water")
        vaos = self._water_geometry(params)
        set_uniforms(prog, **uniforms)
        self._env["u_height"][0].use(location=_HEIGHT_UNIT)
        prog["u_height"].value = _HEIGHT_UNIT
        self._use_sky_lut(prog, params)
        ctx = self.ctx
        ctx.enable(moderngl.BLEND | moderngl.DEPTH_TEST)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        # Depth is written: the sky pass after it fills only pixels nothing was drawn on.
        try:
            for vao in vaos:
                vao.render(moderngl.TRIANGLES)
        finally:
            ctx.disable(moderngl.BLEND)

    def _draw_sky(self, uniforms: Mapping[str, Any], params: Mapping[str, Any]) -> None:
        import moderngl

        mode = 0
        defines = {}
        if uniforms.get("u_lighting") == LIGHTING_MODES["daylight"]:
            mode = 1 + int(uniforms.get("u_surround", 0))  # 1 haze, 2 plane, 3 sea
            # the moon and the stars only in the frames that have them (sky.glsl)
            defines = {"SKY_MOON": int(max(uniforms.get("u_moon_radiance", (0.0,))) > 0.0),
                       "SKY_STARS": int(uniforms.get("u_star_radiance", 0.0) > 0.0)}
        prog = load_program(self.ctx, "sky", {"SKY_MODE": mode, **defines})
        if self._sky_vao is None or self._sky_vao.program.glo != prog.glo:
            self._sky_vao = self.ctx.vertex_array(prog, [])
        set_uniforms(prog, **uniforms)
        if "u_height" in prog and "u_height" in self._env:
            self._env["u_height"][0].use(location=_HEIGHT_UNIT)
            prog["u_height"].value = _HEIGHT_UNIT
        if mode:
            self._use_sky_lut(prog, params)
        if "u_ground_tex" in prog:
            self._bind_ground(prog, params)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.depth_func = "<="
        try:
            self._sky_vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            self.ctx.depth_func = "<"

    def _bind_surface_normals(self, program) -> None:
        """The mesh's vertex normals as an 8-bit texture (common/terrain_fragment.glsl
        surface_normal: per-pixel normals, bilinear over the grid's cells)."""
        def build() -> TextureData:
            n = self.mesh.normals.reshape(self.mesh.rows, self.mesh.cols, 3)
            packed = np.round((np.clip(n, -1.0, 1.0) * 0.5 + 0.5) * 255.0).astype(np.uint8)
            return TextureData(np.ascontiguousarray(packed), repeat=False, mipmaps=False)

        tex = self._env_texture("u_surface_normal", "normals", build)
        tex.use(location=_NORMAL_UNIT)
        program["u_surface_normal"].value = _NORMAL_UNIT

    def _bind_ground(self, program, params: Mapping[str, Any]) -> None:
        """The plane surround's ground texture (the lowest ground's material), hex-tiled
        like the material technique's layers."""
        from terrascape.texture.hextile import HEX_CONTRAST, HEX_ROTATION, HEX_SHARPNESS
        from terrascape.texture.terrain_material import lowest_ground_texture

        seed = int(params.get("seed", 0))
        data = {}

        def build() -> TextureData:
            data["rgba"] = rgba = lowest_ground_texture(self.heightmap, seed=seed)
            return TextureData(rgba, repeat=True, mipmaps=True, mip_blend=True)

        tex = self._env_texture("u_ground_tex", seed, build)
        if "rgba" in data:
            srgb = data["rgba"][..., :3].reshape(-1, 3) / 255.0
            mean = np.where(srgb <= 0.04045, srgb / 12.92,
                            ((srgb + 0.055) / 1.055) ** 2.4).mean(axis=0)
            self._ground_gain = tuple(self._edge_albedo[seed] / np.maximum(mean, 1e-6))
        tex.use(location=_GROUND_UNIT)
        program["u_ground_tex"].value = _GROUND_UNIT
        set_uniforms(program, u_ground_gain=self._ground_gain,
                     # the surround is no technique: the default hex-tiling, whatever the
                     # terrain's technique tiles with
                     u_ground_hex=(HEX_ROTATION, HEX_CONTRAST, HEX_SHARPNESS))

    @with_current_context
    def release(self) -> None:
        """Free every GL object this renderer created."""
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        chunk_bufs = [b for vbos in self._chunk_vbos for b in vbos]
        chunk_bufs += [ibo for ibo, _ in self._chunk_ibos]
        chunk_bufs += [state[2] for state in self._cull_state.values()]
        self._cull_state.clear()
        for buf in [*chunk_bufs, *(self._grid_vbos or [])]:
            buf.release()
        self._grid_vbos = None
        if self._custom_ibo is not None:
            self._custom_ibo.release()
        for tex, _ in self._textures.values():
            tex.release()
        self._textures.clear()
        if self._sky_vao is not None:
            self._sky_vao.release()
        for tex, _ in self._env.values():
            tex.release()
        self._env.clear()
        if self._water_vao is not None:
            self._water_vao.release()
            self._water_buf.release()
            self._water_vao = self._water_buf = None
        self._release_lake()
        for buf in self._skirt_buffers or []:
            buf.release()
        self._skirt_buffers = None
        self._deferred.release()
        self.set_objects(None)


def check_output_size(ctx, size: Any) -> tuple[int, int]:
    """Validate an output ``(width, height)`` against GL_MAX_VIEWPORT_DIMS and texture limits."""
    try:
        w, h = size
    except (TypeError, ValueError):
        raise InvalidParameterError(f"size must be (width, height), got {size!r}") from None
    w = check_int(w, "output size (width)", minimum=1)
    h = check_int(h, "output size (height)", minimum=1)
    lim = describe_context(ctx)
    max_w, max_h = lim["max_viewport_dims"]
    max_tex = lim["max_texture_size"]
    if w > min(max_w, max_tex) or h > min(max_h, max_tex):
        raise InvalidParameterError(
            f"output size {w}×{h} exceeds this GL's limits (viewport {max_w}×{max_h}, "
            f"texture {max_tex})"
        )
    return w, h


__all__ = [
    "RENDER_CHUNK",
    "TechniqueFallbackWarning",
    "TerrainRenderer",
    "as_texture_data",
    "check_output_size",
    "upload_texture",
]
