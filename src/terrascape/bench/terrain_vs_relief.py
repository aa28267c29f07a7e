"""Relief-mapped flat quad vs polygonal terrain with LOD (Janković 2010 §2.7, Test 4).

The thesis renders a 1024² heightmap four ways in Irrlicht — (a) a flat quad with the terrain
as a texture (texture mapping), (b) the same quad with parallax mapping, (c) with relief
mapping (the height texture *is* the terrain), (d) the terrain as polygons with Irrlicht's
geomipmapped terrain node at 1, 3 and 5 levels of detail — and reports FPS (test
configuration 2): texture 824, parallax 716, relief 55, polygons 5 / 62 / 170.

Here, on headless llvmpipe, with one camera seeing the whole terrain for every method:

* (a)(b)(c): :class:`~terrascape.render.relief_quad.ReliefQuadRenderer` (techniques
  ``plain``, ``parallax``, ``relief`` 16+8) on a horizontal
  :class:`~terrascape.relief.reference.ReliefQuad` laid at the terrain's top height, half a
  texel wider than the grid on every side so texel centres sit exactly on the grid vertices;
  relief depth = the terrain's height range in UV units, so the relief surface *is* the
  terrain (``y = top − d·(max − min)``). Colour = the same region texture the polygons use;
  the normals come from the relief texture (``plain`` is therefore texture + per-pixel
  normal-map lighting, no parallax).
* (d): :class:`~terrascape.render.offscreen.OffscreenRenderer`, technique ``plain`` (region
  colour texture, Phong with the vertex normal — ka, kd, ks and shininess set to the quad
  shader's constants, fog and sky off), full resolution and geomipmapping
  (:class:`~terrascape.lod.Geomipmap`, 33² patches, Filipović 2008 §4.2) at τ = 1, 4, 16 px. The
  camera is static, so the LOD selection is done once per τ and its cost reported apart.

Two diamond-square terrains: ``seed`` (smooth, the thesis's height scale — relief 0.11·255 over
1024) and ``mountains`` (Hurst 0.7, relief a quarter of the width), so LOD and relief depth
are exercised at both ends.

Tables (``run``): Table 1 per terrain — triangles, LOD levels used, ms/frame (median of N
frames after a warm-up round, methods interleaved frame by frame, read-back of 8-bit RGBA
included), frames/s, × texture mapping (FPS ratio), the LOD update cost, and the thesis's FPS
for the matching row; Table 2 — image difference of every method against the
full-resolution polygons (luminance, the terrain sample each pixel shows, coverage): what
the speed buys. Nothing is written to disk.
"""

from __future__ import annotations

import contextlib
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from terrascape.bench import BenchTable
from terrascape.errors import InvalidParameterError

EXTENT = 1024.0  # world units per side for every grid size (quick mode only samples coarser)
# Janković 2010 §2.7 Test 4: addTerrainSceneNode scale (1, 0.11, 1) on an 8-bit heightmap of 1024
# texels, i.e. a relief of 0.11·255 ≈ 28 units over 1024.
RELIEF_HEIGHT = 0.11 * 255.0
# name -> diamond-square decay law and relief height (world units over EXTENT).
TERRAINS = {
    "seed": {"label": "seed scale (smooth, H = 1)", "decay": "halve", "hurst": None,
             "relief": RELIEF_HEIGHT},
    "mountains": {"label": "mountains (H = 0.7, relief ¼ of width)", "decay": "hurst",
                  "hurst": 0.7, "relief": EXTENT / 4.0},
}
SUN = (135.0, 45.0)
TOLERANCES = (1.0, 4.0, 16.0)
PATCH_SIZE = 33
# Janković 2010 §2.7, Test 4, test configuration 2 (frames per second).
SEED_FPS = {"texture": 824, "parallax": 716, "relief": 55, 1: 5, 3: 62, 5: 170}
# (label, ReliefQuadRenderer technique, SEED_FPS key)
QUAD_METHODS = (("texture mapping", "plain", "texture"), ("parallax", "parallax", "parallax"),
                ("relief 16+8", "relief", "relief"))
# Phong constants of relief/quad.glsl (ka·ia, kd·id, ks·is, alpha), given to the polygons too.
PHONG = {"ka": 0.25, "kd": 0.75, "ks": 0.15, "shininess": 24.0}


