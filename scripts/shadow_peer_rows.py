"""The shadow rows of ``terrascape bench peers`` for a few suns only, in a fresh process.

    python scripts/shadow_peer_rows.py [ROUNDS]

The bench's own row function (interleaved rounds, ``ROUNDS`` of them, default 7) for the
two 5° suns and one 20° sun: the two-thread speed-up and the time against insolation's,
without the rest of the bench around them. Written to tell a low-sun miss of the 1.8×
speed-up target in one whole-bench run from the spread of the shared cores.
"""

from __future__ import annotations

import sys

import terrascape.bench.peers as peers
from terrascape.bench import BenchTable


def main(rounds: int) -> None:
    peers.SHADOW_CASES = ((5.0, 30.0), (5.0, 200.0), (20.0, 135.0))
    table = BenchTable("shadow rows", ["size", "az °", "el °", "ours s", "insolation s",
                                       "ours/peer", "spread", "1 thread ÷ all",
                                       "ours = ray walk %", "peer = ray walk %"])
    peers._shadow_rows(4097, rounds, table)
    for row in table.rows:
        print(f"sun {row[1]:g}°/{row[2]:g}°: two threads {row[7]:.3f}× one, "
              f"ours ÷ insolation {row[5]:.3f}", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
