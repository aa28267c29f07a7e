"""One place for the numba policy: every kernel uses ``@njit(cache=CACHE, fastmath=FASTMATH)``.

Kernels stay in the numpy subset that also runs as plain Python, so ``NUMBA_DISABLE_JIT=1``
is the debugging/coverage fallback; there are no hand-kept pure-numpy duplicates.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from numba import njit, prange

if TYPE_CHECKING:
    import numpy as np

# Caching to __pycache__ keeps the second start of the CLI fast; it can be switched off where
# the package directory is read-only.
CACHE: bool = os.environ.get("TERRASCAPE_NUMBA_CACHE", "1") != "0"
# fastmath is off by default: determinism (same seed -> same bytes) matters more than the
# last few percent, and NaN checks must keep working.
FASTMATH: bool = False



def read_only(a: np.ndarray) -> np.ndarray:
    """``a`` as a read-only array (a view when it is writable; no copy).

    numba compiles a kernel separately for read-only and writable arrays: heightmap heights
    are read-only, an array a caller hands in (or a copy made on the way) may not be, so
    kernels that take both would compile twice. Handing them read-only arrays only keeps
    one compile each.
    """
    if not a.flags.writeable:
        return a
    view = a.view()
    view.flags.writeable = False
    return view


__all__ = ["CACHE", "FASTMATH", "njit", "prange", "read_only"]