@dataclass
class MethodResult:
    """One measured method (a row of both tables)."""

    method: str
    kind: str  # "quad" or "polygons"
    triangles: int
    ms: float
    levels: str = ""
    n_levels: int = 0
    lod_ms: float | None = None
    seed_key: str | None = None
    image: np.ndarray | None = field(default=None, repr=False)  # uint8 (h, w, 4), bottom-up
    covered: np.ndarray | None = field(default=None, repr=False)  # bool (h, w)
    shown_xz: np.ndarray | None = field(default=None, repr=False)  # float (h, w, 2)

    @property
    def fps(self) -> float:
        return 1000.0 / self.ms


def terrain(size: int, kind: str = "seed", *, seed: int = 1):
    """A test terrain: diamond-square, ``EXTENT`` wide, heights in ``[0, relief]``.

    ``kind`` is a key of :data:`TERRAINS`: ``"seed"`` (smooth, the thesis's height scale) or
    ``"mountains"`` (rougher, a quarter of the width high).
    """
    from terrascape.generate import diamond_square

    if kind not in TERRAINS:
        raise InvalidParameterError(f"terrain kind must be one of {list(TERRAINS)}, got {kind!r}")
    cfg = TERRAINS[kind]
    hm = diamond_square(size, roughness=1.0, seed=seed, spacing=EXTENT / (size - 1),
                        decay=cfg["decay"], hurst=cfg["hurst"])
    return hm.normalised(0.0, cfg["relief"])


def terrain_quad(hm):
    """The :class:`ReliefQuad` whose relief surface is the terrain ``hm``.

    The quad spans the grid plus half a spacing on each side: texel ``(r, c)`` is centred at
    UV ``((c + 0.5)/cols, (r + 0.5)/rows)`` (GL convention), i.e. at the vertex ``(c·dx,
    r·dz)``. It lies at the top height; a texel of depth ``d`` hangs ``d·depth`` UV units
    (``d·(max − min)`` world units) below it.
    """
    from terrascape.relief.reference import ReliefQuad

    dx, dz = hm.spacing
    lu, lv = hm.cols * dx, hm.rows * dz
    span = max(float(hm.max - hm.min), 1e-6)
    return ReliefQuad((-dx / 2.0, float(hm.max), -dz / 2.0), (lu, 0.0, 0.0), (0.0, 0.0, lv),
                      depth=span / math.sqrt(lu * lv))


def _median_ms(frame, frames: int, warmup: int = 1) -> float:
    for _ in range(warmup):
        frame()
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        frame()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1000.0


def _params():
    return {"sun": SUN, "lighting": "vertex", "sky": False, "fog_density": 0.0, **PHONG}


def _unproject_xz(camera, depth: np.ndarray) -> np.ndarray:
    """World (x, z) of every pixel of a bottom-up depth buffer (values in [0, 1])."""
    h, w = depth.shape
    x = (np.arange(w) + 0.5) / w * 2.0 - 1.0
    y = (np.arange(h) + 0.5) / h * 2.0 - 1.0
    xx, yy = np.meshgrid(x, y)
    ndc = np.stack([xx, yy, depth.astype(np.float64) * 2.0 - 1.0, np.ones_like(xx)], -1)
    p = ndc @ np.linalg.inv(camera.view_projection()).T
    return p[..., [0, 2]] / p[..., 3:4]


@dataclass
class _Method:
    """A method under measurement: ``setup`` (untimed) puts the renderer in its state,
    ``frame`` draws and reads back one frame, ``capture`` returns (image, covered, shown xz)."""

    result: MethodResult
    setup: Callable[[], None]
    frame: Callable[[], object]
    capture: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray]]


def _read_polygons(renderer, camera, params):
    img = renderer.render(camera, "plain", params)[::-1].copy()  # bottom-up like GL
    depth = np.frombuffer(renderer.fbo.read(components=1, attachment=-1, dtype="f4"),
                          dtype=np.float32).reshape(img.shape[:2])
    return img, depth < 1.0, _unproject_xz(camera, depth)


