"""Benchmark: sun shadows of objects — stencil shadow volumes against cascaded shadow maps,
both against the exact CPU ray cast (``terrascape bench shadows``).

Full: 10 000 instanced trees and 200 buildings (the built-in meshes) on a 1025² fBm terrain
at 1280×720, daylight material technique. Quick: 1 000 trees and 20 buildings on 257² at
640×360.

* frame time without object shadows, with cascaded shadow maps and with stencil volumes
  (and the volumes without shadow caster culling, and those of the other reach: to
  infinity, or cut off at the lowest surface; ``DEFAULT_REACH`` is drawn),
  drawn interleaved (best of 3, each frame ends with ``ctx.finish()``);
* per-pixel agreement with :func:`terrascape.objects.shadow_reference.shadow_reference`:
  the volumes' stencil count exactly, and both modes from their pixels (a pixel counts as
  shadowed when it is darker than the frame without object shadows), away from shadow
  edges and on sun-facing ground the terrain does not shade — on frames with every object
  drawn as its mesh (the ray cast needs the surface point under each pixel; an impostor's
  quad lies inside its tree), and the cascades also on the frame as drawn, where no
  impostor covers the pixel;
* a sun moving 1° per frame with volumes (rebuilt every frame): the slowest frame against
  the median;
* the thesis' claim that volumes do not go with terrain LOD: the terrain's own shadow volumes
  (the silhouette of the terrain mesh toward the sun) at full detail and from a
  geomipmapping mesh, and the share of terrain pixels whose shadow changes.
"""

from __future__ import annotations

import math
import os
import statistics
import time
import warnings

import numpy as np

from terrascape.bench import BenchTable

TARGET_VOLUMES = 99.5  # % of pixels agreeing with the ray cast
TARGET_CASCADES = 98.0  # % away from contact edges
TARGET_CASCADE_COST = 1.5  # × the frame without object shadows
TARGET_VOLUME_COST = 2.0  # × the frame without object shadows
TARGET_SPIKE = 1.5  # slowest frame of a moving sun × the median
SUN = (135.0, 35.0)
# A pixel is shadowed in a frame when it is this much darker than without object shadows.
DARKER = 0.85
# the variant of the volumes of the reach that is not the default (ShadowVolumes.reach)
_REACH_LABEL = {"floor": "volumes, cut at the lowest surface", "infinite": "volumes to infinity"}


def _scene(n: int, trees: int, buildings: int):
    from terrascape.generate import fbm
    from terrascape.objects import Instances, builtin_meshes, surface_height

    hm = fbm(n, scale=300.0, octaves=6, amplitude=60.0, seed=3, spacing=2.0)
    meshes = builtin_meshes()
    kinds = ("conifer", "broadleaf", "house", "hall")
    rng = np.random.default_rng(11)
    w, d = hm.extent
    count = trees + buildings
    x = rng.uniform(0.04 * w, 0.96 * w, count)
    z = rng.uniform(0.04 * d, 0.96 * d, count)
    kind = np.r_[rng.integers(0, 2, trees), 2 + rng.integers(0, 2, buildings)]
    scale = np.r_[rng.uniform(0.7, 1.3, trees), rng.uniform(0.8, 1.1, buildings)]
    yaw = rng.uniform(0.0, 2 * math.pi, count)
    y = surface_height(hm, x, z)
    inst = Instances(tuple(meshes[k] for k in kinds), kind, np.c_[x, y, z], scale, yaw)
    return hm, inst


def _camera(hm, size):
    from terrascape.camera import Camera

    w, d = hm.extent
    target = np.array([0.5 * w, float(hm.heights.mean()), 0.55 * d])
    eye = np.array([0.5 * w, float(hm.max) + 0.06 * w, 0.9 * d])
    # the near plane as far out as the view allows (the nearest surface is ~0.06·w below
    # the eye): 24-bit depth then resolves the far forest to a few centimetres
    return Camera.look_at(tuple(eye), tuple(target), aspect=size[0] / size[1],
                          near=0.02 * w, far=2.0 * math.hypot(w, d))


def _luma(img: np.ndarray) -> np.ndarray:
    return img[..., :3].astype(np.float64).mean(axis=-1)


def _sun_facing(points: np.ndarray, sun_dir: np.ndarray) -> np.ndarray:
    """bool: pixels whose surface (normal from neighbouring pixels' points) faces the sun."""
    dx = np.gradient(points, axis=1)
    dy = np.gradient(points, axis=0)
    n = np.cross(dy, dx)
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    n *= np.where(n[..., 1:2] < 0, -1.0, 1.0)  # up-facing side for terrain pixels
    return np.nan_to_num(n @ sun_dir) > 0.2


