"""The shadow rows of ``terrascape bench peers`` for a few suns only, in a fresh process,
beside the speed-up two threads give loops with nothing to share on the same host.

    python scripts/shadow_peer_rows.py [ROUNDS]

The bench's own row function (interleaved rounds, ``ROUNDS`` of them, default 7) for the
two 5° suns and one 20° sun: the two-thread speed-up and the time against insolation's,
without the rest of the bench around them. Written to tell a low-sun miss of the 1.8×
speed-up target in one whole-bench run from the spread of the shared cores.

Then the same paired reading (one thread ÷ two, ``ROUNDS`` rounds) of two loops whose
iterations share nothing: one of arithmetic alone, and one that streams a 4097² map into
a mask as the sweep does. What they reach is what two threads can give on these cores at
that moment: a ceiling for the sweep's speed-up.
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit, prange

import terrascape.bench.peers as peers
from terrascape.bench import BenchTable


@njit(parallel=True, fastmath=True, cache=True)
def _arithmetic(out, n):
    for i in prange(out.shape[0]):
        s = 0.0
        for k in range(n):
            s += np.sin(i * 1e-3 + k * 1e-4)
        out[i] = s


@njit(parallel=True, cache=True)
def _streaming(heights, mask):
    for i in prange(heights.shape[0]):
        for j in range(heights.shape[1]):
            mask[i, j] = heights[i, j] > 0.5


def main(rounds: int) -> None:
    peers.SHADOW_CASES = ((5.0, 30.0), (5.0, 200.0), (20.0, 135.0))
    table = BenchTable("shadow rows", ["size", "az °", "el °", "ours s", "insolation s",
                                       "ours/peer", "spread", "1 thread ÷ all",
                                       "ours = ray walk %", "peer = ray walk %"])
    peers._shadow_rows(4097, rounds, table)
    for row in table.rows:
        print(f"sun {row[1]:g}°/{row[2]:g}°: two threads {row[7]:.3f}× one, "
              f"ours ÷ insolation {row[5]:.3f}", flush=True)
    sums = np.empty(4096)
    heights = np.random.default_rng(0).random((4097, 4097), dtype=np.float32)
    mask = np.empty(heights.shape, np.bool_)
    threads = peers.numba.get_num_threads()
    for name, job in (("arithmetic alone", lambda: _arithmetic(sums, 2000)),
                      ("streaming a 4097² map into a mask", lambda: _streaming(heights, mask))):
        scale, lo, hi, _, _ = peers.paired_ratio(peers._with_threads(1, job),
                                                 peers._with_threads(threads, job), rounds)
        print(f"a loop sharing nothing, {name}: two threads {scale:.3f}× one "
              f"({lo:.2f}–{hi:.2f})", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