def _polygon_methods(renderer, hm, camera, viewport, tolerances) -> list[_Method]:
    from terrascape.lod import Geomipmap

    params = _params()
    geo = Geomipmap(hm, patch_size=min(PATCH_SIZE, hm.rows))

    def frame():
        return renderer.render(camera, "plain", params)

    def capture():
        return _read_polygons(renderer, camera, params)

    def full_setup():
        renderer.terrain.set_indices(None)

    full_setup()
    frame()
    methods = [_Method(MethodResult("polygons, full resolution", "polygons",
                                    int(renderer.terrain.last_stats["triangles"]), 0.0, "0", 1),
                       full_setup, frame, capture)]
    for tau in tolerances:
        def lod(t=tau):
            geo.update(camera, viewport, tolerance_px=t)
            return geo.triangles()

        lod_ms = _median_ms(lod, 3)
        tris = lod()
        lev = geo.levels
        methods.append(_Method(
            MethodResult(f"polygons, geomipmap τ={tau:g} px", "polygons", len(tris), 0.0,
                         f"{int(lev.min())}–{int(lev.max())}", int(lev.max()) + 1, lod_ms),
            lambda t=tris: renderer.terrain.set_indices(t), frame, capture))
    # Geomipmap's level-0 template alternates the cell diagonals; the renderer's full mesh
    # uses one diagonal. Level 0 everywhere (τ → 0) is the image-difference floor of the τ
    # rows that the triangulation, not the LOD, causes (quality table only).
    floor = lod(1e-9)
    methods.append(_Method(
        MethodResult("polygons, geomipmap level 0 everywhere (diagonal floor)", "floor",
                     len(floor), float("nan"), "0–0", 1),
        lambda t=floor: renderer.terrain.set_indices(t), frame, capture))
    return methods


def _quad_methods(renderer, hm, camera) -> list[_Method]:
    from terrascape.lighting.sun import sun_direction
    from terrascape.render.relief_quad import technique_id

    quad = terrain_quad(hm)
    light = sun_direction(*SUN)
    w, h = renderer.size
    o = np.asarray(quad.origin)
    methods = []
    for label, tech, key in QUAD_METHODS:
        technique_id(tech)  # typed error if the technique set ever changes

        def frame(t=tech):
            renderer.draw(quad, camera, t, output="colour", light_dir=light)
            return renderer.fbo.read(components=4, dtype="f1")

        def capture(t=tech, f=frame):
            img = np.frombuffer(f(), dtype=np.uint8).reshape(h, w, 4).copy()
            hit = renderer.render(quad, camera, t, output="hit", light_dir=light)
            # The terrain sample a pixel shows is its hit texel; the texture repeats, so a
            # ray that leaves the quad's footprint shows the opposite side.
            uv = np.mod(hit[..., :2].astype(np.float64), 1.0)
            xz = np.stack([o[0] + uv[..., 0] * quad.u_axis[0],
                           o[2] + uv[..., 1] * quad.v_axis[2]], -1)
            return img, img[..., 3] > 0, xz

        frame()
        if renderer.drawn_technique != tech:
            label += f" (fell back to {renderer.drawn_technique})"
        methods.append(_Method(MethodResult(label, "quad", 2, 0.0, seed_key=key),
                               lambda: None, frame, capture))
    return methods


def _time_interleaved(methods: list[_Method], frames: int) -> None:
    """Median ms of ``frames`` frames per method, one frame of each method per round, so a
    change of the machine's load (2 shared cores) hits every method alike."""
    timed = [m for m in methods if m.result.kind != "floor"]
    times: dict[int, list[float]] = {id(m): [] for m in timed}
    for _ in range(1 + frames):  # the first round warms up
        for m in timed:
            m.setup()
            t0 = time.perf_counter()
            m.frame()
            times[id(m)].append(time.perf_counter() - t0)
    for m in timed:
        m.result.ms = statistics.median(times[id(m)][1:]) * 1000.0


def _luminance(img: np.ndarray, covered: np.ndarray, background) -> np.ndarray:
    rgb = img[..., :3].astype(np.float64)
    rgb = np.where(covered[..., None], rgb, np.asarray(background) * 255.0)
    return rgb @ np.array([0.299, 0.587, 0.114])


def quality_figures(result: MethodResult, reference: MethodResult, spacing: float) -> dict:
    """Image difference of ``result`` vs ``reference`` (both measured with ``quality``)."""
    from terrascape.render.techniques import COMMON_PARAMS

    bg = COMMON_PARAMS["horizon_color"]  # the terrain renderer clears to it (sky, fog off)
    union = result.covered | reference.covered
    both = result.covered & reference.covered
    dl = np.abs(_luminance(result.image, result.covered, bg)
                - _luminance(reference.image, reference.covered, bg))[union]
    dxz = np.hypot(*(result.shown_xz - reference.shown_xz)[both].T) / spacing
    dl_both = np.abs(_luminance(result.image, both, bg)
                     - _luminance(reference.image, both, bg))[both]
    return {
        "mean_dl": float(dl.mean()) if dl.size else 0.0,
        "mean_dl_both": float(dl_both.mean()) if dl_both.size else 0.0,
        "pct_dl8": float((dl > 8.0).mean() * 100.0) if dl.size else 0.0,
        "median_dxz": float(np.median(dxz)) if dxz.size else 0.0,
        "pct_dxz1": float((dxz > 1.0).mean() * 100.0) if dxz.size else 0.0,
        "p95_dxz": float(np.percentile(dxz, 95)) if dxz.size else 0.0,
        "pct_cover": float((union & ~both).sum() / max(union.sum(), 1) * 100.0),
    }


