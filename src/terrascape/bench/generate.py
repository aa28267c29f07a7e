"""Benchmark: heightmap generators and blur by grid size (``terrascape bench generate``).

Times are the best of a few runs after a warm-up call (numba compiled and cached), on
float32 output. Sizes 257…4097; ``quick`` runs 257 and 513 only. The gradient-noise table
gives ns per sample on 1 and 2 threads next to pyfastnoisesimd (FastNoiseSIMD's Perlin fBm,
when it is installed) and a plain-numpy reference of the same noise.
"""

from __future__ import annotations

import itertools
import os

import numpy as np

from terrascape.bench import BenchTable, best_of

FULL_SIZES = (257, 513, 1025, 2049, 4097)
QUICK_SIZES = (257, 513)
NOISE_SIZES = (2049, 4097)
QUICK_NOISE_SIZES = (1025,)
NOISE_OCTAVES = 6
NOISE_SCALE = 128.0


def _fastnoise(threads: int):
    """pyfastnoisesimd's Perlin fBm (6 octaves, wavelength 128) as ``fill(rows, cols)``, on
    ``threads`` row bands, or ``None`` when the package is not installed. Rows are padded to
    its SIMD width (16 floats); the caller divides by the samples actually computed."""
    try:
        import pyfastnoisesimd as fns
    except ImportError:
        return None, ("pyfastnoisesimd is not installed (pip install numpy wheel setuptools, "
                      "then pip install --no-build-isolation pyfastnoisesimd)")
    from concurrent.futures import ThreadPoolExecutor

    noise = fns.Noise(seed=1, numWorkers=1)
    noise.noiseType = fns.NoiseType.PerlinFractal
    noise.fractal.fractalType = fns.FractalType.FBM
    noise.fractal.octaves = NOISE_OCTAVES
    noise.frequency = 1.0 / NOISE_SCALE
    pool = ThreadPoolExecutor(threads)

    def fill(rows: int, cols: int) -> int:
        cols = (cols + 15) // 16 * 16
        out = fns.empty_aligned((rows, cols))
        bounds = np.linspace(0, rows, threads + 1).astype(int)
        # FillNoiseSet(array, x0, y0, z0, nx, ny, nz) on contiguous row bands; the library's
        # own genAsGrid needs numpy < 2 (np.product).
        jobs = [pool.submit(noise._fns.FillNoiseSet, out[a:b], int(a), 0, 0, int(b - a), cols, 1)
                for a, b in itertools.pairwise(bounds)]
        for job in jobs:
            job.result()
        return rows * cols

    return fill, f"pyfastnoisesimd {fns.__version__}, SIMD level {fns.extension.SIMD_LEVEL}"


def _wall_and_cpu(func) -> tuple[float, float]:
    """Wall and process CPU seconds (all threads) of one call."""
    import time

    c0, t0 = time.process_time(), time.perf_counter()
    func()
    return time.perf_counter() - t0, time.process_time() - c0


def _noise_table(quick: bool) -> BenchTable:
    import numba

    from terrascape.generate.noise import fbm, reference_fbm

    sizes = QUICK_NOISE_SIZES if quick else NOISE_SIZES
    table = BenchTable(
        title=f"Gradient-noise fBm ({NOISE_OCTAVES} octaves, wavelength {NOISE_SCALE:g} "
        "samples): ns per sample, wall time and CPU time of all threads",
        columns=["grid", "threads", "terrascape wall", "pyfastnoisesimd wall", "ratio",
                 "terrascape CPU", "pyfastnoisesimd CPU", "CPU ratio", "2-thread speed-up"],
    )
    saved = numba.get_num_threads()
    about = "pyfastnoisesimd is not installed"
    one_thread: dict[int, tuple[float, float]] = {}
    inf = float("inf")
    try:
        for n in sizes:
            for threads in (1, 2):
                numba.set_num_threads(threads)
                fill, about = _fastnoise(threads)
                ours, theirs = [inf, inf], [inf, inf]
                repeat = 3 if n <= 2049 else 2

                def make(n=n):
                    return fbm(n, scale=NOISE_SCALE, octaves=NOISE_OCTAVES, seed=1)

                make()
                if fill is not None:
                    samples = fill(n, n)
                # Interleaved, so both see the same machine load.
                for _ in range(repeat):
                    ours = [min(a, b / (n * n)) for a, b in zip(ours, _wall_and_cpu(make),
                                                               strict=True)]
                    if fill is not None:
                        timed = _wall_and_cpu(lambda n=n, fill=fill: fill(n, n))
                        theirs = [min(a, b / samples) for a, b in zip(theirs, timed,
                                                                     strict=True)]
                if threads == 1:
                    one_thread[n] = (ours[0], ours[1])
                have = fill is not None
                table.rows.append([
                    f"{n}²", threads, ours[0] * 1e9, theirs[0] * 1e9 if have else "—",
                    f"{ours[0] / theirs[0]:.2f}" if have else "—",
                    ours[1] * 1e9, theirs[1] * 1e9 if have else "—",
                    f"{ours[1] / theirs[1]:.2f}" if have else "—",
                    f"{one_thread[n][0] / ours[0]:.2f}×" if threads == 2 else "",
                ])
    finally:
        numba.set_num_threads(saved)
    strip = (128, sizes[0])
    ref = best_of(lambda: reference_fbm(strip, scale=NOISE_SCALE, octaves=NOISE_OCTAVES,
                                        seed=1), repeat=2, warmup=1) / (strip[0] * strip[1])
    table.notes += [
        about,
        f"plain-numpy reference of the same noise (four corner hashes per sample, one thread): "
        f"{ref * 1e9:.0f} ns per sample (wall) on a {strip[1]}×{strip[0]} strip",
        "ratio = terrascape / pyfastnoisesimd (< 1: terrascape faster); pyfastnoisesimd "
        "computes 3D Perlin noise on the z = 0 plane (8 corners), terrascape 2D (4 corners)",
        "CPU = process CPU time of all threads per sample: on a shared machine it is closer "
        "to the cost of the work, where wall time also counts waiting for a core (2 threads "
        "that do not duplicate work keep the CPU time of 1)",
        f"CPUs: {os.cpu_count()}, load average at the end: {os.getloadavg()[0]:.2f}",
    ]
    return table