class _Frames:
    """A TerrainRenderer with a stencil target; frames read back as uint8 images."""

    def __init__(self, ctx, hm, size):
        from terrascape.render.stencil import StencilFramebuffer
        from terrascape.render.terrain import TerrainRenderer

        self.ctx, self.size = ctx, size
        self.terrain = TerrainRenderer(ctx, hm)
        self.target = StencilFramebuffer(ctx, size)

    def render(self, camera, params) -> float:
        t0 = time.perf_counter()
        self.terrain.render(self.target.fbo, camera, "material", params)
        self.ctx.finish()
        return time.perf_counter() - t0

    def image(self) -> np.ndarray:
        w, h = self.size
        raw = self.target.fbo.read(components=4, alignment=1)
        return np.frombuffer(raw, np.uint8).reshape(h, w, 4)[::-1].copy()

    def release(self):
        self.target.release()
        self.terrain.release()


def _frame_and_agreement(frames: _Frames, hm, inst, camera, quick: bool) -> list[BenchTable]:
    from terrascape.lighting.sun import sun_direction
    from terrascape.objects.shadow_reference import agreement, boundary_band, shadow_reference
    from terrascape.render.shadow_volumes import DEFAULT_REACH, ShadowVolumes

    modes = ("none", "cascades", "volumes")
    base = {"sun": SUN}
    volumes = ShadowVolumes.of(frames.terrain)
    # the volumes as drawn (culled, the default reach), and the variants they are measured by
    other = "infinite" if DEFAULT_REACH == "floor" else "floor"
    variants = {"none": ("none", True, DEFAULT_REACH),
                "cascades": ("cascades", True, DEFAULT_REACH),
                "volumes": ("volumes", True, DEFAULT_REACH),
                "volumes, no caster culling": ("volumes", False, DEFAULT_REACH),
                _REACH_LABEL[other]: ("volumes", True, other)}
    best = {m: math.inf for m in variants}

    def frame(name):
        mode, cull, reach = variants[name]
        volumes.cull, volumes.reach = cull, reach
        return frames.render(camera, {**base, "object_shadows": mode})

    for name in variants:  # warm-up: shaders, textures, cascades, volumes
        frame(name)
    for _ in range(3):
        for name in variants:
            if variants[name][0] == "volumes":
                # each variant builds its own volumes: time the frames, not the rebuilds
                frame(name)
            best[name] = min(best[name], frame(name))
    frame("volumes")
    stats = dict(frames.terrain.last_stats)
    # The frames compared with the ray cast draw every object as its mesh: the reference
    # needs the true surface point under each pixel, and an impostor's quad passes through
    # the middle of its tree, where every ray toward the sun starts inside the tree. (The
    # cascades still cast small objects as impostors.) The frames as drawn, with
    # impostors, are compared below on the pixels no impostor covers.
    images = {}
    for m in modes:
        volumes.keep_count = m == "volumes"
        frames.render(camera, {**base, "object_shadows": m, "impostor_pixels": 0})
        images[m] = _luma(frames.image())
    count = volumes.last_count
    # the volumes of the other reach, counted on the same frame
    volumes.reach = other
    frames.render(camera, {**base, "object_shadows": "volumes", "impostor_pixels": 0})
    other_count = volumes.last_count
    volumes.reach = DEFAULT_REACH
    volumes.keep_count = False
    depth = frames.target.read_depth()
    mesh_camera = frames.terrain.last_camera  # volumes: drawn with an infinite far plane
    t0 = time.perf_counter()
    ref = shadow_reference(mesh_camera, depth, SUN, instances=inst, heightmap=hm)
    ref_s = time.perf_counter() - t0
    drawn = {}
    for m in ("none", "cascades"):
        frames.render(camera, {**base, "object_shadows": m})
        drawn[m] = _luma(frames.image())
    drawn_depth = frames.target.read_depth()
    drawn_ref = shadow_reference(camera, drawn_depth, SUN, instances=inst, heightmap=hm)
    # pixels an impostor covers (not its mesh): compared as eye distances, the two frames'
    # projections differ (the mesh frame's far plane is at infinity)
    mesh_distance = mesh_camera.eye_distance(depth)
    drawn_distance = frames.terrain.last_camera.eye_distance(drawn_depth)
    both = np.isfinite(mesh_distance) & np.isfinite(drawn_distance)
    quads = np.isfinite(mesh_distance) != np.isfinite(drawn_distance)
    quads[both] = (np.abs(drawn_distance[both] - mesh_distance[both])
                   > 1e-4 * mesh_distance[both])

    w, h = frames.size
    table = BenchTable(
        f"frame time by object shadow mode ({len(inst)} objects, {hm.cols}² terrain, "
        f"{w}×{h}, best of 3 interleaved)",
        ["mode", "ms/frame", "× no object shadows"])
    for m in variants:
        table.rows.append([m, 1e3 * best[m], best[m] / best["none"]])
    table.notes.append(
        f"volumes: {stats.get('shadow_volume_triangles', 0)} volume triangles of "
        f"{stats.get('shadow_volume_casters', 0)} casters, "
        f"{stats.get('shadow_volume_culled', 0)} culled (their shadows cannot reach the "
        f"view); objects "
        f"drawn: {stats.get('objects_meshes', 0)} meshes, "
        f"{stats.get('objects_impostors', 0)} impostors")
    table.check_target("cascades cost", best["cascades"] / best["none"],
                       at_most=TARGET_CASCADE_COST, unit="×")
    table.check_target("volumes cost", best["volumes"] / best["none"],
                       at_most=TARGET_VOLUME_COST, unit="×")

    surface = ref.surface
    band = boundary_band(ref.object_shadow, 2)
    eligible = (surface & ~band & ~ref.terrain_shadow
                & _sun_facing(ref.points, np.asarray(sun_direction(*SUN))))
    exact = 100.0 * agreement(count > 0, ref.object_shadow, surface)
    pix = {m: 100.0 * agreement(images[m] < DARKER * images["none"], ref.object_shadow,
                                eligible) for m in ("cascades", "volumes")}
    drawn_eligible = (drawn_ref.surface & ~quads & ~boundary_band(drawn_ref.object_shadow, 2)
                      & ~drawn_ref.terrain_shadow
                      & _sun_facing(drawn_ref.points, np.asarray(sun_direction(*SUN))))
    pix_drawn = 100.0 * agreement(drawn["cascades"] < DARKER * drawn["none"],
                                  drawn_ref.object_shadow, drawn_eligible)
    agree = BenchTable("agreement with the CPU ray cast (per pixel)",
                       ["mode", "what is compared", "pixels", "agree %"])
    agree.rows.append(["volumes", "stencil count ≠ 0 vs the ray hits an object, every "
                       "surface pixel", int(surface.sum()), exact])
    agree.rows.append([_REACH_LABEL[other], "the same", int(surface.sum()),
                       100.0 * agreement(other_count > 0, ref.object_shadow, surface)])
    for m in ("volumes", "cascades"):
        agree.rows.append([m, f"pixel darker than {DARKER:g}× the unshadowed frame, away "
                           "from shadow edges (2 px), sun-facing, not terrain-shaded "
                           "(objects drawn as meshes)", int(eligible.sum()), pix[m]])
    agree.rows.append(["cascades", "the same, the frame as drawn (impostors far away), on "
                       "the pixels no impostor covers", int(drawn_eligible.sum()), pix_drawn])
    diff = int(((other_count > 0) != (count > 0))[surface].sum())
    agree.notes.append(f"{_REACH_LABEL[other]}: {diff} surface pixels counted otherwise "
                       f"than by the volumes as drawn (reach {DEFAULT_REACH!r})")
    agree.notes.append(f"ray cast: {1e3 * ref_s:.0f} ms for {int(surface.sum())} pixels "
                       f"({int(ref.object_shadow.sum())} in object shadow); impostors cover "
                       f"{int(quads.sum())} pixels of the frame as drawn")
    agree.check_target("volumes agree with the ray cast", exact, at_least=TARGET_VOLUMES,
                       unit=" %")
    agree.check_target("cascades agree away from contact edges", pix["cascades"],
                       at_least=TARGET_CASCADES, unit=" %")
    return [table, agree]


