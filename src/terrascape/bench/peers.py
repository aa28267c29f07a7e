"""``terrascape bench peers``: terrascape against the libraries users would pick instead.

Each row times terrascape and a peer on the same input, interleaved: every round runs both
jobs back to back (the order reversed every other round) and the ratio of that round is
taken; the table gives the median of those ratios and their spread (min–max). The two cores
of a shared host drift by up to 2× within hours, so ratios of neighbouring runs are the only
stable figures. A peer that is not installed is a skipped row, not a failure (install the
``peers`` extra, ``pip install 'terrascape[peers]'``, or one peer such as ``pip install
insolation``; pyfastnoisesimd builds only with ``pip install --no-build-isolation
pyfastnoisesimd``, numpy, wheel and setuptools installed first).

Rows:

* cast-shadow mask — :func:`terrascape.lighting.shadow_mask` (exact line sweep, parallel
  over blocks of ray lines) against ``insolation``'s ``shadows`` (Corripio 2003's sun-path
  scan, numba, parallel over scan lines). Agreement of both with the exact ray walk
  (:func:`terrascape.lighting.shadow_mask_reference`'s per-sample test) is measured on a
  fixed random sample of points, since the full O(n³) walk at 4097² takes minutes.
* static mesh at a true maximum error — :func:`terrascape.lod.greedy_tin.greedy_tin`
  (Garland–Heckbert greedy insertion, then the removal of the vertices the mesh no longer
  needs, in pieces on all threads; dense pieces decimated from every sample instead)
  against ``pydelatin`` (the greedy insertion alone, in
  C++, one thread): triangles and build time, ours on all threads and on one, at 1, 2, 5
  and 10 m on a synthetic map and the real DEM that matplotlib ships
  (Jacksboro fault, 344×403, about 90 m spacing). The error is measured on every sample.
* gradient-noise fBm (6 octaves, wavelength 128 samples) — :func:`terrascape.generate.fbm`
  against pyfastnoisesimd's Perlin FBM (FastNoiseSIMD, thread for thread, 1 and 2 threads)
  and, on a smaller grid and one thread, against ``opensimplex`` (its numpy
  ``noise2array`` per octave) and ``noise`` (``pnoise2`` called per sample, as its users do);
  compared per sample computed.
* plain hillshade — :func:`terrascape.lighting.lambert` against ``xarray-spatial``'s
  ``hillshade`` on the same map and sun (both the cosine of the sun's incidence; their
  agreement is given as a correlation on the inner samples).
* render mesh of the full grid — :func:`terrascape.mesh.terrain_mesh` with its triangle
  indices against pyvista (VTK): a ``StructuredGrid`` surface, triangulated, with point
  normals.
* ``import terrascape`` and ``terrascape --help`` in a fresh interpreter, against ``import
  numpy``, ``import rasterio``, ``gdalinfo --version`` and ``import pyvista``
  (:mod:`terrascape.bench.startup`).

References
----------
.. [1] Corripio, J. G. (2003). Vectorial algebra algorithms for calculating terrain
   parameters from DEMs and solar radiation modelling in mountainous terrain.
   International Journal of Geographical Information Science 17(1), 1–23.
"""

from __future__ import annotations

import importlib.util
import statistics
import time
from collections.abc import Callable

import numba
import numpy as np

from terrascape.bench import BenchTable
from terrascape.bench._sample_dem import real_dem
from terrascape.bench.shade import terrain
from terrascape.lighting import shadow_mask
from terrascape.lighting._common import sun_above_horizon
from terrascape.lighting.shadows import _oriented, _ray_hits_terrain, _sweep_geometry
from terrascape.lighting.sun import sun_direction

# Targets of the peers comparison (terrascape's time ÷ the peer's, two threads).
SHADOW_TARGET = 0.6
AGREEMENT_TARGET = 99.9  # % of samples equal to the exact ray walk
AGREEMENT_SAMPLES = 200_000
NOISE_TARGET = 1.5  # terrascape's time per sample ÷ pyfastnoisesimd's, thread for thread
# (elevation, azimuth) °: the target's span of elevations 5-45° and azimuths round the
# compass, with suns near the x axis (the sweep runs on a transposed copy) and near the axes'
# diagonals
SHADOW_CASES = ((5.0, 30.0), (20.0, 135.0), (45.0, 250.0), (20.0, 0.0), (10.0, 300.0),
                (10.0, 105.0), (20.0, 105.0), (5.0, 200.0), (30.0, 75.0))


