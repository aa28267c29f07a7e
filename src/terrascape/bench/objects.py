"""Objects benchmark: the frame time of a forest with buildings on the terrain — without
objects, with objects but no object shadows, and with the sun's cascaded shadow maps —
drawn interleaved frame by frame along a fixed camera path (headless EGL; on llvmpipe this
measures the CPU).

Full: 10 000 trees and 200 buildings on a 1025² terrain at 1280×720. Quick: 2 000 trees and
40 buildings on 257² at 640×360. :func:`bench_scene` and :func:`frame_times` are shared
with the shadow benchmark (its cascades row).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from terrascape.bench import BenchTable

TREES = ("conifer", "broadleaf")
BUILDINGS = ("house", "hall")
PATH_FRAMES = 4
TARGET = 1.5  # cascades: at most this × the frame without object shadows
MODES = (
    ("no objects", None),
    ("objects, no object shadows", {"object_shadows": "none"}),
    ("objects + cascaded shadow maps", {"object_shadows": "cascades"}),
)


def bench_scene(quick: bool = False, *, seed: int = 1):
    """``(heightmap, instances, size)``: the benchmark's terrain, its trees and buildings
    (uniformly placed, seeded, on the drawn surface) and the frame size."""
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.objects import Instances, builtin_meshes, surface_height

    side, size, n_trees, n_buildings = ((257, (640, 360), 2000, 40) if quick
                                        else (1025, (1280, 720), 10_000, 200))
    hm = generate("fbm", side, seed=seed, spacing=VIEW_SPACING)
    meshes = builtin_meshes()
    names = [*TREES, *BUILDINGS]
    rng = np.random.default_rng(seed)
    n = n_trees + n_buildings
    kind = np.r_[rng.integers(0, len(TREES), n_trees),
                 len(TREES) + rng.integers(0, len(BUILDINGS), n_buildings)]
    ex, ez = hm.extent
    x = rng.uniform(0.02 * ex, 0.98 * ex, n)
    z = rng.uniform(0.02 * ez, 0.98 * ez, n)
    y = surface_height(hm, x, z)
    inst = Instances(tuple(meshes[k] for k in names), kind, np.c_[x, y, z],
                     rng.uniform(0.7, 1.3, n), rng.uniform(0.0, 2.0 * np.pi, n))
    return hm, inst, size


def camera_path(renderer, n: int = PATH_FRAMES):
    """The landscape view from four sides (a low camera: near objects and far impostors)."""
    return [renderer.default_camera(azimuth=180.0 + 90.0 * k) for k in range(n)]


def frame_times(renderer, cams, params, technique: str = "material") -> list[float]:
    """Seconds per frame (``ctx.finish()`` included) for each camera."""
    out = []
    for cam in cams:
        t0 = time.perf_counter()
        renderer.render(cam, technique, params)
        renderer.ctx.finish()
        out.append(time.perf_counter() - t0)
    return out


def terrain_shadow_agreement(quick: bool = False) -> BenchTable:
    """The terrain's shadow on itself, per visible grid sample, against the CPU ray cast
    (:func:`~terrascape.lighting.shadows.shadow_mask_reference`): its own shadow sweep (the
    default) and the sun's cascades with the terrain drawn into them (``cascade_terrain``,
    the sweep off). Samples next to a shadow edge of the reference are left out."""
    from scipy.ndimage import binary_dilation, binary_erosion

    from terrascape.camera import frame_terrain
    from terrascape.lighting.shadows import shadow_mask_reference
    from terrascape.objects import Instances, builtin_meshes
    from terrascape.render.context import headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    hm, _, size = bench_scene(quick)
    sun = (135.0, 25.0)
    ref = shadow_mask_reference(hm, *sun)  # True = in shadow
    edge = binary_dilation(ref, iterations=1) & ~binary_erosion(ref, iterations=1)
    cam = frame_terrain(hm.extent, (hm.min, hm.max), azimuth=200.0, elevation=70.0,
                        aspect=size[0] / size[1])
    zz, xx = np.meshgrid(np.arange(hm.rows) * hm.spacing[1],
                         np.arange(hm.cols) * hm.spacing[0], indexing="ij")
    px = cam.project(np.stack([xx, hm.heights, zz], -1).reshape(-1, 3), size)
    col = np.floor(px[:, 0]).astype(int).reshape(hm.shape)
    row = np.floor(px[:, 1]).astype(int).reshape(hm.shape)
    inside = (row >= 0) & (row < size[1]) & (col >= 0) & (col < size[0])
    # a cast shadow shows only where the sun would light the surface well: leave out
    # slopes turned from the sun (N·L < 0.3), dark with or without any shadow
    from terrascape.lighting.sun import sun_direction

    gz, gx = np.gradient(hm.heights.astype(np.float64), hm.spacing[1], hm.spacing[0])
    normal = np.stack([-gx, np.ones_like(gx), -gz], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    keep = inside & ~edge & (normal @ sun_direction(*sun) > 0.3)
    empty = Instances((builtin_meshes()["rock"],), np.zeros(0, int), np.zeros((0, 3)),
                      np.zeros(0), np.zeros(0))
    variants = (
        ("terrain sweep (default)", {"shadows": True}),
        ("cascades with the terrain in them", {"shadows": False, "cascade_terrain": True,
                                               "object_shadows": "cascades"}),
    )
    table = BenchTable("the terrain's shadow on itself vs a CPU ray cast",
                       ["method", "agreement %", "samples", "shadowed %"])
    with headless_context() as ctx:
        r = OffscreenRenderer(ctx, hm, size=size)
        try:
            lit = r.render(cam, "plain", {"sun": sun, "shadows": False, "haze": 0.0})
            r.terrain.set_objects(empty)
            for label, params in variants:
                img = r.render(cam, "plain", {"sun": sun, "haze": 0.0, **params})
                ratio = (img[..., :3].astype(float).sum(-1)
                         / np.maximum(lit[..., :3].astype(float).sum(-1), 1.0))
                measured = ratio[np.clip(row, 0, size[1] - 1), np.clip(col, 0, size[0] - 1)]
                shadowed = measured < 0.8
                agree = float((shadowed[keep] == ref[keep]).mean()) * 100.0
                table.rows.append([label, round(agree, 2), int(keep.sum()),
                                   round(float(ref[keep].mean()) * 100.0, 1)])
        finally:
            r.release()
    table.notes.append(f"sun azimuth {sun[0]}°, elevation {sun[1]}°; overhead view at 70°; "
                       "a sample counts as shadowed below 80 % of its fully lit brightness")
    return table


def bird_path(renderer, n: int = 2):
    """Views from 55° above (the bird's-eye view of a map): far objects are impostors there
    too (the atlas holds views from the side to straight above)."""
    return [renderer.default_camera(azimuth=200.0 + 90.0 * k, elevation=55.0)
            for k in range(n)]


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.render.context import describe_context, headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    hm, inst, size = bench_scene(quick)
    tables = []
    with headless_context() as ctx:
        info = describe_context(ctx)
        bare = OffscreenRenderer(ctx, hm, size=size)  # the same terrain, never any objects
        r = OffscreenRenderer(ctx, hm, size=size)
        try:
            t0 = time.perf_counter()
            r.terrain.set_objects(inst)
            setup_s = time.perf_counter() - t0
            paths = (("landscape views", camera_path(r)), ("bird's-eye views", bird_path(r)))
            for _, params in MODES:  # warm-up: shader compiles, shadow targets, sweeps
                frame_times(bare if params is None else r, paths[0][1][:1], params or {})
            for view, cams in paths:
                times: dict[str, list[float]] = {label: [] for label, _ in MODES}
                stats: dict[str, dict] = {}
                for cam in cams:  # interleaved: the machine's load hits every mode alike
                    for label, params in MODES:
                        times[label] += frame_times(bare if params is None else r, [cam],
                                                    params or {})
                        if params is not None:
                            stats[label] = dict(r.terrain.last_stats)
                tables.append(_table(hm, inst, size, view, cams, times, stats, setup_s, info))
        finally:
            r.release()
            bare.release()
    return [*tables, terrain_shadow_agreement(quick)]


def _table(hm, inst, size, view, cams, times, stats, setup_s, info) -> BenchTable:
    table = BenchTable(
        f"objects on a {hm.rows}² terrain at {size[0]}×{size[1]}: {len(inst)} instances, "
        f"{view}",
        ["mode", "ms/frame (median)", "× no object shadows", "meshes drawn", "impostors",
         "shadow-map triangles"])
    base = statistics.median(times[MODES[1][0]])
    for label, _ in MODES:
        ms = statistics.median(times[label]) * 1e3
        st = stats.get(label, {})
        table.rows.append([label, round(ms, 1), round(ms / (base * 1e3), 2),
                           st.get("objects_meshes", 0), st.get("objects_impostors", 0),
                           st.get("shadow_terrain_triangles", 0)
                           + st.get("shadow_object_triangles", 0)])
    table.check_target(f"cascades / no object shadows ({view})",
                       table.value(MODES[2][0], "× no object shadows"), at_most=TARGET,
                       unit="×")
    table.notes += [
        f"{len(cams)} views interleaved frame by frame; setup (atlas bake, uploads) "
        f"{setup_s:.2f} s; GL: {info.get('renderer', '?')}",
        "trees: conifer and broadleaf, buildings: house and hall (built-in meshes), "
        "uniformly placed, seed 1",
    ]
    return table
