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


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.render.context import describe_context, headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    hm, inst, size = bench_scene(quick)
    with headless_context() as ctx:
        info = describe_context(ctx)
        bare = OffscreenRenderer(ctx, hm, size=size)  # the same terrain, never any objects
        r = OffscreenRenderer(ctx, hm, size=size)
        cams = camera_path(r)
        times: dict[str, list[float]] = {label: [] for label, _ in MODES}
        stats: dict[str, dict] = {}
        try:
            t0 = time.perf_counter()
            r.terrain.set_objects(inst)
            setup_s = time.perf_counter() - t0
            for _, params in MODES:  # warm-up: shader compiles, shadow targets, sweeps
                frame_times(bare if params is None else r, cams[:1], params or {})
            for cam in cams:  # interleaved: the machine's load hits every mode alike
                for label, params in MODES:
                    times[label] += frame_times(bare if params is None else r, [cam],
                                                params or {})
                    if params is not None:
                        stats[label] = dict(r.terrain.last_stats)
        finally:
            r.release()
            bare.release()
    table = BenchTable(
        f"objects on a {hm.rows}² terrain at {size[0]}×{size[1]}: {len(inst)} instances",
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
    table.check_target("cascades / no object shadows",
                       table.value(MODES[2][0], "× no object shadows"), at_most=TARGET,
                       unit="×")
    table.notes += [
        f"{len(cams)} views interleaved frame by frame; setup (atlas bake, uploads) "
        f"{setup_s:.2f} s; GL: {info.get('renderer', '?')}",
        "trees: conifer and broadleaf, buildings: house and hall (built-in meshes), "
        "uniformly placed, seed 1",
    ]
    return [table]
