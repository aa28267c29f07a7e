"""One place for the numba policy: every kernel uses ``@njit(cache=CACHE, fastmath=FASTMATH)``.

Kernels stay in the numpy subset that also runs as plain Python, so ``NUMBA_DISABLE_JIT=1``
is the debugging/coverage fallback; there are no hand-kept pure-numpy duplicates.
"""

from __future__ import annotations

import os

from numba import njit, prange

# Caching to __pycache__ keeps the second start of the CLI fast; it can be switched off where
# the package directory is read-only.
CACHE: bool = os.environ.get("TERRASCAPE_NUMBA_CACHE", "1") != "0"
# fastmath is off by default: determinism (same seed -> same bytes) matters more than the
# last few percent, and NaN checks must keep working.
FASTMATH: bool = False

__all__ = ["CACHE", "FASTMATH", "njit", "prange"]
