"""Peak memory of the greedy TIN itself, per triangle of its mesh.

    python scripts/greedy_tin_peak_memory.py [SIZE] [ERROR]

In a fresh interpreter: an fBm map of SIZE² (default 4097, seed 2) meshed by
:func:`terrascape.lod.greedy_tin.greedy_tin` within ERROR (default 0: every sample a
vertex); prints the process's peak resident memory before and after (``ru_maxrss``), the
triangles, and the difference per triangle. The model of ``terrascape.memory``
(``PEAK_BYTES_PER_TRIANGLE["greedy join"]``) is this figure rounded up.
"""

from __future__ import annotations

import subprocess
import sys

_CHILD = """
import resource, sys
from terrascape.generate.registry import generate
from terrascape.lod.greedy_tin import greedy_tin
size, error = int(sys.argv[1]), float(sys.argv[2])
hm = generate("fbm", size, seed=2)
greedy_tin(generate("fbm", 65, seed=2), max_error=error)  # compiled or loaded first
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tris = greedy_tin(hm, max_error=error)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(f"{size}² at error {error:g}: {len(tris):,} triangles; peak {before / 1024:.0f} MiB "
      f"before, {after / 1024:.0f} MiB after: {(after - before) * 1024 / len(tris):.1f} B "
      "per triangle")
"""


def main(argv: list[str]) -> None:
    size = argv[0] if argv else "4097"
    error = argv[1] if len(argv) > 1 else "0"
    subprocess.run([sys.executable, "-c", _CHILD, size, error], check=True)


if __name__ == "__main__":
    main(sys.argv[1:])
