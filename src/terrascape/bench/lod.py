"""Benchmark: geomipmapping, quadtree culling, static RTIN meshes and every static mesher
side by side (``terrascape bench lod``).

* geomipmapping (Filipović 2008 §4.2): setup, per-frame level selection + index ranges (median,
  p95) and the full ``triangles()`` gather on a seeded camera flight, 257…4097 (quick:
  257, 513);
* quadtree AABB culling per frame (2049², 17×17 patches; quick 513²) and its disagreement
  with a brute-force test of every patch;
* static RTIN meshes at TRUE maximum errors of 1, 5, 20 m on fBm terrains in metres (1025²,
  2049²; quick 257², 513²), with pymartini / pydelatin when installed — their errors are
  MEASURED on every sample, never taken from their parameters;
* RTIN hard budget mode 16k / 64k / 256k triangles → achieved error;
* every static mesher of :data:`terrascape.lod.static_meshers.STATIC_MESHERS` side by side
  (what ``terrascape mesh --mesher`` offers) on an fBm map (1025²; quick 257²) and a real
  DEM of another size (the Jacksboro fault), at 1, 5 and 20 m: triangles, build time and
  the error measured on every sample.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from terrascape.bench import BenchTable, best_of
from terrascape.camera import Camera

FULL_GM_SIZES = (257, 513, 1025, 2049, 4097)
QUICK_GM_SIZES = (257, 513)
VIEWPORT = (1920, 1080)
TOLERANCE_PX = 2.0


def _terrain(n: int):
    from terrascape.generate import fbm

    # ±800 m relief on a 10 m grid; the first octave is 5 km long and the finest ~80 m, so
    # the statistics do not depend on n (a bigger map is just a bigger area)
    return fbm(n, scale=500.0, octaves=7, amplitude=800.0, seed=1, spacing=10.0)


def _flight(hm, frames: int, seed: int = 7):
    """A seeded camera flight: a loop at 150–400 m above the terrain's top, looking ahead
    and down 15–30°."""
    rng = np.random.default_rng(seed)
    w, d = hm.extent
    phase = rng.uniform(0, 2 * math.pi)
    cams = []
    for k in range(frames):
        a = phase + 2 * math.pi * k / frames
        x = w / 2 + 0.35 * w * math.cos(a)
        z = d / 2 + 0.35 * d * math.sin(a)
        y = hm.max + rng.uniform(150, 400)
        yaw = math.degrees(math.atan2(-math.sin(a), -math.cos(a))) + rng.uniform(-20, 20)
        cams.append(Camera(position=(x, y, z), yaw=yaw, pitch=-rng.uniform(15, 30),
                           fov_y=60.0, aspect=VIEWPORT[0] / VIEWPORT[1], near=1.0,
                           far=max(w, d) * 1.5))
    return cams


def _geomipmap_table(quick: bool) -> tuple[BenchTable, dict]:
    from terrascape.lod import Geomipmap

    sizes = QUICK_GM_SIZES if quick else FULL_GM_SIZES
    frames = 30 if quick else 100
    table = BenchTable(
        title=f"Geomipmapping (17×17 patches, τ = {TOLERANCE_PX:g} px, "
              f"{VIEWPORT[0]}×{VIEWPORT[1]}, {frames}-frame flight)",
        columns=["side", "patches", "setup s", "update median ms", "update p95 ms",
                 "triangles() median ms", "mean triangles", "full-res triangles",
                 "level histogram (last frame)"],
    )
    kept = {}
    for n in sizes:
        hm = _terrain(n)
        Geomipmap(_terrain(33), 17)  # compile/load kernels outside the timing
        t0 = time.perf_counter()
        gm = Geomipmap(hm, 17)
        setup = time.perf_counter() - t0
        upd, gat, tris = [], [], []
        for cam in _flight(hm, frames):
            t0 = time.perf_counter()
            gm.update(cam, VIEWPORT, TOLERANCE_PX)
            upd.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            tri = gm.triangles()
            gat.append(time.perf_counter() - t0)
            tris.append(len(tri))
        hist = np.bincount(gm.levels.ravel(), minlength=gm.n_levels).tolist()
        table.rows.append([
            f"{n}²", gm.patch_shape[0] * gm.patch_shape[1], setup,
            float(np.median(upd) * 1e3), float(np.percentile(upd, 95) * 1e3),
            float(np.median(gat) * 1e3), int(np.mean(tris)), 2 * (n - 1) ** 2, str(hist),
        ])
        if n == 2049 or (quick and n == sizes[-1]):
            kept["gm"] = gm
            kept["hm"] = hm
    table.notes += [
        "update = distance to each patch AABB, level from the precomputed D_n (Formula 3), "
        "neighbour ±1 fixed point, masks and per-patch index ranges (the zero-copy draw path)",
        "triangles() = materialised uint32 grid-index mesh (not needed for GL drawing)",
        "targets (brief): setup ≤ 0.5 s at 2049²; update ≤ 2 ms at 4097²",
    ]
    table.check_target("geomipmap setup 2049²", table.value("2049²", "setup s"),
                       at_most=0.5, unit=" s")
    table.check_target("geomipmap update 4097²", table.value("4097²", "update median ms"),
                       at_most=2, unit=" ms")
    return table, kept


def _culling_table(quick: bool, kept: dict) -> BenchTable:
    from terrascape.lod import PatchQuadtree

    n = 513 if quick else 2049
    hm = kept.get("hm") if kept.get("hm") is not None and kept["hm"].rows == n else _terrain(n)
    frames = 50 if quick else 200
    qt = PatchQuadtree(hm, 17)
    out = np.zeros(qt.patch_shape, np.bool_)
    times, brute_times, visible, nodes = [], [], [], []
    wrongly_culled = extra = 0
    cams = _flight(hm, frames, seed=11)
    qt.visible(cams[0].frustum_planes(), out=out)  # warm-up
    for cam in cams:
        planes = cam.frustum_planes()
        t0 = time.perf_counter()
        qt.visible(planes, out=out)
        times.append(time.perf_counter() - t0)
        nodes.append(qt.last_nodes_tested)
        t0 = time.perf_counter()
        brute = qt.visible_brute_force(planes)
        brute_times.append(time.perf_counter() - t0)
        wrongly_culled += int(np.count_nonzero(brute & ~out))
        extra += int(np.count_nonzero(out & ~brute))
        visible.append(int(out.sum()))
    table = BenchTable(
        title=f"Quadtree AABB frustum culling, {n}² with 17×17 patches ({frames} frames)",
        columns=["patches", "tree nodes", "median ms", "p95 ms", "mean nodes tested",
                 "mean visible patches", "brute force (numpy) median ms",
                 "wrongly culled", "extra kept"],
        rows=[[qt.patch_shape[0] * qt.patch_shape[1], qt.node_count,
               float(np.median(times) * 1e3), float(np.percentile(times, 95) * 1e3),
               float(np.mean(nodes)), float(np.mean(visible)),
               float(np.median(brute_times) * 1e3), wrongly_culled, extra]],
        notes=["target (brief): ≤ 0.5 ms per frame on 2049²; wrongly culled must be 0"],
    )
    table.check_target("culling 2049² median", float(np.median(times) * 1e3) if n == 2049
                       else None, at_most=0.5, unit=" ms")
    table.check_target("wrongly culled patches", wrongly_culled, at_most=0)
    return table


def _martini_grid(tile, n: int, e: float) -> np.ndarray:
    v, t = tile.get_mesh(e)
    return (v[:, 1].astype(np.int64) * n + v[:, 0].astype(np.int64))[t.reshape(-1, 3)]


def _delatin_grid(h: np.ndarray, e: float) -> np.ndarray:
    from pydelatin import Delatin

    rows, cols = h.shape
    d = Delatin(h, height=rows, width=cols, max_error=e)
    x = np.rint(d.vertices[:, 0]).astype(np.int64)
    y = np.rint(d.vertices[:, 1]).astype(np.int64)
    # pydelatin's y axis points up: row = rows − 1 − y
    return ((rows - 1 - y) * cols + x)[d.triangles]


def _truly_met(make, hm, target: float, steps: int) -> tuple[float, int, float]:
    """Largest parameter (bisection) whose MEASURED error is ≤ target: (param, tris, err)."""
    from terrascape.lod import max_vertical_error

    lo, hi = 0.0, target
    best = (0.0, -1, 0.0)
    tri = make(hi)
    err = max_vertical_error(hm, tri)
    if err <= target:
        return hi, len(tri), err
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        tri = make(mid)
        err = max_vertical_error(hm, tri)
        if err <= target:
            lo, best = mid, (mid, len(tri), err)
        else:
            hi = mid
    return best


def _rtin_tables(quick: bool) -> list[BenchTable]:
    from terrascape.lod import Rtin, max_vertical_error, rtin_mesh

    sizes = (257, 513) if quick else (1025, 2049)
    errors = (1.0, 5.0, 20.0)
    try:
        from pymartini import Martini
    except ImportError:
        Martini = None
    try:
        import pydelatin  # noqa: F401

        have_delatin = True
    except ImportError:
        have_delatin = False
    rtin_t = BenchTable(
        title="Static RTIN mesh at a true maximum vertical error (fBm ±800 m, 10 m grid)",
        columns=["side", "max error m", "error setup s", "extract s", "one-mesh build s",
                 "triangles", "measured error m", "guaranteed bound m"],
    )
    cmp_t = BenchTable(
        title="Other meshers at the same error: parameter = target, and at a TRULY met error",
        columns=["side", "target m", "mesher", "triangles @param", "measured m @param",
                 "param for measured ≤ target", "triangles @met", "measured m @met",
                 "RTIN / mesher triangles @met", "mesher build s @met", "RTIN build s",
                 "RTIN / mesher build time"],
    )
    budget_t = BenchTable(
        title="RTIN hard triangle budget (greedy by nested error)",
        columns=["side", "budget", "triangles", "guaranteed bound m", "measured error m",
                 "extract s"],
    )
    Rtin(_terrain(33))  # compile/load kernels outside the timing
    rtin_mesh(_terrain(33), max_error=1.0)
    for n in sizes:
        hm = _terrain(n)
        t0 = time.perf_counter()
        rtin = Rtin(hm)
        setup = time.perf_counter() - t0
        tile = Martini(n).create_tile(hm.heights) if Martini is not None else None
        ours = {}
        ours_s = {}
        for e in errors:
            t0 = time.perf_counter()
            m = rtin.mesh(max_error=e)
            ext = time.perf_counter() - t0
            measured = max_vertical_error(hm, m.triangles)
            ours[e] = len(m.triangles)
            # a from-scratch build of one mesh: the fast one-error path (same mesh)
            ours_s[e] = best_of(lambda hm=hm, e=e: rtin_mesh(hm, max_error=e), repeat=3)
            rtin_t.rows.append([f"{n}²", e, setup, ext, ours_s[e], len(m.triangles), measured,
                                m.bound])
        for e in errors:
            others = []
            if tile is not None:
                others.append(("pymartini", lambda x, t=tile, n=n: _martini_grid(t, n, x), 12,
                               lambda x, h=hm.heights, n=n: Martini(n).create_tile(h)
                               .get_mesh(x)))
            if have_delatin:
                others.append(("pydelatin", lambda x, h=hm.heights: _delatin_grid(h, x), 6,
                               lambda x, h=hm.heights: _delatin_grid(h, x)))
            for name, make, steps, build in others:
                tri = make(e)
                err = max_vertical_error(hm, tri)
                param, met_tris, met_err = _truly_met(make, hm, e, steps)
                ratio = ours[e] / met_tris if met_tris > 0 else float("nan")
                # from-scratch build at the truly met parameter (pymartini: the Martini
                # tables + error tile + mesh; pydelatin: the whole greedy insertion)
                build_s = best_of(lambda b=build, x=param: b(x), repeat=3, warmup=0)
                cmp_t.rows.append([f"{n}²", e, name, len(tri), err, param, met_tris, met_err,
                                   ratio, build_s, ours_s[e], ours_s[e] / build_s])
        for budget in (16_000, 64_000, 256_000):
            t0 = time.perf_counter()
            m = rtin.mesh(max_triangles=budget)
            ext = time.perf_counter() - t0
            budget_t.rows.append([f"{n}²", budget, len(m.triangles), m.bound,
                                  max_vertical_error(hm, m.triangles), ext])
    rtin_t.notes += [
        "measured error = max over EVERY grid sample (terrascape.lod.max_vertical_error); "
        "it never exceeds the request",
        "error setup = exact error of every bintree triangle + nesting (done once per map; "
        "for budgets and many meshes); one-mesh build = rtin_mesh(max_error=…) from scratch: "
        "bounds + early-exit scans, the same mesh (best of 3)",
    ]
    # Issue 6 targets at errors ≤ 5 m: RTIN ≤ 2× pymartini's build time, ≥ 5× faster
    # than pydelatin (a time ratio ≤ 0.2).
    for side, err, name, *_, time_ratio in cmp_t.rows:
        limit = {"pymartini": 2.0, "pydelatin": 0.2}.get(name)
        if limit is not None and err <= 5.0:
            cmp_t.check_target(f"RTIN build time / {name}'s, {side} at {err:g} m", time_ratio,
                               at_most=limit, unit="×")
    if Martini is None:
        cmp_t.notes.append("pymartini not installed: skipped (pip install pymartini)")
    if not have_delatin:
        cmp_t.notes.append("pydelatin not installed: skipped (pip install pydelatin)")
    cmp_t.notes += [
        "@param: the mesher's own max_error parameter set to the target; measured on every "
        "sample. @met: largest parameter (bisection) whose measured error ≤ target",
        "ratio < 1 means RTIN needs fewer triangles than that mesher for the same true error",
        "build s: one from-scratch build, best of 3 after a warm-up (RTIN: rtin_mesh with "
        "max_error); targets (issue 6): "
        "RTIN ≤ 2× pymartini's time, ≥ 5× faster than pydelatin at errors ≤ 5 m",
    ]
    budget_t.notes += [
        "bound is non-increasing with the budget by construction; the triangle count never "
        "exceeds the budget (each split adds 1 or 2 triangles)",
        "the first budget row of each size includes the one-time sort of the vertex order",
    ]
    return [rtin_t, cmp_t, budget_t]


STATIC_ERRORS = (1.0, 5.0, 20.0)


def static_mesher_table(quick: bool) -> BenchTable:
    """Every static mesher of the table at the same true maximum errors, on a synthetic map
    and a real DEM: triangles and build time, each also as a ratio to the first (default)
    mesher's, and the error measured on every sample."""
    from terrascape.bench.peers import real_dem
    from terrascape.lod import max_vertical_error
    from terrascape.lod.static_meshers import STATIC_MESHERS

    side = 257 if quick else 1025
    maps = ((f"fBm {side}² (±800 m, 10 m grid)", _terrain(side)),
            ("Jacksboro DEM 344×403", real_dem()))
    names = list(STATIC_MESHERS)
    table = BenchTable(
        title="Static meshers side by side at a true maximum vertical error "
              "(terrascape mesh --mesher)",
        columns=["map", "max error m", "mesher", "triangles", f"÷ {names[0]}'s", "build s",
                 f"÷ {names[0]}'s time", "measured error m"],
    )
    small = _terrain(33)
    for name in names:  # compile (or load the compiled code) outside the timing
        STATIC_MESHERS[name].mesh(small, max_error=1.0)
    for label, hm in maps:
        for error in STATIC_ERRORS:
            first = None
            for name in names:
                mesher = STATIC_MESHERS[name]
                tri = mesher.mesh(hm, max_error=error)
                build = best_of(lambda m=mesher, e=error, hm=hm: m.mesh(hm, max_error=e),
                                repeat=3, warmup=0)
                measured = max_vertical_error(hm, tri)
                first = first or (len(tri), build)
                table.rows.append([label, error, name, len(tri), len(tri) / first[0], build,
                                   build / first[1], measured])
    table.check_target("every mesher's measured error ÷ the error asked for",
                       max(row[7] / row[1] for row in table.rows), at_most=1.0, unit="×")
    table.notes += [
        "the meshers are the rows of STATIC_MESHERS, each with its default options; build s: "
        "best of 3 after a warm-up, on numba's threads",
        "measured error: the largest |mesh − height| over every sample of the map",
    ]
    return table


def run(quick: bool = False) -> list[BenchTable]:
    """Geomipmapping flight, quadtree culling, RTIN true-error and budget tables, and the
    static meshers side by side."""
    import numba

    gm_table, kept = _geomipmap_table(quick)
    tables = [gm_table, _culling_table(quick, kept), *_rtin_tables(quick),
              static_mesher_table(quick)]
    tables[0].notes.append(
        f"numba threads: {numba.get_num_threads()}, CPUs: {os.cpu_count()}, "
        f"load average: {os.getloadavg()[0]:.2f} (shared machine)"
    )
    return tables
