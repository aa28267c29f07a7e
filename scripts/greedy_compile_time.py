"""The greedy TIN's first-ever compile: seconds from an empty numba cache, one thread.

    python scripts/greedy_compile_time.py [SRC]

In a fresh interpreter with an empty ``NUMBA_CACHE_DIR`` and ``NUMBA_NUM_THREADS=1``: the
first mesh in pieces of a 600² map (which compiles the pieces, their join and the output),
then the first mesh as one greedy order (what that adds). ``SRC``: another checkout's
``src`` folder (e.g. a ``git worktree`` of an earlier commit), to compare.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

_CHILD = """
import time
import numpy as np
from terrascape.heightmap import Heightmap
from terrascape.lod.greedy_tin import greedy_tin
hm = Heightmap(np.random.default_rng(1).standard_normal((600, 600)).cumsum(0).astype(np.float32))
t0 = time.perf_counter()
greedy_tin(hm, max_error=2.0)
t1 = time.perf_counter()
greedy_tin(hm, max_error=2.0, in_pieces=False)
t2 = time.perf_counter()
print(f"first mesh in pieces: {t1 - t0:.1f} s; one greedy order after it: {t2 - t1:.1f} s")
"""


def main(src: str | None) -> None:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1")
        if src:
            env["PYTHONPATH"] = str(Path(src).resolve())
        subprocess.run([sys.executable, "-c", _CHILD], env=env, check=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
