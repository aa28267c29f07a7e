"""Peak memory of the greedy TIN itself, per triangle of its mesh.

    python scripts/greedy_tin_peak_memory.py [SIZE] [ERROR] [--one-order]

In a fresh interpreter: an fBm map of SIZE² (default 4097, seed 2) meshed by
:func:`terrascape.lod.greedy_tin.greedy_tin` within ERROR (default 0: every sample a
vertex); prints the process's peak resident memory before and after (``ru_maxrss``), the
triangles, and the difference per triangle. The model of ``terrascape.memory``
(``PEAK_BYTES_PER_TRIANGLE["greedy join"]``) is this figure rounded up.

With ``--one-order``, one greedy order over the whole map (``in_pieces=False``): the
difference is also given per slot of the insertion's arrays (``_START_SLOTS`` doubled until
they held the mesh; at error 0 every sample is a vertex and almost none is removed
afterwards, so the mesh's triangles are about the most the insertion held), for
``PEAK_BYTES_PER_TRIANGLE["greedy one order"]``.
"""

from __future__ import annotations

import subprocess
import sys

_CHILD = """
import resource, sys
from terrascape.generate.registry import generate
from terrascape.lod.greedy_tin import _START_SLOTS, greedy_tin
size, error, pieces = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == "pieces"
hm = generate("fbm", size, seed=2)
greedy_tin(generate("fbm", 65, seed=2), max_error=error, in_pieces=pieces)  # compiled first
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tris = greedy_tin(hm, max_error=error, in_pieces=pieces)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
grown = (after - before) * 1024
line = (f"{size}² at error {error:g}{'' if pieces else ', one order'}: {len(tris):,} "
        f"triangles; peak {before / 1024:.0f} MiB before, {after / 1024:.0f} MiB after: "
        f"{grown / len(tris):.1f} B per triangle")
if not pieces:
    slots = _START_SLOTS
    while slots < len(tris):
        slots *= 2
    line += f", {grown / slots:.1f} B per slot of {slots:,}"
print(line)
"""


def main(argv: list[str]) -> None:
    one_order = "--one-order" in argv
    argv = [a for a in argv if a != "--one-order"]
    size = argv[0] if argv else "4097"
    error = argv[1] if len(argv) > 1 else "0"
    subprocess.run([sys.executable, "-c", _CHILD, size, error,
                    "one-order" if one_order else "pieces"], check=True)


if __name__ == "__main__":
    main(sys.argv[1:])
