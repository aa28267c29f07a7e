"""Size and encoding time of 16-bit height PNGs at zlib compression levels 3, 4 and 6.

    python scripts/png_compress_levels.py [SIZE]

For the Jacksboro DEM (344×403) and SIZE² (default 2049) hills, fBm and diamond-square maps
from their generators (seed 1), quantised to 16 bits as ``write_png16`` does: the bytes of
the PNG and the median of 3 encodings (Pillow, in memory) at each level, and the ratios of
each level to level 6, Pillow's default.
"""

from __future__ import annotations

import io
import statistics
import sys
import time

import numpy as np
from PIL import Image

from terrascape.bench.peers import real_dem
from terrascape.generate.diamond_square import diamond_square
from terrascape.generate.fault import fault_formation
from terrascape.generate.hills import hills
from terrascape.generate.noise import fbm
from terrascape.io._common import quantise

LEVELS = (3, 4, 6)


def encode(image: Image.Image, level: int) -> tuple[int, float]:
    times = []
    for _ in range(3):
        buf = io.BytesIO()
        start = time.perf_counter()
        image.save(buf, format="PNG", compress_level=level)
        times.append(time.perf_counter() - start)
    return len(buf.getvalue()), statistics.median(times)


def main() -> None:
    size = int(sys.argv[1]) if len(sys.argv) > 1 else 2049
    maps = {"Jacksboro DEM": real_dem(), f"hills {size}²": hills(size, seed=1),
            f"fBm {size}²": fbm(size, seed=1),
            f"diamond-square {size}²": diamond_square(size, seed=1),
            f"fault {size}²": fault_formation(size, seed=1)}
    print("| map | " + " | ".join(f"level {lv} bytes | level {lv} s" for lv in LEVELS) + " | "
          + " | ".join(f"size {lv} ÷ 6 | time {lv} ÷ 6" for lv in LEVELS[:-1]) + " |")
    print("|---" * (4 * len(LEVELS) - 1) + "|")
    for name, hm in maps.items():
        codes, _, _ = quantise(hm.heights, 65535)
        image = Image.fromarray(np.ascontiguousarray(codes))
        results = [encode(image, level) for level in LEVELS]
        cells = " | ".join(f"{n:,} | {t:.3f}" for n, t in results)
        n6, t6 = results[-1]
        ratios = " | ".join(f"{n / n6:.3f} | {t / t6:.2f}" for n, t in results[:-1])
        print(f"| {name} | {cells} | {ratios} |", flush=True)


if __name__ == "__main__":
    main()