def _moving_sun(frames: _Frames, camera, quick: bool) -> BenchTable:
    from terrascape.render.shadow_volumes import ShadowVolumes

    n = 6 if quick else 12
    volumes = ShadowVolumes.of(frames.terrain)
    times, builds = [], []
    for k in range(n + 1):
        sun = (SUN[0] + k, SUN[1])
        t = frames.render(camera, {"sun": sun, "object_shadows": "volumes"})
        if k:  # the first frame also builds what a new sun needs outside the volumes
            times.append(t)
            builds.append(volumes.build_seconds)
    med = statistics.median(times)
    table = BenchTable(f"a sun moving 1° per frame with volumes ({n} frames)",
                       ["frames", "median ms", "slowest ms", "slowest × median",
                        "volume rebuild ms (median)"])
    table.rows.append([n, 1e3 * med, 1e3 * max(times), max(times) / med,
                       1e3 * statistics.median(builds)])
    table.notes.append("every frame rebuilds the silhouettes of all objects (numba) and the "
                       "terrain's soft shadows for the new sun")
    table.check_target("slowest frame × median", max(times) / med, at_most=TARGET_SPIKE,
                       unit="×")
    return table


def _terrain_volume(hm, triangles: np.ndarray, sun_dir) -> np.ndarray:
    from terrascape.mesh import terrain_mesh
    from terrascape.objects import ObjectMesh
    from terrascape.objects.silhouette import OpenMeshWarning, mesh_volume

    mesh = terrain_mesh(hm)
    pos = mesh.positions.reshape(-1, 3)
    used = np.unique(triangles)
    remap = np.full(len(pos), -1, np.int64)
    remap[used] = np.arange(len(used))
    m = ObjectMesh("terrain", pos[used], np.tile([0.0, 1.0, 0.0], (len(used), 1)),
                   np.ones((len(used), 3)), remap[triangles])
    with warnings.catch_warnings():
        # the terrain's border is open: its lit faces' border edges close the volume
        warnings.simplefilter("ignore", OpenMeshWarning)
        return mesh_volume(m, np.eye(4)[None], sun_dir)


