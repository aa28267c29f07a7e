"""Benchmark: heightmap generators and blur by grid size (``terrascape bench generate``).

Times are the best of a few runs after a warm-up call (numba compiled and cached), on
float32 output. Sizes 257…4097; ``quick`` runs 257 and 513 only.
"""

from __future__ import annotations

import os

from terrascape.bench import BenchTable, best_of

FULL_SIZES = (257, 513, 1025, 2049, 4097)
QUICK_SIZES = (257, 513)


def run(quick: bool = False) -> list[BenchTable]:
    """Time diamond-square, fault formation (1000 faults), hills (1000) and Gaussian blur."""
    import numba

    from terrascape.filters import gaussian_blur, hydraulic_erosion, thermal_erosion
    from terrascape.generate import diamond_square, fault_formation, fbm, hills

    sizes = QUICK_SIZES if quick else FULL_SIZES
    cases = {
        "diamond-square (halve)": lambda n: diamond_square(n, seed=1),
        "fault 1000 (step)": lambda n: fault_formation(n, iterations=1000, seed=1),
        "fault 1000 (sine, w=8)": lambda n: fault_formation(n, iterations=1000, seed=1,
                                                            falloff="sine"),
        "hills 1000 (r = side/64…side/16)": lambda n: hills(n, count=1000, seed=1),
        "fBm 6 octaves (H7)": lambda n: fbm(n, seed=1),
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
        title="Erosion time (ms) by grid side (H7, beyond the seeds)",
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
    return [table, ero]
