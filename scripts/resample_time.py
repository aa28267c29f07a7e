"""Time ``resample_cubic`` against one ``scipy.ndimage.zoom`` call on the same map.

    python scripts/resample_time.py [SIDE [FACTOR [ROUNDS]]]

An fBm map of SIDE² samples (default 4097, seed 3) is resampled to ``FACTOR·(SIDE - 1) + 1``
samples a side (default factor 2), alternating the two ``ROUNDS`` times (default 3). Prints
each time, the medians, the shapes each returns and the largest difference over the rows
and columns both have (zoom's grid is stretched when its rounded size is not the one asked
for).
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np
from scipy import ndimage

from terrascape.filters.resample import resample_cubic
from terrascape.generate import fbm


def main() -> None:
    side = int(sys.argv[1]) if len(sys.argv) > 1 else 4097
    factor = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    heights = fbm(side, seed=3).heights
    target = round(factor * (side - 1)) + 1
    zoom = (target - 1) / (side - 1)
    resample_cubic(heights[:20, :20], (30, 30))  # thread pools and imports warmed up
    ours, scipy_s = [], []
    for _ in range(rounds):
        start = time.perf_counter()
        banded = resample_cubic(heights, (target, target))
        ours.append(time.perf_counter() - start)
        start = time.perf_counter()
        zoomed = ndimage.zoom(heights.astype(np.float64), zoom, order=3, mode="nearest",
                              grid_mode=False)
        scipy_s.append(time.perf_counter() - start)
        print(f"resample_cubic {ours[-1]:.2f} s, ndimage.zoom {scipy_s[-1]:.2f} s", flush=True)
    n = min(banded.shape[0], zoomed.shape[0])
    diff = float(np.abs(banded[:n, :n] - zoomed[:n, :n]).max())
    print(f"{side}² -> {target}²: resample_cubic median {statistics.median(ours):.2f} s "
          f"{banded.shape}, ndimage.zoom median {statistics.median(scipy_s):.2f} s "
          f"{zoomed.shape}; largest difference {diff:.3g} (heights 0 … "
          f"{float(heights.max()):.4g})")


if __name__ == "__main__":
    main()
