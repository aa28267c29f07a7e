"""The greedy TIN's first-ever compile: seconds from an empty numba cache, one thread.

    python scripts/greedy_compile_time.py [SRC] [--kernels]

In a fresh interpreter with an empty ``NUMBA_CACHE_DIR`` and ``NUMBA_NUM_THREADS=1``: the
first mesh in pieces of a 600² map (which compiles the pieces, their join and the output),
then the first mesh as one greedy order (what that adds). ``SRC``: another checkout's
``src`` folder (e.g. a ``git worktree`` of an earlier commit), to compare. With
``--kernels``, also each compiled function's own share (numba's compile events, the time of
the functions it compiles on the way subtracted), largest first.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

_CHILD = """
import sys
import time
import numpy as np
from numba.core import event

own = {}

class _Compiles(event.Listener):
    # a compile's own time: its duration less that of the compiles nested in it
    def __init__(self):
        self.open = []

    def on_start(self, ev):
        self.open.append([time.perf_counter(), 0.0])

    def on_end(self, ev):
        start, nested = self.open.pop()
        took = time.perf_counter() - start
        dispatcher = ev.data.get("dispatcher")
        name = dispatcher.py_func.__qualname__ if dispatcher is not None else "?"
        own[name] = own.get(name, 0.0) + took - nested
        if self.open:
            self.open[-1][1] += took

event.register("numba:compile", _Compiles())
from terrascape.heightmap import Heightmap
from terrascape.lod.greedy_tin import greedy_tin
hm = Heightmap(np.random.default_rng(1).standard_normal((600, 600)).cumsum(0).astype(np.float32))
t0 = time.perf_counter()
greedy_tin(hm, max_error=2.0)
t1 = time.perf_counter()
greedy_tin(hm, max_error=2.0, in_pieces=False)
t2 = time.perf_counter()
print(f"first mesh in pieces: {t1 - t0:.1f} s; one greedy order after it: {t2 - t1:.1f} s")
if "--kernels" in sys.argv:
    for name, seconds in sorted(own.items(), key=lambda kv: -kv[1]):
        if seconds >= 0.05:
            print(f"{seconds:7.2f} s  {name}")
"""


def main(src: str | None, kernels: bool) -> None:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1")
        if src:
            env["PYTHONPATH"] = str(Path(src).resolve())
        subprocess.run([sys.executable, "-c", _CHILD, *(["--kernels"] if kernels else [])],
                       env=env, check=True)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--kernels"]
    main(args[0] if args else None, "--kernels" in sys.argv[1:])
