"""Drawing objects on the terrain: instanced meshes, distance LOD with impostors, and the
sun's cascaded shadow maps of objects and terrain together.

* Each mesh of an :class:`~terrascape.objects.model.Instances` set has one vertex buffer;
  all its instances are drawn in one instanced call from a per-instance buffer of foot
  position, scale and yaw (the transform of ``Instances.matrices()``).
* Every frame the instances are culled against the view frustum on the CPU (bounding
  spheres, vectorised numpy) and split by projected size: an object smaller on screen than
  ``impostor_pixels`` is drawn as an impostor — a quad facing the viewer, textured from an
  atlas of the mesh rendered once from a hemisphere of directions (8 around it at each of
  4 elevations, 0° to straight above; Maciel & Shirley 1995), with normals, so it is lit
  like the mesh; the four atlas views around the viewer's direction are blended — seen
  from above (40° to 70° and up) each sampled where it saw the point the viewing ray meets
  (its plane through the middle of the mesh), so views a turn apart line up.
* ``object_shadows="cascades"``: the sun's cascaded shadow maps
  (:mod:`terrascape.render.cascades`) drawn from the objects (meshes near, sun-facing
  impostors far), looked up by the terrain's and the objects' shading
  (``common/cascades.glsl``). The terrain's shadow on the terrain stays its own ray-cast
  sweep, and on objects it is ray-cast per pixel through the height texture toward the sun
  (``objects/common/object_shading.glsl``): exact, and on llvmpipe far cheaper than drawing
  the terrain's 2 M triangles into every cascade. ``cascade_terrain=True`` draws the
  terrain into the cascades too (a grid thinned to each cascade's texel size) — the
  "cascades for everything" variant, for comparison. ``"none"``: objects cast no shadow
  (they still receive the terrain's).

References
----------
Maciel, P. W. C. & Shirley, P. (1995). Visual navigation of large environments using
textured clusters. *Proc. ACM I3D*, 95-102.

Engel, W. (2006). Cascaded shadow maps. In *ShaderX5*, 197-206.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.objects.model import Instances, ObjectMesh
from terrascape.render.cascades import fit_cascades
from terrascape.render.shaders import load_program, set_uniforms

OBJECT_SHADOW_MODES = ("cascades", "volumes", "none")
IMPOSTOR_VIEWS = 8  # atlas views around each mesh, at each elevation
# Elevations (degrees) of the atlas views, evenly spaced from the side to straight above
IMPOSTOR_ELEVATIONS = (0.0, 30.0, 60.0, 90.0)
IMPOSTOR_CELL = 128
CASCADE_COUNT = 3
# an object shorter than this many texels of a cascade casts into it as an impostor
SHADOW_IMPOSTOR_TEXELS = 24.0
# Texture units of the objects' own textures (below the terrain's daylight units 10-14 and
# the spare units from 16; technique samplers count up from 0).
_ATLAS_COLOR_UNIT = 8
_ATLAS_NORMAL_UNIT = 9
_SUN_SKY_UNIT = 10
_HEIGHT_UNIT = 11
CASCADE_UNIT = 17  # after the sky table (15) and the spare unit (16)
_INSTANCE_BYTES = 20  # vec4 place + float yaw
# Terrain caster blocks: at most this many cells per side (16-bit indices, cheap culling).
_CASTER_BLOCK = 64


class ObjectShadowFallbackWarning(UserWarning):
    """An object shadow mode is not available here; another one was drawn instead."""


def resolve_object_shadows(value: Any, has_objects: bool) -> str:
    """The object shadow mode of a frame: ``None`` means cascades with objects, else none."""
    if value is None:
        return "cascades" if has_objects else "none"
    if value not in OBJECT_SHADOW_MODES:
        raise InvalidParameterError(
            f"object_shadows must be one of {', '.join(OBJECT_SHADOW_MODES)}, got {value!r}")
    return value if has_objects else "none"


def cascade_resolution(value: Any, viewport) -> int:
    """Texels per side of each cascade: ``value``, or (``None``) the frame's height rounded
    up to a power of two, 512 to 2048 — about one texel per pixel in the nearest slice; on
    a software rasteriser clearing and filling the maps is most of their cost."""
    if value is None:
        return int(min(2048, max(512, 1 << max(int(viewport[1]) - 1, 1).bit_length())))
    res = int(value) if isinstance(value, (int, np.integer)) else -1
    if not 16 <= res <= 8192:
        raise InvalidParameterError(f"cascade_resolution must be an integer in [16, 8192], "
                                    f"got {value!r}")
    return res


def sphere_in_frustum(planes: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """bool ``(N,)``: spheres not entirely outside one of the six inward frustum planes
    ``(a, b, c, d)`` (:meth:`~terrascape.camera.Camera.frustum_planes`)."""
    dist = centres @ planes[:, :3].T + planes[:, 3]
    return np.all(dist >= -radii[:, None], axis=1)


def impostor_mask(camera: Camera, centres: np.ndarray, heights: np.ndarray,
                  viewport_height: int, impostor_pixels: float) -> np.ndarray:
    """bool ``(N,)``: objects drawn as impostors — their height projects to fewer than
    ``impostor_pixels`` pixels (from any elevation: the atlas holds views from the side to
    straight above). None when ``impostor_pixels`` is 0."""
    if impostor_pixels <= 0:
        return np.zeros(len(centres), bool)
    dist = np.linalg.norm(camera.eye - centres, axis=1)
    return heights * camera.pixels_per_radian(viewport_height) < impostor_pixels * dist


def impostor_up_range(radius: float, y0: float, y1: float) -> tuple[float, float]:
    """The range of the quad's "up" coordinate that holds the mesh seen from every atlas
    elevation θ: a cylinder of ``radius`` over y0…y1 spans y0·cos θ − r·sin θ …
    y1·cos θ + r·sin θ along the up axis of a view from θ."""
    lo, hi = math.inf, -math.inf
    for el in IMPOSTOR_ELEVATIONS:
        c, s = math.cos(math.radians(el)), math.sin(math.radians(el))
        lo, hi = min(lo, y0 * c - radius * s), max(hi, y1 * c + radius * s)
    return lo, hi


def _bake_matrix(view: int, views: int, elevation: float, radius: float,
                 up_range: tuple[float, float], mid: float, depth_radius: float) -> np.ndarray:
    """Orthographic camera of atlas view ``view`` at ``elevation`` degrees: from direction
    d = (sin φ cos θ, sin θ, cos φ cos θ) in the mesh's frame, x along the horizontal right
    (cos φ, 0, −sin φ) over [-radius, radius], y along up = d × right over ``up_range``,
    depth along d within ``depth_radius`` of the point (0, mid, 0). The impostor quad
    (objects/impostor.glsl) spans the same coordinates."""
    phi = 2.0 * math.pi * view / views
    el = math.radians(elevation)
    d = np.array([math.sin(phi) * math.cos(el), math.sin(el), math.cos(phi) * math.cos(el)])
    right = np.array([math.cos(phi), 0.0, -math.sin(phi)])
    up = np.cross(d, right)
    u0, u1 = up_range
    m = np.zeros((4, 4))
    m[0, :3] = right / radius
    m[1, :3] = up * (2.0 / (u1 - u0))
    m[1, 3] = -(u1 + u0) / (u1 - u0)
    m[2, :3] = -d / depth_radius  # nearer to the viewer = smaller depth
    m[2, 3] = mid * math.sin(el) / depth_radius
    m[3, 3] = 1.0
    return m


class _MeshGPU:
    """One mesh's buffers and its static per-instance data."""

    def __init__(self, ctx, mesh: ObjectMesh, index: int, inst: Instances) -> None:
        self.mesh = mesh
        self.index = index
        self.vbos = [ctx.buffer(np.ascontiguousarray(a, np.float32).tobytes())
                     for a in (mesh.positions, mesh.normals, mesh.colors)]
        self.ibo = ctx.buffer(np.ascontiguousarray(mesh.indices, np.uint32).tobytes())
        p = mesh.positions.astype(np.float64)
        self.radius_xz = max(float(np.sqrt(p[:, 0] ** 2 + p[:, 2] ** 2).max()), 1e-6)
        y0, y1 = float(p[:, 1].min()), float(p[:, 1].max())
        if y1 - y0 < 1e-6:
            y1 = y0 + 1e-6
        self.y_range = (y0, y1)
        mid = 0.5 * (y0 + y1)
        radius = float(np.sqrt(p[:, 0] ** 2 + (p[:, 1] - mid) ** 2 + p[:, 2] ** 2).max())
        self.mid = mid
        self.sphere_radius = max(radius, 1e-6)
        self.up_range = impostor_up_range(self.radius_xz, y0, y1)
        sel = inst.of_kind(index)
        scale = inst.scale[sel].astype(np.float64)
        self.count = len(sel)
        self.data = np.ascontiguousarray(
            np.c_[inst.positions[sel], inst.scale[sel], inst.yaw[sel]].astype(np.float32))
        self.centres = inst.positions[sel].astype(np.float64) + np.c_[
            np.zeros(len(sel)), mid * scale, np.zeros(len(sel))]
        self.radii = radius * scale
        self.heights = (y1 - y0) * scale
        self.buffers: dict[str, Any] = {}
        self.vaos: dict[tuple, Any] = {}

    def buffer(self, ctx, slot: str):
        buf = self.buffers.get(slot)
        if buf is None:
            buf = self.buffers[slot] = ctx.buffer(reserve=max(self.count, 1) * _INSTANCE_BYTES,
                                                  dynamic=True)
        return buf

    def release(self) -> None:
        for vao in self.vaos.values():
            vao.release()
        for buf in [*self.vbos, self.ibo, *self.buffers.values()]:
            buf.release()


