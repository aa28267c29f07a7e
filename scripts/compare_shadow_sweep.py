"""Time this checkout's shadow sweep against an earlier commit's, in one process.

    python scripts/compare_shadow_sweep.py REV [SIZE]

Loads ``src/terrascape/lighting/shadows.py`` as it was at REV beside the current module,
checks that both give the same mask bit for bit for each sun, then times them in turns
(5 interleaved rounds; numba's cache off so both compile the same way) and prints the
median times and the median of the per-round ratios. Exit 1 when a mask differs.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
import types
from pathlib import Path

os.environ["TERRASCAPE_NUMBA_CACHE"] = "0"

import numpy as np

import terrascape.lighting.shadows as current
from terrascape.bench.shade import terrain

SUNS = ((105, 10), (60, 10), (300, 10), (30, 5), (105, 20), (135, 20), (0, 20), (250, 45),
        (200, 5), (75, 30), (120, 10))  # (azimuth, elevation) °
ROUNDS = 5


def module_at(rev: str) -> types.ModuleType:
    repo = Path(__file__).resolve().parent.parent
    source = subprocess.check_output(
        ["git", "-C", str(repo), "show", f"{rev}:src/terrascape/lighting/shadows.py"],
        text=True)
    module = types.ModuleType(f"shadows_at_{rev}")
    module.__file__ = f"<shadows.py at {rev}>"
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def main(argv: list[str]) -> int:
    if not 1 <= len(argv) <= 2:
        print("usage: python scripts/compare_shadow_sweep.py REV [SIZE]", file=sys.stderr)
        return 2
    before = module_at(argv[0])
    hm = terrain(int(argv[1]) if len(argv) > 1 else 4097)
    print(f"{hm.shape[0]}², {argv[0]} vs this checkout, {ROUNDS} interleaved rounds")
    for az, el in SUNS:
        if not np.array_equal(current.shadow_mask(hm, az, el), before.shadow_mask(hm, az, el)):
            print(f"sun {az}°/{el}°: the masks differ")
            return 1
        times: dict[str, list[float]] = {"before": [], "now": []}
        for _ in range(ROUNDS):
            for name, module in (("before", before), ("now", current)):
                start = time.perf_counter()
                module.shadow_mask(hm, az, el)
                times[name].append(time.perf_counter() - start)
        ratio = statistics.median(n / b for b, n in zip(times["before"], times["now"],
                                                          strict=True))
        print(f"sun {az:>3}°/{el:<2}°: before {statistics.median(times['before']) * 1e3:6.1f} ms"
              f"  now {statistics.median(times['now']) * 1e3:6.1f} ms  now/before {ratio:.2f}"
              "  masks equal")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