def _terrain_lod(ctx, hm, camera, size, quick: bool) -> BenchTable:
    """The terrain's own shadow volumes under LOD (the thesis: vanishing vertices take
    their shadows with them)."""
    from terrascape.lighting.sun import sun_direction
    from terrascape.lod.schemes import scheme
    from terrascape.mesh.terrain_mesh import grid_triangles
    from terrascape.objects.shadow_reference import agreement, shadow_reference
    from terrascape.render.shadow_volumes import ShadowVolumes

    sun_el = 12.0  # a low sun: long terrain shadows
    sun = (SUN[0], sun_el)
    d = np.asarray(sun_direction(*sun), np.float64)
    frames = _Frames(ctx, hm, size)
    volumes = ShadowVolumes.of(frames.terrain)
    full = grid_triangles(hm.rows, hm.cols).astype(np.int64)

    def mask(draw_tris, cast_tris):
        frames.terrain.set_indices(None if draw_tris is None else draw_tris)
        frames.render(camera, {"sun": sun, "object_shadows": "none", "shadows": False})
        volumes.set_triangles(_terrain_volume(hm, cast_tris, d))
        volumes.count(frames.target.fbo, camera.view_projection())
        from terrascape.render.stencil import read_stencil

        depth = frames.target.read_depth()
        return read_stencil(frames.target.fbo) > 0, depth

    table = BenchTable(
        f"terrain shadow volumes under LOD ({hm.cols}² terrain, sun {sun_el:g}° high, "
        f"{size[0]}×{size[1]})",
        ["casting mesh", "drawn mesh", "triangles", "terrain pixels", "shadowed %",
         "changed vs full detail %"])
    try:
        ref_mask, depth = mask(None, full)
        surface = depth < 1.0
        ref = shadow_reference(camera, depth, sun, heightmap=hm)
        table.rows.append(["full detail", "full detail", len(full), int(surface.sum()),
                           100.0 * ref_mask[surface].mean(), 0.0])
        agree_full = 100.0 * agreement(ref_mask, ref.terrain_shadow, surface)
        for tol in (2.0, 8.0):
            gm = scheme("geomipmap").build(hm)
            gm.update(camera, size, tolerance_px=tol)
            lod = gm.triangles().astype(np.int64)
            for drawn, label in ((None, "full detail"), (lod, "the same LOD")):
                m, dep = mask(drawn, lod)
                surf = dep < 1.0
                both = surface & surf
                table.rows.append([f"geomipmap {tol:g} px", label, len(lod), int(surf.sum()),
                                   100.0 * m[surf].mean(),
                                   100.0 * float((m[both] != ref_mask[both]).mean())])
        frames.terrain.set_indices(None)
    finally:
        frames.release()
    table.notes.append(
        f"full-detail terrain volumes agree with the CPU ray cast of the terrain on "
        f"{agree_full:.2f} % of terrain pixels (object shadows off; the frame's own soft "
        "terrain shadows off)")
    table.notes.append("'changed': pixels whose shadow (stencil count ≠ 0) differs from the "
                       "full-detail volumes on the full-detail terrain")
    return table


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.render.context import describe_context, headless_context

    n, size = (257, (640, 360)) if quick else (1025, (1280, 720))
    trees, buildings = (1000, 20) if quick else (10_000, 200)
    t0 = time.perf_counter()
    hm, inst = _scene(n, trees, buildings)
    camera = _camera(hm, size)
    tables: list[BenchTable] = []
    with headless_context() as ctx:
        frames = _Frames(ctx, hm, size)
        try:
            frames.terrain.set_objects(inst)
            tables += _frame_and_agreement(frames, hm, inst, camera, quick)
            tables.append(_moving_sun(frames, camera, quick))
        finally:
            frames.release()
        tables.append(_terrain_lod(ctx, hm, camera, size, quick))
        renderer = describe_context(ctx).get("renderer", "?")
    tables[0].notes.append(
        f"GL: {renderer}; load average {os.getloadavg()[0]:.2f} (shared machine); whole run "
        f"{time.perf_counter() - t0:.0f} s")
    return tables
