"""Where the shadow sweep's two-thread speed-up goes: each block of ray lines timed alone.

    python scripts/shadow_block_costs.py [SIZE]

For each sun, on one thread: the sweep as one block, and split into the 2 and 4 blocks of
equal work that two threads share (:func:`terrascape.lighting.shadows._block_bounds`),
each block timed by itself (best of 3). The sum over the blocks against the one block is
what splitting costs. Then the whole mask on two threads split into 2 and into 4 blocks
(median of 5). Last, what else the whole mask's time holds: the extrema pass that streams
the map (the kernel's own loop) and the mask's first touch, on one thread and on two
(median of 7).
"""

from __future__ import annotations

import sys
import time

import numba
import numpy as np

from terrascape._numba import read_only
from terrascape.bench.shade import terrain
from terrascape.bench.terrain_vs_relief import _median_ms  # after one untimed call
from terrascape.lighting import shadows as sweep
from terrascape.lighting._common import sun_above_horizon

SUNS = ((30, 5), (200, 5), (135, 20))  # (azimuth, elevation) °


def _extrema(h):
    segments = (h.shape[1] + sweep._SEGMENT - 1) // sweep._SEGMENT
    smax = np.empty((h.shape[0], segments), h.dtype)
    smin = np.empty_like(smax)
    top = max(sweep._segment_extrema(h[a], smax[a], smin[a]) for a in range(h.shape[0]))
    return smax, smin, sweep._SKIP_MARGIN * (top + 1.0)


def main(size: int) -> None:
    hm = terrain(size)
    h = read_only(hm.heights)
    n0, n1 = h.shape
    for az, el in SUNS:
        transpose, da, db, rise = sweep._sweep_geometry(hm, sun_above_horizon(az, el))
        if transpose:
            print(f"sun {az}°/{el}°: swept along columns, not measured here")
            continue
        e = da * db
        fl0, fr0 = sweep._line_offset(np.int64(0), 0, 0, e)
        j_lo, nj = sweep._ray_line_span(n0, n1, e, fl0 + fr0)
        smax, smin, slack = _extrema(h)
        out = np.zeros(h.shape, np.bool_)
        numba.set_num_threads(1)
        totals = {}
        for blocks in (1, 2, 4):
            bounds = sweep._block_bounds(n0, n1, e, j_lo + fl0 + fr0, nj, blocks)
            times = []
            for k in range(blocks):
                best = np.inf
                for _ in range(3):
                    t0 = time.perf_counter()
                    sweep._sweep_block(h, da, db, rise, sweep._NEAR, out, j_lo, bounds[k],
                                       bounds[k + 1] - 1, smax, smin, slack)
                    best = min(best, time.perf_counter() - t0)
                times.append(best * 1e3)
            totals[blocks] = sum(times)
            print(f"sun {az}°/{el}°, one thread, {blocks} block(s): "
                  + " + ".join(f"{t:.1f}" for t in times)
                  + f" = {totals[blocks]:.1f} ms ({totals[blocks] / totals[1]:.3f}× one block)")
        numba.set_num_threads(2)
        for blocks in (2, 4):
            def whole(blocks=blocks, transpose=transpose, da=da, db=db, rise=rise):
                mask = np.zeros(h.shape, np.bool_)
                with numba.parallel_chunksize(1):
                    sweep._line_sweep_kernel(h, da, db, rise, sweep._NEAR, mask, blocks, 0, 0,
                                             transpose, transpose)
            print(f"sun {az}°/{el}°, two threads, whole mask in {blocks} blocks: "
                  f"{_median_ms(whole, 5):.1f} ms")


@numba.njit(parallel=True)
def _extrema_pass(h, smax, smin):
    """The sweep kernel's extrema pass over the map's rows (``_line_sweep_kernel``)."""
    bands = (h.shape[0] + 63) // 64
    magnitude = np.zeros(bands, dtype=np.float64)
    for band in numba.prange(bands):
        for a in range(band * 64, min(h.shape[0], band * 64 + 64)):
            magnitude[band] = max(magnitude[band],
                                  sweep._segment_extrema(h[a], smax[a], smin[a]))
    return magnitude.max()


def other_parts(size: int) -> None:
    h = read_only(terrain(size).heights)
    segments = (h.shape[1] + sweep._SEGMENT - 1) // sweep._SEGMENT
    smax = np.empty((h.shape[0], segments), h.dtype)
    smin = np.empty_like(smax)

    for threads in (1, 2):
        numba.set_num_threads(threads)
        extrema = _median_ms(lambda: _extrema_pass(h, smax, smin), 7)
        touch = _median_ms(lambda: np.zeros(h.shape, np.bool_).fill(True), 7)
        print(f"{threads} thread(s): extrema pass {extrema:.1f} ms, the mask's first touch "
              f"{touch:.1f} ms")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4097)
    other_parts(int(sys.argv[1]) if len(sys.argv) > 1 else 4097)