def _measure(ctx=None, *, size: int = 65, viewport=(160, 90), frames: int = 2,
             tolerances=TOLERANCES, quality: bool = True,
             kind: str = "seed") -> list[MethodResult]:
    """Measure every method of one terrain: the three quad methods (texture mapping first),
    full-resolution polygons, the geomipmap rows, then the diagonal-floor row."""
    from terrascape.render.context import current, headless_context
    from terrascape.render.offscreen import OffscreenRenderer, default_camera
    from terrascape.render.relief_quad import ReliefQuadRenderer
    from terrascape.render.techniques import build_region_texture, get_technique

    viewport = tuple(viewport)
    # headless_context: releasing it makes a caller's own GL context current again
    gl = contextlib.ExitStack()
    if ctx is None:
        ctx = gl.enter_context(headless_context())
    quads = polys = None
    try:
        with current(ctx):
            hm = terrain(size, kind)
            camera = default_camera(hm, viewport)
            heights01 = (hm.heights - hm.min) / max(float(hm.max - hm.min), 1e-6)
            # The polygons' colour texture (one texel per vertex) on the quad too.
            colour = build_region_texture(hm, get_technique("plain").resolve(_params())).data
            colour = np.asarray(colour, dtype=np.float32)[..., :3] / 255.0
            quads = ReliefQuadRenderer(ctx, heights01, size=viewport, colour=colour,
                                       depth_hint=terrain_quad(hm).depth)
            polys = OffscreenRenderer(ctx, hm, size=viewport)
            methods = _quad_methods(quads, hm, camera)
            methods += _polygon_methods(polys, hm, camera, viewport, tolerances)
            _time_interleaved(methods, frames)
            if quality:
                for m in methods:
                    m.setup()
                    m.result.image, m.result.covered, m.result.shown_xz = m.capture()
    finally:
        for r in (quads, polys):
            if r is not None:
                with current(ctx):
                    r.release()
        gl.close()
    return [m.result for m in methods]


def _seed_rows(results: list[MethodResult]) -> dict[int, int]:
    """Row index → seed LOD count: full resolution is Irrlicht's 1 level (no LOD); 3 and 5
    go to the geomipmap row whose number of levels in use (max level + 1) is nearest."""
    out: dict[int, int] = {}
    polys = [i for i, r in enumerate(results) if r.kind == "polygons"]
    out[polys[0]] = 1
    free = polys[1:]
    for k in (3, 5):
        if not free:
            break
        best = min(free, key=lambda i: (abs(results[i].n_levels - k), i))
        out[best] = k
        free.remove(best)
    return out