def run(quick: bool = False) -> list[BenchTable]:
    """Time diamond-square, fault formation (1000 faults), hills (1000) and Gaussian blur."""
    import numba

    from terrascape.filters import gaussian_blur, hydraulic_erosion, thermal_erosion
    from terrascape.generate import diamond_square, fault_formation, fbm, generate, hills

    sizes = QUICK_SIZES if quick else FULL_SIZES
    cases = {
        "diamond-square (halve)": lambda n: diamond_square(n, seed=1),
        "square-square (halve; diamond-square's default variant)":
            lambda n: generate("diamond-square", n, seed=1, raw=True),
        "fault 1000 (step)": lambda n: fault_formation(n, iterations=1000, seed=1),
        "fault 1000 (sine, w=8)": lambda n: fault_formation(n, iterations=1000, seed=1,
                                                            falloff="sine"),
        "hills 1000 (r = side/64…side/16)": lambda n: hills(n, count=1000, seed=1),
        "hills, registry default (no flat floor: ~10 hills per sample)":
            lambda n: generate("hills", n, seed=1, raw=True),
        "fBm 6 octaves, wavelength 128": lambda n: fbm(n, seed=1),
        "ridged, registry default (wavelength side/4)":
            lambda n: generate("ridged", n, seed=1, raw=True),
    }
    table = BenchTable(
        title="Heightmap generation time (ms) by grid side",
        columns=["algorithm", *[f"{n}²" for n in sizes]],
    )
    for name, make in cases.items():
        row: list = [name]
        for n in sizes:
            # Small cases are cheap: more repeats escape scheduling hiccups on a shared machine.
            repeat = 7 if n <= 1025 else 3
            row.append(best_of(lambda make=make, n=n: make(n), repeat=repeat, warmup=1) * 1e3)
        table.rows.append(row)
    blur_row: list = ["gaussian blur σ=2 (scipy, float64)"]
    for n in sizes:
        hm = diamond_square(n, seed=1)
        blur_row.append(best_of(lambda hm=hm: gaussian_blur(hm, 2.0), repeat=5, warmup=1) * 1e3)
    table.rows.append(blur_row)
    table.notes += [
        f"best of 3–7 runs after a warm-up; numba threads: {numba.get_num_threads()}, "
        f"CPUs: {os.cpu_count()}, load average at the end: {os.getloadavg()[0]:.2f}",
        "targets (brief): diamond-square 4097² ≤ 250 ms; fault 1025² × 1000 ≤ 1000 ms; "
        "hills 1025² × 1000 ≤ 500 ms",
        "diamond-square includes the bulk draw of size² float32 uniforms (numpy Generator)",
    ]
    table.check_target("diamond-square 4097²", table.value("diamond-square (halve)", "4097²"),
                       at_most=250, unit=" ms")
    table.check_target("fault 1025² × 1000", table.value("fault 1000 (step)", "1025²"),
                       at_most=1000, unit=" ms")
    table.check_target("hills 1025² × 1000",
                       table.value("hills 1000 (r = side/64…side/16)", "1025²"),
                       at_most=500, unit=" ms")
    erosion_sizes = QUICK_SIZES if quick else (257, 513, 1025)
    ero = BenchTable(
        title="Erosion time (ms) by grid side",
        columns=["filter", *[f"{n}²" for n in erosion_sizes]],
    )
    thermal_row: list = ["thermal, 10 iterations, 8 neighbours"]
    hydraulic_row: list = ["hydraulic, 10 000 droplets × ≤30 steps"]
    for n in erosion_sizes:
        hm = diamond_square(n, roughness=n / 4, seed=1)
        thermal_row.append(best_of(lambda hm=hm: thermal_erosion(hm, iterations=10),
                                   repeat=3, warmup=1) * 1e3)
        hydraulic_row.append(best_of(lambda hm=hm: hydraulic_erosion(hm, droplets=10_000),
                                     repeat=3, warmup=1) * 1e3)
    ero.rows += [thermal_row, hydraulic_row]
    ero.notes.append("hydraulic droplets run sequentially (each sees the previous ones)")
    return [table, _noise_table(quick), ero]