def paired_ratio(
    ours: Callable[[], object], theirs: Callable[[], object], rounds: int
) -> tuple[float, float, float, float, float]:
    """Median ratio ours/theirs over interleaved rounds, with min and max, and median times.

    Both jobs run once untimed first (compilation, caches). Odd rounds run the peer first.
    """
    ours()
    theirs()
    ratios, t_ours, t_theirs = [], [], []
    for r in range(rounds):
        pair = [(0, ours), (1, theirs)]
        if r % 2:
            pair.reverse()
        times = [0.0, 0.0]
        for slot, job in pair:
            t0 = time.perf_counter()
            job()
            times[slot] = time.perf_counter() - t0
        t_ours.append(times[0])
        t_theirs.append(times[1])
        ratios.append(times[0] / times[1])
    return (
        statistics.median(ratios), min(ratios), max(ratios),
        statistics.median(t_ours), statistics.median(t_theirs),
    )


def _with_threads(n: int, job: Callable[[], object]) -> Callable[[], object]:
    def run() -> object:
        before = numba.get_num_threads()
        numba.set_num_threads(n)
        try:
            return job()
        finally:
            numba.set_num_threads(before)

    return run


def exact_shadow_at(hm, azimuth: float, elevation: float, rows, cols) -> np.ndarray:
    """The exact ray walk's decision at the given samples only (bool array)."""
    light = sun_above_horizon(azimuth, elevation)
    geo = _sweep_geometry(hm, light)
    if geo is None:
        return np.zeros(len(rows), dtype=bool)
    transpose, da, db, rise = geo
    h, _, _ = _oriented(hm, transpose)
    hmax = float(hm.heights.max())
    a_idx, b_idx = (cols, rows) if transpose else (rows, cols)
    return np.array(
        [_ray_hits_terrain(h, int(a), int(b), da, db, rise, hmax) for a, b in zip(a_idx, b_idx,
                                                                             strict=True)],
        dtype=bool,
    )


def insolation_shadow(hm, azimuth: float, elevation: float) -> np.ndarray:
    """``insolation``'s shadow mask in terrascape's axes (True = shadow)."""
    from insolation.shadows import shadows

    sx, sy, sz = sun_direction(azimuth, elevation)
    # insolation's sun vector: (toward +column, toward +row, up); rows grow southward in
    # both, so terrascape's z is its second component.
    illum = shadows(hm.heights.astype(np.float64), float(hm.spacing[0]),
                    np.array([sx, sz, sy]), 1)
    return illum == 0


def _shadow_rows(size: int, rounds: int, table: BenchTable) -> None:
    have_peer = importlib.util.find_spec("insolation") is not None
    hm = terrain(size)
    rng = np.random.default_rng(5)
    # 200,000 samples: the share that disagrees is about 0.05 %, and on 20,000 samples its
    # sampling noise (±0.02-0.03 %) alone moved a sun across the 99.9 % line
    rows = rng.integers(0, hm.shape[0], AGREEMENT_SAMPLES)
    cols = rng.integers(0, hm.shape[1], AGREEMENT_SAMPLES)
    threads = numba.get_num_threads()
    for el, az in SHADOW_CASES:
        ours_mask = shadow_mask(hm, az, el)
        exact = exact_shadow_at(hm, az, el, rows, cols)
        agree_ours = 100.0 * float(np.mean(ours_mask[rows, cols] == exact))
        one = _with_threads(1, lambda hm=hm, az=az, el=el: shadow_mask(hm, az, el))
        two = _with_threads(threads, lambda hm=hm, az=az, el=el: shadow_mask(hm, az, el))
        scale, _, _, _, t2 = paired_ratio(one, two, rounds)
        if not have_peer:
            table.rows.append([size, az, el, t2, "-", "-", "-", scale, agree_ours, "-"])
            continue
        peer = lambda hm=hm, az=az, el=el: insolation_shadow(hm, az, el)  # noqa: E731
        peer_mask = peer()
        agree_peer = 100.0 * float(np.mean(peer_mask[rows, cols] == exact))
        ratio, lo, hi, t_ours, t_peer = paired_ratio(two, peer, rounds)
        table.rows.append([size, az, el, t_ours, t_peer, ratio, f"{lo:.2f}–{hi:.2f}", scale,
                           agree_ours, agree_peer])
        table.check_target(f"sun {az:g}°/{el:g}°: ours ÷ insolation", ratio,
                           at_most=SHADOW_TARGET, unit="×")
        table.check_target(f"sun {az:g}°/{el:g}°: equal to the ray walk", agree_ours,
                           at_least=AGREEMENT_TARGET, unit=" %")
        table.check_target(f"sun {az:g}°/{el:g}°: two threads' speed-up", scale,
                           at_least=1.8, unit="×")
    if not have_peer:
        table.notes.append("insolation is not installed: peer columns skipped")