class ObjectRenderer:
    """Draws one :class:`~terrascape.objects.model.Instances` set on a
    :class:`~terrascape.render.terrain.TerrainRenderer`'s context (made by
    :meth:`TerrainRenderer.set_objects <terrascape.render.terrain.TerrainRenderer.set_objects>`,
    which calls it inside its frame)."""

    def __init__(self, terrain, instances: Instances) -> None:
        if not isinstance(instances, Instances):
            raise InvalidParameterError(
                f"objects must be an Instances set, got {type(instances).__name__}")
        self.terrain = terrain
        self.ctx = terrain.ctx
        self.instances = instances
        self.meshes = [_MeshGPU(self.ctx, m, k, instances) for k, m in enumerate(instances.meshes)]
        self._corner_vbo = self.ctx.buffer(
            np.array([-1, 0, 1, 0, -1, 1, 1, 1], np.float32).tobytes())
        self._atlas = self._bake_atlas()
        self._shadow: tuple | None = None  # (resolution, count, texture, fbo)
        self._casters: dict[int, list] = {}  # terrain caster blocks per grid stride
        self.cascades = None  # the last frame's Cascades (tests, benchmarks)
        self.mode = "none"
        self.enabled = True  # False: kept on the GPU but not drawn (the viewer's toggle)
        self._terrain_shadows = True
        self._params: Mapping[str, Any] | None = None
        self.last_stats: dict[str, int] = {}
        self._view_sets: list[tuple[int, int]] = []

    # --- impostor atlas ---------------------------------------------------------------
    def _bake_atlas(self):
        """Render every mesh from IMPOSTOR_VIEWS directions at each of IMPOSTOR_ELEVATIONS
        into a colour and a normal atlas (per mesh one row of cells per elevation),
        premultiplied by coverage (the background is 0)."""
        import moderngl

        ctx = self.ctx
        views, cell = IMPOSTOR_VIEWS, IMPOSTOR_CELL
        rows = len(IMPOSTOR_ELEVATIONS)
        size = (views * cell, len(self.meshes) * rows * cell)
        # half floats: 4 elevations × 8 views of 128² per mesh, premultiplied values in
        # [-1, 1] — 11 bits of mantissa are far below what a 128-texel cell resolves
        colour = ctx.texture(size, 4, dtype="f2")
        normal = ctx.texture(size, 4, dtype="f2")
        depth = ctx.depth_renderbuffer(size)
        fbo = ctx.framebuffer(color_attachments=[colour, normal], depth_attachment=depth)
        prog = load_program(ctx, "objects/bake")
        fbo.use()
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        for m in self.meshes:
            vao = ctx.vertex_array(prog, [(m.vbos[0], "3f", "in_position"),
                                          (m.vbos[1], "3f", "in_normal"),
                                          (m.vbos[2], "3f", "in_color")], m.ibo, 4)
            for j, el in enumerate(IMPOSTOR_ELEVATIONS):
                for k in range(views):
                    ctx.viewport = (k * cell, (m.index * rows + j) * cell, cell, cell)
                    set_uniforms(prog, u_bake=_bake_matrix(
                        k, views, el, m.radius_xz, m.up_range, m.mid, m.sphere_radius))
                    vao.render(moderngl.TRIANGLES)
            vao.release()
        fbo.release()
        depth.release()
        for tex in (colour, normal):
            tex.build_mipmaps()
            tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = False
        return colour, normal

    def atlas_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """float32 ``(rows, cols, 4)`` colour and normal atlases (row 0 = bottom)."""
        out = []
        for tex in self._atlas:
            w, h = tex.size
            out.append(np.frombuffer(tex.read(), np.float16).reshape(h, w, 4).astype(np.float32))
        return out[0], out[1]

    # --- per-frame selection ------------------------------------------------------------
    def _upload(self, m: _MeshGPU, slot: str, idx: np.ndarray) -> int:
        if idx.size:
            m.buffer(self.ctx, slot).write(m.data[idx].tobytes())
        return int(idx.size)

    def _vao(self, program, m: _MeshGPU, slot: str, impostor: bool):
        key = (program.glo, slot, impostor)
        vao = m.vaos.get(key)
        if vao is None:
            inst = (m.buffer(self.ctx, slot), "4f 1f/i", "in_place", "in_yaw")
            if impostor:
                vao = self.ctx.vertex_array(program, [(self._corner_vbo, "2f", "in_corner"),
                                                      inst], skip_errors=True)
            else:
                vao = self.ctx.vertex_array(
                    program, [(m.vbos[0], "3f", "in_position"), (m.vbos[1], "3f", "in_normal"),
                              (m.vbos[2], "3f", "in_color"), inst], m.ibo, 4, skip_errors=True)
            m.vaos[key] = vao
        return vao

    def _draw_sets(self, sets, programs, slot: str, uniforms: Mapping[str, Any],
                   facing) -> int:
        """Draw per mesh its instances ``sets[k] = (mesh idx, impostor idx)``."""
        import moderngl

        mesh_prog, imp_prog = programs
        set_uniforms(mesh_prog, **uniforms)
        set_uniforms(imp_prog, **uniforms)
        rows = len(IMPOSTOR_ELEVATIONS)
        cells = (float(IMPOSTOR_VIEWS), float(len(self.meshes) * rows))
        set_uniforms(imp_prog, u_facing=facing, u_views=float(IMPOSTOR_VIEWS),
                     u_elevations=float(rows), u_atlas_cells=cells,
                     u_atlas_color=_ATLAS_COLOR_UNIT, u_atlas_normal=_ATLAS_NORMAL_UNIT)
        self._atlas[0].use(location=_ATLAS_COLOR_UNIT)
        self._atlas[1].use(location=_ATLAS_NORMAL_UNIT)
        drawn = 0
        for m, (near, far) in zip(self.meshes, sets, strict=True):
            n = self._upload(m, slot + "m", near)
            if n:
                self._vao(mesh_prog, m, slot + "m", False).render(moderngl.TRIANGLES,
                                                                    instances=n)
                drawn += n * m.mesh.triangles
            n = self._upload(m, slot + "i", far)
            if n:
                set_uniforms(imp_prog, u_radius=m.radius_xz, u_up_range=m.up_range,
                             u_mid=m.mid, u_atlas_row=float(m.index * rows))
                self._vao(imp_prog, m, slot + "i", True).render(moderngl.TRIANGLE_STRIP,
                                                                  vertices=4, instances=n)
                drawn += 2 * n
        return drawn

    # --- shadows --------------------------------------------------------------------
    def scene_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World AABB of the terrain (as drawn) and every object."""
        t = self.terrain
        ex, ez = t.mesh.extent
        lo = np.array([0.0, t.world.min, 0.0])
        hi = np.array([ex, t.world.max, ez])
        for m in self.meshes:
            if m.count:
                lo = np.minimum(lo, (m.centres - m.radii[:, None]).min(axis=0))
                hi = np.maximum(hi, (m.centres + m.radii[:, None]).max(axis=0))
        return lo, hi

    def _shadow_target(self, resolution: int, count: int):
        import moderngl

        if self._shadow is not None and self._shadow[:2] == (resolution, count):
            return self._shadow
        self._release_shadow()
        limit = self.terrain.limits["max_texture_size"]
        if resolution * count > limit:
            raise InvalidParameterError(
                f"cascade_resolution {resolution} × {count} cascades exceeds this GL's "
                f"texture size {limit}")
        tex = self.ctx.depth_texture((resolution * count, resolution))
        tex.compare_func = "<="
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        fbo = self.ctx.framebuffer(depth_attachment=tex)
        self._shadow = (resolution, count, tex, fbo)
        return self._shadow

    def _release_shadow(self) -> None:
        if self._shadow is not None:
            self._shadow[3].release()
            self._shadow[2].release()
            self._shadow = None

    def _caster_blocks(self, stride: int) -> list:
        """The terrain grid thinned to every ``stride``-th vertex (last row and column kept),
        in blocks of at most _CASTER_BLOCK cells: (vertex array, bbox lo, bbox hi)."""
        have = self._casters.get(stride)
        if have is not None:
            return have
        mesh = self.terrain.mesh
        grid = mesh.positions.reshape(mesh.rows, mesh.cols, 3)
        rows = np.unique(np.r_[np.arange(0, mesh.rows, stride), mesh.rows - 1])
        cols = np.unique(np.r_[np.arange(0, mesh.cols, stride), mesh.cols - 1])
        sub = grid[rows][:, cols]
        prog = load_program(self.ctx, "objects/terrain_depth")
        blocks = []
        b = _CASTER_BLOCK
        for r0 in range(0, len(rows) - 1, b):
            for c0 in range(0, len(cols) - 1, b):
                tile = np.ascontiguousarray(sub[r0:r0 + b + 1, c0:c0 + b + 1], np.float32)
                h, w = tile.shape[:2]
                a = (np.arange(h - 1)[:, None] * w + np.arange(w - 1)[None, :]).reshape(-1)
                idx = np.stack([a, a + w, a + 1, a + 1, a + w, a + w + 1], axis=1)
                vbo = self.ctx.buffer(tile.tobytes())
                ibo = self.ctx.buffer(idx.astype(np.uint16).tobytes())
                vao = self.ctx.vertex_array(prog, [(vbo, "3f", "in_position")], ibo, 2)
                flat = tile.reshape(-1, 3)
                blocks.append((vao, vbo, ibo, flat.min(axis=0), flat.max(axis=0)))
        self._casters[stride] = blocks
        return blocks

    def _draw_terrain_caster(self, matrix: np.ndarray, texel: float) -> int:
        """The terrain into one cascade, from the grid thinned to about its texel size."""
        import moderngl

        spacing = min(self.terrain.heightmap.spacing)
        stride = 1
        while stride * 2 * spacing <= texel and stride < 64:
            stride *= 2
        prog = load_program(self.ctx, "objects/terrain_depth")
        set_uniforms(prog, u_view_proj=matrix)
        tris = 0
        for vao, _, _, lo, hi in self._caster_blocks(stride):
            corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                for z in (lo[2], hi[2])])
            clip = corners @ matrix.T
            if (clip[:, 0] > 1).all() or (clip[:, 0] < -1).all() or (clip[:, 1] > 1).all() \
                    or (clip[:, 1] < -1).all():
                continue
            vao.render(moderngl.TRIANGLES)
            tris += vao.vertices // 3
        return tris

    def _render_cascades(self, camera: Camera, viewport, params: Mapping[str, Any],
                         sun_dir: np.ndarray) -> dict[str, Any]:
        import moderngl

        resolution = cascade_resolution(params.get("cascade_resolution"), viewport)
        lo, hi = self.scene_bounds()
        cascades = fit_cascades(camera, sun_dir, lo, hi, count=CASCADE_COUNT,
                                resolution=resolution)
        self.cascades = cascades
        res, count, _, fbo = self._shadow_target(resolution, CASCADE_COUNT)
        ctx = self.ctx
        fbo.use()
        ctx.scissor = None
        fbo.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)  # thin and open meshes cast from both sides
        ctx.polygon_offset = (1.5, 2.0)  # slope-scaled bias against self-shadowing
        mesh_prog = load_program(ctx, "objects/mesh", {"DEPTH_ONLY": 1})
        imp_prog = load_program(ctx, "objects/impostor", {"DEPTH_ONLY": 1})
        stats = {"shadow_terrain_triangles": 0, "shadow_object_triangles": 0}
        try:
            for k in range(count):
                ctx.viewport = (k * res, 0, res, res)
                mat = cascades.matrices[k]
                if params.get("cascade_terrain"):
                    stats["shadow_terrain_triangles"] += self._draw_terrain_caster(
                        mat, float(cascades.texel_size[k]))
                sets = self._light_sets(mat, float(cascades.texel_size[k]))
                stats["shadow_object_triangles"] += self._draw_sets(
                    sets, (mesh_prog, imp_prog), f"c{k}", {"u_view_proj": mat},
                    (*sun_dir, 0.0))
        finally:
            ctx.polygon_offset = (0.0, 0.0)
        self.last_stats.update(stats)
        far = np.zeros(4)
        far[:count] = cascades.splits[1:]
        texel = np.zeros(4)
        texel[:count] = cascades.texel_size
        bias = np.zeros(4)
        bias[:count] = 0.5 * cascades.texel_size / cascades.depth_range
        mats = np.zeros((4, 4, 4))
        mats[:count] = cascades.matrices
        return {"u_cascade_count": count, "u_cascade_matrix": np.ascontiguousarray(
                    mats.transpose(0, 2, 1)).reshape(-1),
                "u_cascade_far": far, "u_cascade_texel": texel, "u_cascade_bias": bias,
                "u_cascade_eye": camera.eye, "u_cascade_forward": camera.forward}

    def _light_sets(self, matrix: np.ndarray, texel: float) -> list:
        """Per mesh, the instances inside a cascade's box (x, y in light clip space; every
        depth toward the sun casts) as (meshes, impostors): an impostor where the view
        draws one (an object out of view casts at the LOD of its distance), and where the
        object spans fewer than SHADOW_IMPOSTOR_TEXELS texels of this cascade (its mesh
        would add triangles, not detail)."""
        s = float(np.linalg.norm(matrix[0, :3]))
        out = []
        for m, far in zip(self.meshes, self._far_flag, strict=True):
            if m.count == 0:
                out.append((np.zeros(0, int), np.zeros(0, int)))
                continue
            clip = m.centres @ matrix[:2, :3].T + matrix[:2, 3]
            inside = np.all(np.abs(clip) <= 1.0 + (m.radii * s)[:, None], axis=1)
            idx = np.flatnonzero(inside)
            coarse = far[idx] | (m.heights[idx] < SHADOW_IMPOSTOR_TEXELS * texel)
            out.append((idx[~coarse], idx[coarse]))
        return out

    # --- the frame ----------------------------------------------------------------------
    def begin_frame(self, camera: Camera, viewport, params: Mapping[str, Any],
                    sun_dir) -> dict[str, Any]:
        """Before the terrain is drawn: pick the shadow mode, render the cascades (they
        bind their own framebuffer and viewport) and return the uniforms the terrain's and
        the objects' shading read."""
        # an empty set still shadows with cascades (with cascade_terrain: the terrain alone)
        mode = resolve_object_shadows(params.get("object_shadows"), True)
        # "volumes" reaches here only on a target with a stencil buffer (the renderer
        # falls back to cascades otherwise); terrascape.render.shadow_volumes draws them.
        self.mode = mode
        self._params = params  # draw() binds the frame's sky table from them
        self._terrain_shadows = bool(params.get("shadows", True))
        impostor_pixels = float(params.get("impostor_pixels", 48.0))
        if not math.isfinite(impostor_pixels) or impostor_pixels < 0:
            raise InvalidParameterError(
                f"impostor_pixels must be >= 0 (0 = never), got {impostor_pixels}")
        self.last_stats = {}
        # the LOD of every instance from the view camera (the shadow passes use it too)
        self._far_flag = [impostor_mask(camera, m.centres, m.heights, viewport[1],
                                        impostor_pixels) for m in self.meshes]
        self._view_sets = [(vis[~far[vis]], vis[far[vis]])
                           for far, vis in zip(self._far_flag, self._visible(camera),
                                               strict=True)]
        if mode == "cascades":
            return self._render_cascades(camera, viewport, params, np.asarray(sun_dir))
        self.cascades = None
        return {"u_cascade_count": 0}

    def _visible(self, camera: Camera) -> list[np.ndarray]:
        planes = camera.frustum_planes()
        return [np.flatnonzero(sphere_in_frustum(planes, m.centres, m.radii)) if m.count
                else np.zeros(0, int) for m in self.meshes]

    def bind_receiver(self, program) -> None:
        """The cascade depth texture for a program that reads common/cascades.glsl."""
        if self._shadow is not None and self.mode == "cascades" and \
                "u_cascade_depth" in program:
            self._shadow[2].use(location=CASCADE_UNIT)
            program["u_cascade_depth"].value = CASCADE_UNIT

    def draw(self, uniforms: Mapping[str, Any], *, impostors: bool = True) -> dict[str, int]:
        """After the terrain (depth-tested against it): every visible object, meshes near and
        impostors far (``impostors=False``: the meshes only), lit like the terrain."""
        import moderngl

        ctx = self.ctx
        mesh_prog = load_program(ctx, "objects/mesh")
        imp_prog = load_program(ctx, "objects/impostor")
        env = self.terrain._env
        sun_sky, height = env.get("u_sun_sky"), env.get("u_height")
        extra = {"u_has_sun_sky": int(sun_sky is not None), "u_sun_sky": _SUN_SKY_UNIT,
                 "u_has_height": int(height is not None), "u_height": _HEIGHT_UNIT,
                 "u_shadow_march": int(self._terrain_shadows)}
        if sun_sky is not None:
            sun_sky[0].use(location=_SUN_SKY_UNIT)
        if height is not None:
            height[0].use(location=_HEIGHT_UNIT)
        for prog in (mesh_prog, imp_prog):
            set_uniforms(prog, **extra)
            # common/atmosphere.glsl reads the frame's sky table: without it the haze and
            # sky light of every object sample whatever sits on texture unit 0
            if self._params is not None:
                self.terrain._use_sky_lut(prog, self._params)
            self.bind_receiver(prog)
            if self.mode != "cascades":
                set_uniforms(prog, u_cascade_count=0)
                if "u_cascade_depth" in prog:
                    prog["u_cascade_depth"].value = CASCADE_UNIT + 1  # a unit of its own
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.front_face = "ccw"
        cam = uniforms["u_camera_pos"]
        sets = self._view_sets if impostors else [(near, far[:0])
                                                  for near, far in self._view_sets]
        drawn = self._draw_sets(sets, (mesh_prog, imp_prog), "v", uniforms, (*cam, 1.0))
        ctx.disable(moderngl.CULL_FACE)
        stats = {"objects_meshes": int(sum(len(a) for a, _ in self._view_sets)),
                 "objects_impostors": int(sum(len(b) for _, b in self._view_sets)),
                 "objects_triangles": drawn}
        self.last_stats.update(stats)
        return dict(self.last_stats)

    def release(self) -> None:
        for m in self.meshes:
            m.release()
        self._corner_vbo.release()
        for tex in self._atlas:
            tex.release()
        self._release_shadow()
        for blocks in self._casters.values():
            for vao, vbo, ibo, _, _ in blocks:
                vao.release()
                vbo.release()
                ibo.release()
        self._casters.clear()


__all__ = [
    "CASCADE_COUNT",
    "IMPOSTOR_ELEVATIONS",
    "OBJECT_SHADOW_MODES",
    "ObjectRenderer",
    "ObjectShadowFallbackWarning",
    "cascade_resolution",
    "impostor_mask",
    "impostor_up_range",
    "resolve_object_shadows",
    "sphere_in_frustum",
]