def tables(measured: dict[str, list[MethodResult]], *, size: int, viewport, frames: int,
           spacing: float) -> list[BenchTable]:
    """One speed table per terrain (Table 1: seed scale first — the thesis's Test 4 — then
    mountains), then Table 2, the image difference of every terrain's methods."""
    seed_tex = SEED_FPS["texture"]
    speeds = {
        kind: BenchTable(
            f"Janković 2010 §2.7 Test 4, {TERRAINS[kind]['label']}: relief-mapped quad vs "
            f"polygonal terrain ({size}² diamond-square, {viewport[0]}×{viewport[1]}, whole "
            "terrain in view)",
            ["method", "triangles", "LOD levels used", "ms/frame", "frames/s",
             "× texture mapping", "LOD update ms (not in frame)", "seed FPS (config 2)",
             "seed × texture"])
        for kind in measured
    }
    quality = BenchTable(
        "What the speed buys: image difference vs full-resolution polygons (same camera, "
        "same sun, same colour texture and Phong constants)",
        ["terrain", "method", "triangles", "ms/frame", "mean |ΔL| (0–255)", "% px |ΔL| > 8",
         "mean |ΔL| where both cover", "median Δ shown sample (grid cells)",
         "p95 Δ shown sample (grid cells)", "% px Δ shown sample > 1 cell",
         "% px coverage differs"])
    for kind, results in measured.items():
        name = TERRAINS[kind]["label"]
        tex_fps = results[0].fps
        seed_map = _seed_rows(results)
        for i, r in enumerate(results):
            if r.kind == "floor":
                continue
            key = r.seed_key if r.kind == "quad" else seed_map.get(i)
            seed = SEED_FPS.get(key) if key is not None else None
            seed_label = "" if seed is None else (
                f"{seed} ({key} LOD level{'s' if key != 1 else ''})" if isinstance(key, int)
                else seed)
            speeds[kind].rows.append([
                r.method, r.triangles, r.levels if r.kind == "polygons" else "", r.ms,
                r.fps, r.fps / tex_fps, "" if r.lod_ms is None else r.lod_ms, seed_label,
                "" if seed is None else seed / seed_tex,
            ])
        ref = next(r for r in results if r.kind == "polygons")
        if ref.image is None:
            continue
        for r in results:
            q = quality_figures(r, ref, spacing)
            ms = "" if r.kind == "floor" else r.ms
            quality.rows.append([name, r.method, r.triangles, ms, q["mean_dl"], q["pct_dl8"],
                                 q["mean_dl_both"], q["median_dxz"], q["p95_dxz"],
                                 q["pct_dxz1"], q["pct_cover"]])
    speed = next(iter(speeds.values()))
    speed.notes += [
        f"ms/frame: median of {frames} frames after one warm-up round, methods interleaved "
        "frame by frame; draw + glReadPixels of 8-bit "
        "RGBA (llvmpipe: CPU rasteriser on 2 shared cores — ratios, not absolute FPS, "
        "compare with the thesis's GPU); × texture mapping = FPS / FPS of texture mapping",
        "quad rows: ReliefQuadRenderer on one flat quad (2 triangles); relief = 16 linear + 8 "
        "binary steps; 'texture mapping' = colour texture + normal-map Phong, no parallax",
        "polygon rows: OffscreenRenderer 'plain' (region texture, vertex-normal Phong); "
        f"geomipmapping (Filipović 2008 §4.2) with {PATCH_SIZE}² patches at tolerance τ, levels "
        "chosen once for the static camera (update + triangles() gather timed apart, median of "
        "3)",
        "seed LOD rows: Irrlicht terrain node limited to 1 / 3 / 5 levels of detail; 1 level "
        "= full resolution; k levels matched to the τ row whose number of levels in use "
        "(coarsest level + 1) is nearest to k (Irrlicht picks levels by distance, not error)",
        f"terrains: {EXTENT:g} units wide; 'seed scale': relief {RELIEF_HEIGHT:.1f} (the "
        "seed's terrain scale 0.11 on 8-bit heights), diamond-square halving decay; "
        f"'mountains': relief {TERRAINS['mountains']['relief']:g}, Hurst 0.7 decay; camera "
        "frame_terrain (azimuth 210°, elevation 35°), sun azimuth 135°, elevation 45°",
    ]
    quality.notes += [
        "ΔL: Rec. 601 luminance of the 8-bit images over pixels either image covers "
        "(background = horizon colour for both); 'where both cover' excludes silhouette "
        "differences",
        "shown sample: world (x, z) of the terrain point whose colour/normal a pixel shows — "
        "polygons: the unprojected depth buffer; quad: the hit texture coordinate (mod 1, the "
        "texture repeats); over pixels both cover; in grid spacings (the tail is occlusion "
        "edges: a pixel on a ridge's outline shows the ridge or the valley behind it)",
        "coverage: the flat quad has no silhouette — it covers the terrain's footprint at the "
        "top height, and rays leaving the footprint wrap to the opposite edge",
        "diagonal floor: geomipmap level 0 (alternating cell diagonals) vs the full mesh (one "
        "diagonal) — the part of the τ rows' difference that the LOD does not cause",
        "lighting differs slightly: the quad uses the bilinear per-texel normal map and "
        "evaluates V at the quad's top surface; the polygons interpolate vertex normals",
    ]
    for other in list(speeds.values())[1:]:
        other.notes.append("notes: see the first terrain's table")
    return [*speeds.values(), quality]


def run(quick: bool = False) -> list[BenchTable]:
    t0 = time.perf_counter()
    size, viewport, frames = (257, (640, 360), 9) if quick else (1025, (1280, 720), 11)
    measured = {kind: _measure(size=size, viewport=viewport, frames=frames, kind=kind)
                for kind in TERRAINS}
    out = tables(measured, size=size, viewport=viewport, frames=frames,
                 spacing=EXTENT / (size - 1))
    if quick:
        out[0].notes.append("--quick: 257² terrains, 640×360")
    out[-1].notes.append(f"benchmark wall time {time.perf_counter() - t0:.1f} s")
    return out


__all__ = ["MethodResult", "quality_figures", "run", "terrain", "terrain_quad"]