TIN_ERRORS = (1.0, 2.0, 5.0, 10.0)
TIN_TRIANGLE_TARGET = 1.0
TIN_SPEED_TARGET = 0.2  # ours ÷ peer time (5× faster)
# the large map's row: one error, a few seconds a build
TIN_LARGE = ("synthetic 4097²", 4097, 2.0)


def _large_rounds(rounds: int) -> int:
    return max(3, rounds // 2)


def _tin_rows(quick: bool, rounds: int, table: BenchTable) -> None:
    from terrascape.lod.greedy_tin import greedy_tin
    from terrascape.lod.mesh_checks import max_vertical_error

    have_peer = importlib.util.find_spec("pydelatin") is not None
    maps = [("synthetic 1025²" if not quick else "synthetic 513²",
             terrain(513 if quick else 1025).normalised(0.0, 400.0), TIN_ERRORS, rounds)]
    try:
        maps.append(("Jacksboro DEM 344×403", real_dem(), TIN_ERRORS, rounds))
    except (ImportError, OSError):
        table.notes.append("matplotlib's sample DEM is missing: real-DEM rows skipped")
    if not quick:
        # a large map, where the pieces also keep each one's work in cache (a few seconds a
        # build, so one error and fewer rounds)
        name, size, err = TIN_LARGE
        maps.append((name, terrain(size).normalised(0.0, 1000.0), (err,),
                     _large_rounds(rounds)))
    for name, hm, errors, map_rounds in maps:
        rows, cols = hm.shape
        for err in errors:
            ours = lambda hm=hm, err=err: greedy_tin(hm, max_error=err)  # noqa: E731
            tri = ours()
            measured = max_vertical_error(hm, tri)
            if not have_peer:
                table.rows.append([name, err, len(tri), "-", "-", "-", "-", "-", measured])
                continue
            from pydelatin import Delatin

            peer = lambda hm=hm, err=err, rows=rows, cols=cols: Delatin(  # noqa: E731
                hm.heights, width=cols, height=rows, max_error=err)
            n_peer = len(peer().triangles)
            ratio, lo, hi, _, _ = paired_ratio(ours, peer, map_rounds)
            # the peer runs on one thread: ours on one thread too, for a fair reading
            alone, _, _, _, _ = paired_ratio(_with_threads(1, ours), peer, map_rounds)
            table.rows.append([name, err, len(tri), n_peer, len(tri) / n_peer, ratio,
                               f"{lo:.2f}–{hi:.2f}", alone, measured])
            table.check_target(f"{name} at {err:g} m: triangles ÷ pydelatin's", len(tri) / n_peer,
                               at_most=TIN_TRIANGLE_TARGET, unit="×")
            table.check_target(f"{name} at {err:g} m: time ÷ pydelatin's", ratio,
                               at_most=TIN_SPEED_TARGET, unit="×")
    if not have_peer:
        table.notes.append("pydelatin is not installed: peer columns skipped")


def _noise_rows(quick: bool, rounds: int, table: BenchTable) -> None:
    """fBm against pyfastnoisesimd thread for thread, then against opensimplex and noise on
    one thread; times are per sample computed (pyfastnoisesimd pads rows to 16 floats)."""
    from terrascape.bench.generate import NOISE_OCTAVES, NOISE_SCALE, _fastnoise
    from terrascape.generate.noise import fbm

    def ours(n: int) -> Callable[[], object]:
        return lambda: fbm(n, scale=NOISE_SCALE, octaves=NOISE_OCTAVES, seed=1)

    about = ""
    for n in (1025,) if quick else (2049, 4097):
        for threads in (1, 2):
            fill, about = _fastnoise(threads)
            if fill is None:
                table.rows.append([f"{n}²", threads, "pyfastnoisesimd", "-", "-", "-", "-"])
                continue
            peer_samples = fill(n, n)
            ratio, lo, hi, t_ours, t_peer = paired_ratio(
                _with_threads(threads, ours(n)), lambda n=n, fill=fill: fill(n, n), rounds)
            per_sample = peer_samples / (n * n)  # ratio of the times per sample computed
            table.rows.append([f"{n}²", threads, "pyfastnoisesimd", t_ours / (n * n) * 1e9,
                               t_peer / peer_samples * 1e9, ratio * per_sample,
                               f"{lo * per_sample:.2f}–{hi * per_sample:.2f}"])
            table.check_target(f"fBm {n}² on {threads} thread(s) ÷ pyfastnoisesimd",
                               ratio * per_sample, at_most=NOISE_TARGET, unit="×")
    table.notes.append(about)
    n = 129 if quick else 257
    x = np.arange(n, dtype=np.float64) / NOISE_SCALE
    peers: dict[str, Callable[[], object] | str] = {}
    if importlib.util.find_spec("opensimplex") is not None:
        import opensimplex

        opensimplex.seed(1)

        def simplex_fbm() -> np.ndarray:
            total = np.zeros((n, n))
            for octave in range(NOISE_OCTAVES):
                f = 2.0 ** octave
                total += 0.5 ** octave * opensimplex.noise2array(x * f, x * f)
            return total

        peers["opensimplex"] = simplex_fbm
    else:
        peers["opensimplex"] = "opensimplex is not installed (pip install opensimplex)"
    if importlib.util.find_spec("noise") is not None:
        from noise import pnoise2

        def perlin_fbm() -> np.ndarray:
            return np.array([[pnoise2(c, r, octaves=NOISE_OCTAVES, base=1) for c in x]
                             for r in x])

        peers["noise"] = perlin_fbm
    else:
        peers["noise"] = "noise is not installed (pip install noise)"
    for name, peer in peers.items():
        if isinstance(peer, str):
            table.rows.append([f"{n}²", 1, name, "-", "-", "-", "-"])
            table.notes.append(peer)
            continue
        ratio, lo, hi, t_ours, t_peer = paired_ratio(_with_threads(1, ours(n)), peer,
                                                     max(3, rounds // 2))
        table.rows.append([f"{n}²", 1, name, t_ours / (n * n) * 1e9, t_peer / (n * n) * 1e9,
                           ratio, f"{lo:.3f}–{hi:.3f}"])


def _hillshade_rows(size: int, rounds: int, table: BenchTable) -> None:
    from terrascape.lighting import lambert

    hm = terrain(size)
    azimuth, elevation = 315.0, 45.0
    ours = lambda: lambert(hm, azimuth, elevation)  # noqa: E731
    if importlib.util.find_spec("xrspatial") is None:
        table.rows.append([f"{size}²", "xarray-spatial hillshade", "-", "-", "-", "-", "-"])
        table.notes.append("xarray-spatial is not installed (pip install xarray-spatial)")
        return
    import xarray as xr
    from xrspatial import hillshade

    dx, dz = hm.spacing
    grid = xr.DataArray(hm.heights, dims=("y", "x"),
                        coords={"y": np.arange(hm.rows) * dz, "x": np.arange(hm.cols) * dx})
    # xarray-spatial measures azimuth clockwise from north and, for a DataArray whose y grows
    # downwards as here, sees north at row 0 like terrascape; only the inner samples compare
    # (it leaves the border NaN).
    peer = lambda: hillshade(grid, azimuth=int(azimuth), angle_altitude=int(elevation))  # noqa: E731
    theirs = np.asarray(peer())
    inner = (slice(1, -1), slice(1, -1))
    a, b = ours()[inner].ravel(), theirs[inner].ravel()
    keep = np.isfinite(b)
    correlation = float(np.corrcoef(a[keep], b[keep])[0, 1])
    ratio, lo, hi, t_ours, t_peer = paired_ratio(ours, peer, rounds)
    table.rows.append([f"{size}²", "xarray-spatial hillshade", t_ours, t_peer, ratio,
                       f"{lo:.2f}–{hi:.2f}", correlation])


def _mesh_rows(size: int, rounds: int, table: BenchTable) -> None:
    from terrascape.mesh import terrain_mesh

    hm = terrain(size)

    def ours() -> tuple[object, np.ndarray]:
        mesh = terrain_mesh(hm)
        return mesh, mesh.triangles

    if importlib.util.find_spec("pyvista") is None:
        table.rows.append([f"{size}²", "pyvista", "-", "-", "-", "-", "-", "-"])
        table.notes.append("pyvista is not installed (pip install pyvista)")
        return
    import pyvista as pv

    dx, dz = hm.spacing
    xs, zs = np.meshgrid(np.arange(hm.cols) * dx, np.arange(hm.rows) * dz)

    def peer():
        grid = pv.StructuredGrid(xs, hm.heights.astype(np.float64), zs)
        return grid.extract_surface(algorithm=None).triangulate().compute_normals(
            cell_normals=False, split_vertices=False, consistent_normals=False,
            auto_orient_normals=False)

    n_ours = len(ours()[1])
    n_peer = peer().n_cells
    ratio, lo, hi, t_ours, t_peer = paired_ratio(ours, peer, rounds)
    table.rows.append([f"{size}²", "pyvista", t_ours, t_peer, ratio, f"{lo:.2f}–{hi:.2f}",
                       n_ours, n_peer])


def run(quick: bool = False) -> list[BenchTable]:
    size = 1025 if quick else 4097
    rounds = 3 if quick else 7
    shadows = BenchTable(
        f"Cast-shadow mask {size}²: terrascape's sweep vs insolation (Corripio 2003)",
        ["size", "az °", "el °", "ours s", "insolation s", "ours/peer", "spread",
         "1 thread ÷ all", "ours = ray walk %", "peer = ray walk %"],
    )
    _shadow_rows(size, rounds, shadows)
    shadows.notes += [
        f"medians of {rounds} interleaved rounds; ours on {numba.get_num_threads()} threads",
        "1 thread ÷ all: terrascape's speed-up from its threads (paired rounds)",
        f"agreement with the exact ray walk on {AGREEMENT_SAMPLES:,} random samples",
    ]
    tin = BenchTable(
        "Static mesh at a true maximum error: greedy insertion and vertex removal vs "
        "pydelatin",
        ["map", "max error m", "ours triangles", "pydelatin triangles", "ratio",
         "time ours/peer", "spread", "1 thread ours/peer", "measured error m"],
    )
    _tin_rows(quick, rounds, tin)
    large = "" if quick else f" ({TIN_LARGE[1]}²: {_large_rounds(rounds)})"
    tin.notes += [
        f"medians of {rounds} interleaved rounds{large}; ours on {numba.get_num_threads()} "
        "threads (pieces of the map meshed in parallel), pydelatin on one",
        "measured error: the largest |mesh − height| over every sample of the map",
    ]
    noise = BenchTable(
        "Gradient-noise fBm, 6 octaves: terrascape vs pyfastnoisesimd, opensimplex, noise",
        ["grid", "threads", "peer", "ours ns/sample", "peer ns/sample", "ours/peer",
         "spread"],
    )
    _noise_rows(quick, rounds, noise)
    noise.notes += [
        f"medians of {rounds} interleaved rounds (opensimplex, noise: {max(3, rounds // 2)}); "
        "pyfastnoisesimd on its own threads, as many as ours",
        f"target: ≤ {NOISE_TARGET:g}× pyfastnoisesimd's time per sample, thread for thread",
    ]
    grid = 1025 if quick else 2049
    hillshade = BenchTable(
        "Plain hillshade (sun 315°, 45°): terrascape's Lambert term vs xarray-spatial",
        ["size", "peer", "ours s", "peer s", "ours/peer", "spread", "correlation"],
    )
    _hillshade_rows(grid, rounds, hillshade)
    hillshade.notes.append("correlation of the two shadings over the inner samples")
    mesh = BenchTable(
        "Full-grid render mesh (positions, normals, triangles): terrascape vs pyvista",
        ["size", "peer", "ours s", "peer s", "ours/peer", "spread", "ours triangles",
         "peer triangles"],
    )
    _mesh_rows(grid, rounds, mesh)
    mesh.notes.append("ours: terrain_mesh (also tangents) and its triangle indices; pyvista: "
                      "StructuredGrid → extract_surface → triangulate → compute_normals")
    from terrascape.bench._render_peer import frame_rate_table
    from terrascape.bench.startup import startup_table

    startup = startup_table(5 if quick else 15)
    frames = frame_rate_table(257 if quick else 1025, 1 if quick else 3)
    return [shadows, tin, noise, hillshade, mesh, frames, startup]


__all__ = ["exact_shadow_at", "insolation_shadow", "paired_ratio", "real_dem", "run"]
