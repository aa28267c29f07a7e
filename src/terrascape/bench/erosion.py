"""Benchmark: erosion models measured like real terrain (``terrascape bench erosion``).

For each model and grid side: wall time, the drainage-area exceedance exponent β
(``P(A ≥ a) ~ a^−β``, areas in samples, fitted from 10 samples to 1 % of the map), the share
of samples in closed depressions and the mean height change, next to the same figures for
the raw fBm input and for a real DEM (the Jacksboro fault DEM that matplotlib ships,
403×344 samples of 3″ ≈ 90 m). The input is the same landscape at every size: fBm with a
base wavelength of 1/8 of the map, 6 octaves at 1025² (one more per doubling, one fewer
per halving), 300 m of relief over 4 km. Targets (real basins: β ≈ 0.43–0.5,
Rodriguez-Iturbe & Rinaldo 1997): after the default model β in 0.40–0.55 and at most 10 %
of samples in depressions, 1025² in ≤ 15 s and 4097² in ≤ 4 min on two cores.

Sizes 1025², 2049², 4097² (grid, droplets and thermal up to 2049²); ``quick``: 257², 513².
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from terrascape.bench import BenchTable
from terrascape.bench._sample_dem import real_dem

FULL_SIZES = (1025, 2049, 4097)
QUICK_SIZES = (257, 513)
BETA_RANGE = (0.40, 0.55)
MAX_DEPRESSION_SHARE = 0.10
TIME_LIMITS = {1025: 15.0, 4097: 240.0}  # seconds, default model


def bench_terrain(side: int):
    """The benchmark's fBm input at ``side`` samples: the same 4 km landscape at any size."""
    from terrascape.generate import fbm

    steps = side - 1
    octaves = max(3, 6 + round(math.log2(steps / 1024)))
    return fbm(side, scale=steps / 8, octaves=octaves, seed=1,
               spacing=4096.0 / steps).normalised(0.0, 300.0)


def _models(quick: bool) -> list[tuple[str, tuple[int, ...]]]:
    if quick:
        return [(m, QUICK_SIZES) for m in ("stream-power", "grid", "droplets", "thermal")]
    return [("stream-power", FULL_SIZES), ("grid", (1025, 2049)), ("droplets", (1025, 2049)),
            ("thermal", (1025, 2049))]


def run(quick: bool = False) -> list[BenchTable]:
    """Time every model and measure its drainage; print which targets were met."""
    import numba

    from terrascape.analysis.drainage import drainage_statistics
    from terrascape.filters import DEFAULT_MODEL, erode
    from terrascape.filters.erosion_models import DEFAULT_DEPOSITION

    table = BenchTable(
        title="Erosion: time and drainage like real terrain (β of P(A ≥ a) ~ a^−β, "
              "share of samples in closed depressions)",
        columns=["terrain / model", "side", "time (s)", "β", "depressions (%)",
                 "mean |Δh| (m)", "top 1 % carries (%)"],
    )
    dem = real_dem()
    st = drainage_statistics(dem)
    table.rows.append(["real DEM (Jacksboro fault, 90 m)", f"{dem.cols}×{dem.rows}", "",
                       st.beta, 100 * st.depression_share, "", 100 * st.top1_flow_share])
    erode(bench_terrain(65))  # compile (or load the numba cache) outside the timings
    for model in ("grid", "droplets", "thermal"):
        erode(bench_terrain(65), model=model, iterations=5)
    raw_done: set[int] = set()
    met: list[str] = []
    missed: list[str] = []
    for model, sizes in _models(quick):
        for side in sizes:
            hm = bench_terrain(side)
            if side not in raw_done:
                raw = drainage_statistics(hm)
                table.rows.append(["raw fBm", f"{side}²", "", raw.beta,
                                   100 * raw.depression_share, 0.0, 100 * raw.top1_flow_share])
                raw_done.add(side)
            t0 = time.perf_counter()
            res = erode(hm, model=model)
            seconds = time.perf_counter() - t0
            st = drainage_statistics(res.heightmap)
            dh = float(np.abs(res.heightmap.heights - hm.heights).mean())
            table.rows.append([model, f"{side}²", seconds, st.beta,
                               100 * st.depression_share, dh, 100 * st.top1_flow_share])
            if model != DEFAULT_MODEL:
                continue
            ok_beta = BETA_RANGE[0] <= st.beta <= BETA_RANGE[1]
            ok_dep = st.depression_share <= MAX_DEPRESSION_SHARE
            (met if ok_beta else missed).append(
                f"{side}² β {st.beta:.3f} in {BETA_RANGE[0]}–{BETA_RANGE[1]}")
            (met if ok_dep else missed).append(
                f"{side}² depressions {100 * st.depression_share:.1f} % ≤ 10 %")
            if side in TIME_LIMITS:
                (met if seconds <= TIME_LIMITS[side] else missed).append(
                    f"{side}² in {seconds:.1f} s ≤ {TIME_LIMITS[side]:g} s")
    table.notes += [
        f"default model: {DEFAULT_MODEL} (deposition G = {DEFAULT_DEPOSITION:g}: fans where "
        "rivers leave steep ground); each model at its defaults (terrascape erode "
        "--model NAME); one run per cell, after a compile run on 65²",
        "targets met: " + ("; ".join(met) if met else "none"),
        "targets missed: " + ("; ".join(missed) if missed else "none"),
        f"numba threads: {numba.get_num_threads()}, CPUs: {os.cpu_count()}, load average "
        f"at the end: {os.getloadavg()[0]:.2f} (times on a shared machine drift)",
    ]
    return [table]


__all__ = ["bench_terrain", "real_dem", "run"]
