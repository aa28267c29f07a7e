"""Benchmark: ROAM, Turner's ROAM and geomipmapping on ONE flight, drawn (``bench lod_flight``).

Filipović 2008 §5.3 (figures 27–29) compares the LOD algorithms by frame rate and triangle count vs
heightmap size at an 80,000-triangle target, and by frame rate vs triangle count. The other
LOD benches (``lod_roam``, ``lod``) time the LOD update alone; here every frame is the FULL
frame a viewer pays for, drawn headless on the renderer used everywhere else:

1. LOD update for the frame's camera and the gather of its triangle list, for every scheme
   of :data:`~terrascape.lod.schemes.SCHEMES` through its common interface
   (``update(camera, viewport, max_triangles=N)`` — or ``tolerance_px=τ`` for a scheme with
   no triangle budget — + ``triangles(visible_only=...)`` as the scheme draws:
   ROAM the whole map, Turner and geomipmapping the patches passing the frustum test);
2. upload of that index list into the renderer's dynamic index buffer
   (``TerrainRenderer.set_indices``);
3. draw (sky + terrain with the ``regions`` technique) and read-back of the colour buffer to
   numpy, which waits for the GPU (llvmpipe) to finish the frame.

All three algorithms (and the full-resolution mesh as a reference) fly the same camera path:
the seeded circle of ``bench lod_roam`` (150 m above the highest peak, 5 m per frame,
15° down) on the same fBm terrain (±800 m on a 10 m grid). Geomipmapping has no triangle
budget, so its pixel tolerance τ is chosen per map (and per target) by bisection on the
first frame — the smallest τ whose triangle count is ≤ the target — and then kept fixed for
the flight, as a real application would fix it.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from terrascape.bench import BenchTable
from terrascape.errors import InvalidParameterError
from terrascape.lod.schemes import SCHEMES

FULL_SIZES = (257, 513, 1025, 2049, 4097)
QUICK_SIZES = (257, 513)
FULL_TARGETS = (10_000, 20_000, 40_000, 80_000, 160_000, 320_000)
QUICK_TARGETS = (10_000, 40_000, 80_000)
FULL_VIEWPORT = (1280, 720)
QUICK_VIEWPORT = (640, 360)
FULL_FRAMES = 40
QUICK_FRAMES = 10
# Frames flown and drawn before the statistics start: shader compile and texture upload,
# ROAM's first frame (refined from the two root triangles), Turner's threshold feedback.
WARMUP = 3
TARGET = 80_000
TURNER_PATCH = SCHEMES["turner"].options["patch_size"]
GM_PATCH = SCHEMES["geomipmap"].options["patch_size"]  # the thesis's default (§4.2)
TAU_MIN = 1e-3  # px: the bisection's lower end (full resolution in practice)
TECHNIQUE = "regions"
# Full-resolution reference rows above this side are skipped (parameter of the size table;
# measured: ~0.25 s per frame at 2049² and ~0.45 s at 4097² on llvmpipe, so all fit).
FULL_RES_MAX = 4097
ALGORITHMS = tuple(s.label for s in SCHEMES.values())  # table names, SCHEMES order
_BY_LABEL = {s.label: s for s in SCHEMES.values()}
FULL_RES = "full resolution"


def _terrain(n: int):
    from terrascape.bench.lod_roam import _terrain as roam_terrain

    # the terrain of `bench lod_roam` / `bench lod`, so the figures are comparable
    return roam_terrain(n)


def _flight(hm, frames: int, viewport: tuple[int, int]):
    """The camera path of `bench lod_roam` with the aspect of this viewport."""
    from terrascape.bench.lod_roam import _flight as roam_flight

    aspect = viewport[0] / viewport[1]
    return [replace(c, aspect=aspect) for c in roam_flight(hm, frames)]


# --- geomipmapping tolerance -------------------------------------------------------------------
def bisect_tolerance(
    gm,
    camera,
    viewport: tuple[int, int],
    target: int,
    *,
    lo: float = TAU_MIN,
    hi: float = 1e6,
    rel: float = 1e-3,
) -> tuple[float, int]:
    """Smallest pixel tolerance τ at which geomipmapping draws ≤ ``target`` triangles.

    The triangle count of :meth:`~terrascape.lod.Geomipmap.update` (with frustum culling) is
    non-increasing in τ: the switching distances ``D_n = δ·C`` scale with ``C ∝ 1/τ``
    (Filipović 2008 Formula 3), so a larger τ only selects coarser levels. Bisection in log τ.

    Parameters
    ----------
    gm
        :class:`~terrascape.lod.Geomipmap`; left updated with the returned τ.
    camera, viewport
        The view the count is measured for.
    target
        Triangle target (>= 1).
    lo, hi
        Search interval in pixels. At ``lo`` the mesh is full resolution in practice; if it
        already fits, ``lo`` is returned. If even ``hi`` (every patch at its coarsest level)
        exceeds the target, ``hi`` is returned with its (too large) count.
    rel
        Relative precision of τ.

    Returns
    -------
    (tau_px, triangles)
    """
    if not (isinstance(target, (int, np.integer)) and target >= 1):
        raise InvalidParameterError(f"target must be an integer >= 1, got {target!r}")
    if not 0 < lo < hi or not 0 < rel < 1:
        raise InvalidParameterError(
            f"need 0 < lo < hi and 0 < rel < 1, got lo={lo}, hi={hi}, rel={rel}"
        )

    def count(tau: float) -> int:
        gm.update(camera, viewport, tau, cull=True)
        return gm.triangle_count()

    n_lo = count(lo)
    if n_lo <= target:
        return lo, n_lo
    n_hi = count(hi)
    if n_hi > target:
        return hi, n_hi
    # invariant: count(lo) > target >= count(hi)
    while hi / lo > 1.0 + rel:
        mid = math.sqrt(lo * hi)
        n = count(mid)
        if n <= target:
            hi, n_hi = mid, n
        else:
            lo = mid
    gm.update(camera, viewport, hi, cull=True)
    return hi, n_hi


# --- one algorithm on the flight -------------------------------------------------------------
@dataclass
class FlightResult:
    """Per-frame timings (ms) and drawn triangles of one algorithm on one flight."""

    algorithm: str
    side: int
    target: int | None
    setup_s: float
    lod_ms: np.ndarray
    upload_ms: np.ndarray
    draw_ms: np.ndarray
    frame_ms: np.ndarray
    triangles: np.ndarray
    tau_px: float | None = None
    first_triangles: int | None = None  # geomipmap: count at the bisected τ, first frame
    coverage: float = float("nan")  # share of pixels showing terrain in the last frame

    @property
    def fps(self) -> float:
        """Frames per second from the median full frame time."""
        return 1000.0 / float(np.median(self.frame_ms))


def _budgeted(entry) -> bool:
    """Whether the scheme takes a triangle budget (else its tolerance is bisected)."""
    return "max_triangles" in entry.parameter_names


def _lod_driver(name: str, hm, target: int, first_cam, viewport):
    """(mesh(camera) -> triangles or None, setup seconds, τ, first-frame triangles)."""
    if name == FULL_RES:
        return (lambda cam: None), 0.0, None, None
    entry = _BY_LABEL.get(name)
    if entry is None:
        raise InvalidParameterError(
            f"unknown algorithm {name!r}; expected {(*ALGORITHMS, FULL_RES)}")
    t0 = time.perf_counter()
    lod = entry.build(hm)
    visible_only = entry.draw_visible_only
    if _budgeted(entry):
        def mesh(cam):
            lod.update(cam, viewport, max_triangles=target)
            return lod.triangles(visible_only=visible_only)

        return mesh, time.perf_counter() - t0, None, None
    tau, first = bisect_tolerance(lod, first_cam, viewport, target)

    def mesh(cam):
        lod.update(cam, viewport, tolerance_px=tau)
        return lod.triangles(visible_only=visible_only)

    return mesh, time.perf_counter() - t0, tau, first


def _sky_only(renderer, cam) -> np.ndarray:
    """A frame of ``cam`` with no terrain drawn (to measure what the terrain covers)."""
    renderer.terrain.set_indices(np.zeros((0, 3), np.uint32))
    sky = renderer.render(cam, TECHNIQUE, None)
    renderer.terrain.set_indices(None)
    return sky


def fly(
    renderer,
    hm,
    names: Sequence[str],
    cams: Sequence,
    viewport: tuple[int, int],
    target: int,
    *,
    warmup: int = WARMUP,
) -> list[FlightResult]:
    """Fly ``cams`` with each algorithm of ``names``, drawing every frame.

    The algorithms take turns frame by frame (camera k is drawn by all of them before camera
    k + 1), so a change of load on the shared machine hits all of them alike. Each keeps its
    own state, so the frame coherence ROAM relies on is unaffected. Statistics skip the
    first ``warmup`` cameras.
    """
    drivers = [_lod_driver(name, hm, target, cams[0], viewport) for name in names]
    timings = [([], [], [], [], []) for _ in names]  # lod, upload, draw, frame, triangles
    images: list = [None] * len(names)
    for k, cam in enumerate(cams):
        for i, (mesh, *_) in enumerate(drivers):
            t0 = time.perf_counter()
            triangles = mesh(cam)
            t1 = time.perf_counter()
            renderer.terrain.set_indices(triangles)
            t2 = time.perf_counter()
            images[i] = renderer.render(cam, TECHNIQUE, None)  # read-back = GPU sync
            t3 = time.perf_counter()
            if k < warmup:
                continue
            lod, upload, draw, frame, tris = timings[i]
            lod.append(t1 - t0)
            upload.append(t2 - t1)
            draw.append(t3 - t2)
            frame.append(t3 - t0)
            tris.append(renderer.terrain.last_stats["triangles"])
    sky = _sky_only(renderer, cams[-1])
    out = []
    for name, (_, setup, tau, first), (*ms, tris), image in zip(
        names, drivers, timings, images, strict=True
    ):
        ms = [np.asarray(v) * 1e3 for v in ms]
        cov = float(np.mean(np.any(image != sky, axis=-1)))
        out.append(FlightResult(
            name, hm.rows, None if name == FULL_RES else target, setup, *ms,
            np.asarray(tris, np.int64), tau, first, cov,
        ))  # fmt: skip
    return out


# --- tables ------------------------------------------------------------------------------------
def _context_note(ctx) -> str:
    from terrascape.render.context import describe_context

    d = describe_context(ctx)
    return f"GL: {d['renderer']} ({d['version']}), headless EGL, single-sampled framebuffer"


def _with_renderer(ctx, hm, viewport, fn: Callable):
    from terrascape.render.offscreen import OffscreenRenderer

    t0 = time.perf_counter()
    r = OffscreenRenderer(ctx, hm, size=viewport)
    setup = time.perf_counter() - t0
    try:
        return fn(r), setup
    finally:
        r.release()


def _size_results(
    ctx,
    sizes: Sequence[int],
    frames: int,
    viewport: tuple[int, int],
    target: int = TARGET,
    full_res_max: int = FULL_RES_MAX,
    algorithms: Sequence[str] = ALGORITHMS,
):
    """Results per (size, algorithm) and per-size setup notes."""
    results: list[FlightResult] = []
    notes = []
    for n in sizes:
        t0 = time.perf_counter()
        hm = _terrain(n)
        gen = time.perf_counter() - t0
        cams = _flight(hm, frames + WARMUP, viewport)
        names = [*algorithms, *([FULL_RES] if n <= full_res_max else [])]

        def run_all(r, hm=hm, cams=cams, names=names):
            return fly(r, hm, names, cams, viewport, target)

        res, rsetup = _with_renderer(ctx, hm, viewport, run_all)
        results += res
        setups = ", ".join(f"{x.algorithm} {x.setup_s:.2f} s" for x in res if x.setup_s)
        notes.append(
            f"{n}²: terrain {gen:.2f} s, renderer (vertex + chunk buffers) "
            f"{rsetup:.2f} s, LOD setup {setups}"
        )
    return results, notes


def _size_row(r: FlightResult) -> list:
    return [
        r.algorithm, f"{r.side}²", round(float(np.mean(r.triangles))),
        float(np.median(r.lod_ms)), float(np.median(r.upload_ms)), float(np.median(r.draw_ms)),
        float(np.median(r.frame_ms)), r.fps,
        "" if r.tau_px is None else float(r.tau_px), round(100.0 * r.coverage, 1),
    ]  # fmt: skip


def _size_table(ctx, sizes, frames, viewport, target=TARGET, full_res_max=FULL_RES_MAX):
    results, setup_notes = _size_results(ctx, sizes, frames, viewport, target, full_res_max)
    table = BenchTable(
        f"LOD flight: frame rate and triangles vs map size at {target:,} triangles",
        ["algorithm", "map", "triangles (mean)", "LOD ms (median)", "upload ms (median)",
         "draw ms (median)", "frame ms (median)", "frames/s", "τ px", "terrain px %"],
        [_size_row(r) for r in results],
    )  # fmt: skip
    skipped = [n for n in sizes if n > full_res_max]
    table.notes += [
        f"viewport {viewport[0]}×{viewport[1]}, fov 60°, {frames} frames measured after "
        f"{WARMUP} warm-up frames; the same seeded flight for every row (bench lod_roam's "
        "circle: 150 m above the highest peak, 5 m/frame, 15° down) over fBm ±800 m, 10 m grid",
        "frame = LOD update + triangle gather (LOD ms) + index upload (upload ms) + draw of "
        f"sky and terrain ('{TECHNIQUE}' technique) + read-back of the colour buffer to numpy, "
        "which waits for the GPU (draw ms); frames/s = 1000 / median frame ms",
        "triangles = triangles drawn: ROAM = every leaf of the whole map (off-screen parts "
        "stay coarse), Turner = leaves of the patches passing the frustum test "
        f"({TURNER_PATCH}² patches), geomipmap = visible {GM_PATCH}² patches; the LOD index "
        "list is drawn as one call (the renderer does not cull it further)",
        "geomipmap: τ = smallest pixel tolerance with ≤ target triangles on the first frame "
        "(bisection), then fixed for the flight, so its count drifts with the view",
        "upload = TerrainRenderer.set_indices (uint32 index list written into one dynamic "
        "buffer, reallocated at 1.5× the size when too small)",
        "full resolution: no LOD, the renderer's 129² chunks with their own AABB frustum "
        "culling and, where their cells are sub-pixel, small-triangle culling; triangles = "
        "those of the chunks drawn",
        "on a software rasteriser 'regions' is shaded deferred (once per pixel) in every row",
        "terrain px % = share of the last frame's pixels covered by terrain (vs a sky-only "
        "frame): every row must show the same view",
        *setup_notes,
        _context_note(ctx),
    ]

    def sides(pred) -> str:
        return ", ".join(f"{r.side}²" for r in results if pred(r))

    roam_short = sides(lambda r: r.algorithm == "ROAM" and r.triangles.max() < 0.95 * target)
    if roam_short:
        table.notes.append(
            f"on {roam_short} ROAM's mesh reaches zero screen-space error (the exact mesh) "
            "below the target, so it stops short of it"
        )
    gm_full = sides(lambda r: r.algorithm == "geomipmap" and r.tau_px == TAU_MIN)
    if gm_full:
        table.notes.append(
            f"on {gm_full} geomipmapping at the smallest τ searched ({TAU_MIN} px, every "
            "visible patch at full resolution) still stays below the target"
        )
    if skipped:
        table.notes.append(
            "full resolution skipped for "
            + ", ".join(f"{n}²" for n in skipped)
            + f" (above {full_res_max}², to keep the run short)"
        )
    return table, results


def _target_results(ctx, n: int, targets: Sequence[int], frames: int, viewport):
    hm = _terrain(n)
    cams = _flight(hm, frames + WARMUP, viewport)

    def run_all(r):
        return {t: fly(r, hm, ALGORITHMS, cams, viewport, t) for t in targets}

    res, _ = _with_renderer(ctx, hm, viewport, run_all)
    return res


def _target_table(ctx, n: int, targets, frames, viewport) -> tuple[BenchTable, dict]:
    res = _target_results(ctx, n, targets, frames, viewport)
    rows, columns = [], ["target"]
    for label in ALGORITHMS:
        if not _budgeted(_BY_LABEL[label]):
            columns.append(f"{label} τ px")
        columns += [f"{label} triangles", f"{label} frames/s"]
    for t in targets:
        row = [t]
        for r in res[t]:
            if r.tau_px is not None:
                row.append(float(r.tau_px))
            row += [round(float(np.mean(r.triangles))), r.fps]
        rows.append(row)
    table = BenchTable(
        f"LOD flight: frame rate vs triangle target ({n}²)",
        columns,
        rows,
        [f"same flight and frame definition as the size table; {n}², viewport "
         f"{viewport[0]}×{viewport[1]}, {frames} frames after {WARMUP} warm-up; triangles = "
         "mean drawn per frame; frames/s = 1000 / median full frame ms",
         "geomipmap τ bisected per target on the first frame, then fixed"],
    )  # fmt: skip
    return table, res


def run(quick: bool = False) -> list[BenchTable]:
    """Size table (quick: 257², 513²; 640×360; 10 frames) and target table (quick 513²)."""
    import numba

    from terrascape.render.context import current, headless_context

    sizes = QUICK_SIZES if quick else FULL_SIZES
    frames = QUICK_FRAMES if quick else FULL_FRAMES
    viewport = QUICK_VIEWPORT if quick else FULL_VIEWPORT
    targets = QUICK_TARGETS if quick else FULL_TARGETS
    n_target = 513 if quick else 1025
    with headless_context() as ctx, current(ctx):
        size_t, _ = _size_table(ctx, sizes, frames, viewport)
        target_t, _ = _target_table(ctx, n_target, targets, frames, viewport)
    size_t.notes.append(
        f"numba threads: {numba.get_num_threads()}, CPUs: {os.cpu_count()}, load average "
        f"{os.getloadavg()[0]:.2f} (shared machine; llvmpipe rasterises on the same CPUs)"
    )
    return [size_t, target_t]
