"""How long a relief cone map takes, on the natural and city fields of ``terrascape relief``.

    python scripts/cone_map_time.py [--rounds N] [--compile] [--preparation] SIZE [SIZE ...]

For each size and field: the median time of ``footprint_cone_map`` (the cone map the
renderer builds) over ``N`` builds (default 3) after a warm-up on a small texture, and a
hash of its bytes, so that two versions of the code can be compared (run once with
``PYTHONPATH`` set to the other version's ``src``). With ``--compile``, first the time of
a first ``footprint_cone_map`` and then of a first ``cone_map`` in a new process with an
empty numba cache (what a new installation pays once). With ``--preparation``, also the
median time of the footprint's cell minima on the natural field, as the minimum of a
stack of the four corners (the code before 2026-12-07) and as it is made now.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from terrascape.relief.cone_map import footprint_cone_map
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.minmax_mip import corner_depths
from terrascape.relief.reference import heights_to_depth

_FIRST_CALLS = """
import time
import numpy as np
from terrascape.relief.cone_map import cone_map, footprint_cone_map
h = np.random.default_rng(3).random((16, 16))
t0 = time.perf_counter()
footprint_cone_map(h)
t1 = time.perf_counter()
cone_map(h)
t2 = time.perf_counter()
print(f"compile: first footprint_cone_map {t1 - t0:.1f} s, then first cone_map {t2 - t1:.1f} s")
"""


def first_calls() -> None:
    with tempfile.TemporaryDirectory() as cache:
        subprocess.run([sys.executable, "-c", _FIRST_CALLS], check=True,
                       env={**os.environ, "NUMBA_CACHE_DIR": cache})


def preparation(n: int, rounds: int) -> None:
    depth = heights_to_depth(natural_field(n))

    def stacked():
        return corner_depths(depth).min(axis=-1)

    def pairs():  # as footprint_cone_map makes them
        pair_min = np.minimum(depth, np.roll(depth, -1, axis=1))
        return np.minimum(pair_min, np.roll(pair_min, -1, axis=0))

    for name, make in (("stack of four corners", stacked), ("pairs of neighbours", pairs)):
        times = []
        for _ in range(rounds):
            t0 = time.perf_counter()
            cells = make()
            times.append(time.perf_counter() - t0)
        digest = hashlib.sha1(cells.tobytes()).hexdigest()[:12]
        print(f"{n}² natural, cell minima by {name}: {statistics.median(times):.3f} s, "
              f"minima {digest}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", type=int, nargs="+")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--compile", action="store_true")
    parser.add_argument("--preparation", action="store_true")
    args = parser.parse_args()
    if args.compile:
        first_calls()
    if args.preparation:
        for n in args.sizes:
            preparation(n, args.rounds)
    footprint_cone_map(natural_field(32))  # compiled (or loaded from the cache) first
    for n in args.sizes:
        fields = {"natural": natural_field(n),
                  "city": city_field(n, block=max(8, n // 8), street=max(2, n // 40), seed=1)}
        for name, heights in fields.items():
            times = []
            for _ in range(args.rounds):
                t0 = time.perf_counter()
                cones = footprint_cone_map(heights)
                times.append(time.perf_counter() - t0)
            digest = hashlib.sha1(cones.tobytes()).hexdigest()[:12]
            print(f"{n}² {name}: {statistics.median(times):.3f} s "
                  f"({min(times):.3f}–{max(times):.3f}), cones {digest}", flush=True)


if __name__ == "__main__":
    main()
