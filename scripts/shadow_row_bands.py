"""Would the shadow sweep along the map's rows gain from copying them a band at a time, as
the sweep along its columns does?

    python scripts/shadow_row_bands.py [SIZE] [ROUNDS]

Builds a variant of ``terrascape.lighting.shadows`` in a temporary folder: every block fills
a ring of rows with its part of the next 64 grid lines (a copy of each line's samples the
block reads, as :func:`_fill_lines` does for the columns) and sweeps the ring, instead of
reading the map's rows in place with prefetch hints. Checks that both give the same mask,
then times both on one and two threads, interleaved (``ROUNDS`` rounds, default 25), at the
four row suns of ``terrascape bench peers``: medians, the two-thread speed-up of each, and
the median of the within-round ratios variant ÷ present on two threads.
"""

from __future__ import annotations

import importlib.util
import pathlib
import sys
import tempfile
import time

import numba
import numpy as np

import terrascape.lighting.shadows as present
from terrascape.bench.shade import terrain
from terrascape.lighting.sun import sun_direction

ROW_SUNS = ((5.0, 30.0), (5.0, 200.0), (20.0, 135.0), (20.0, 0.0))

# The block of _sweep_block from its "if h_transposed:" to the end of the else branch
# (the second call ending "band, band_lines)") becomes one call for both orientations.
ONE_CALL = """    lines = np.empty((_BAND + near, n1), dtype=h.dtype)
    ranges = np.empty((_BAND, 3), dtype=np.int64)
    _sweep_lines(h, lines, lines, _BAND + near, ranges, da, db, rise, near, out, j_lo,
                 lo, hi, smax, smin, slack, a_org, b_org, out_transposed, sl, ring,
                 near_hit, by_runs, all_runs, skipped, band, band_lines, h_transposed)"""

# (present text, variant text): the ring for row sweeps too, filled by _fill_rows
EDITS = (
    ("                 by_runs, all_runs, skipped, band, band_lines):",
     "                 by_runs, all_runs, skipped, band, band_lines, h_transposed):"),
    ("""    n0, n1 = (h.shape[1], h.shape[0]) if ring_rows else (h.shape[0], h.shape[1])
    e = da * db""",
     """    n0, n1 = (h.shape[1], h.shape[0]) if h_transposed else (h.shape[0], h.shape[1])
    e = da * db"""),
    ("""        if ring_rows and t % _BAND == 0:
            _fill_lines(h, lines, t, min(_BAND, n0 - t), a, da, lo, hi, j_lo, a_org, b_org,
                        e, near + 4, ranges)""",
     """        if ring_rows and t % _BAND == 0:
            if h_transposed:
                _fill_lines(h, lines, t, min(_BAND, n0 - t), a, da, lo, hi, j_lo, a_org,
                            b_org, e, near + 4, ranges)
            else:
                _fill_rows(h, lines, t, min(_BAND, n0 - t), a, da, lo, hi, j_lo, a_org,
                           b_org, e, near + 4)"""),
    ("""@njit(cache=CACHE, _nrt=False, inline="always")
def _fill_sample(""",
     """@njit(cache=CACHE, _nrt=False)
def _fill_rows(h, lines, t0, count, a0, da, lo, hi, j_lo, a_org, b_org, e, margin):
    n1 = h.shape[1]
    rows = lines.shape[0]
    for i in range(count):
        a = a0 - i * da
        b0, b1 = _block_span(a, lo, hi, j_lo, a_org, b_org, e, n1, margin)
        if b0 <= b1:
            dst = lines[(t0 + i) % rows, b0:b1 + 1]
            src = h[a, b0:b1 + 1]
            for k in range(b1 - b0 + 1):
                dst[k] = src[k]


@njit(cache=CACHE, _nrt=False, inline="always")
def _fill_sample("""),
    ("cache=CACHE", "cache=False"),
)


def _variant(folder: pathlib.Path):
    text = pathlib.Path(present.__file__).read_text()
    begin = text.index("    if h_transposed:\n        # the band being swept")
    finish = text.index("band, band_lines)", text.index("    else:\n", begin))
    text = text[:begin] + ONE_CALL + text[finish + len("band, band_lines)"):]
    for old, new in EDITS:
        if old not in text:
            sys.exit("the sweep changed since this script was written: update its EDITS")
        text = text.replace(old, new)
    path = folder / "shadows_row_bands.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("shadows_row_bands", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _time(module, hm, light, threads: int) -> float:
    numba.set_num_threads(threads)
    start = time.perf_counter()
    module._fast_mask_for_light(hm, light)
    return time.perf_counter() - start


def main(size: int, rounds: int) -> None:
    hm = terrain(size)
    threads = numba.get_num_threads()
    with tempfile.TemporaryDirectory() as folder:
        variant = _variant(pathlib.Path(folder))
        for el, az in ROW_SUNS:
            light = sun_direction(az, el)
            same = np.array_equal(present._fast_mask_for_light(hm, light),
                                  variant._fast_mask_for_light(hm, light))
            times = {key: [] for key in ("p1", "p2", "v1", "v2")}
            for _ in range(rounds):
                for key, module, n in (("p1", present, 1), ("p2", present, threads),
                                       ("v1", variant, 1), ("v2", variant, threads)):
                    times[key].append(_time(module, hm, light, n))
            t = {key: np.array(v) for key, v in times.items()}
            print(f"sun {az:g}°/{el:g}°: same mask {same}; present {np.median(t['p1']) * 1e3:.0f}"
                  f" / {np.median(t['p2']) * 1e3:.0f} ms on 1 / {threads} threads "
                  f"({np.median(t['p1'] / t['p2']):.2f}×), row bands "
                  f"{np.median(t['v1']) * 1e3:.0f} / {np.median(t['v2']) * 1e3:.0f} ms "
                  f"({np.median(t['v1'] / t['v2']):.2f}×); row bands ÷ present on "
                  f"{threads} threads {np.median(t['v2'] / t['p2']):.3f}", flush=True)
    numba.set_num_threads(threads)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4097,
         int(sys.argv[2]) if len(sys.argv) > 2 else 25)
