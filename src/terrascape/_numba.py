"""One place for the numba policy: every kernel uses ``@njit(cache=CACHE, fastmath=FASTMATH)``.

Kernels stay in the numpy subset that also runs as plain Python, so ``NUMBA_DISABLE_JIT=1``
is the debugging/coverage fallback; there are no hand-kept pure-numpy duplicates.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from llvmlite import ir
from llvmlite.binding import llvm_version_info
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

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


# LLVM names its intrinsics by their pointer types: typed i8* up to LLVM 16 (numba < 0.61),
# one opaque pointer type from LLVM 17
_PREFETCH_INTRINSIC = ("llvm.prefetch.p0" if llvm_version_info[0] >= 17
                       else "llvm.prefetch.p0i8")


@intrinsic
def prefetch(typingctx, array, index):
    """Ask the CPU to bring ``array[index]`` (a 1-D array) into cache, without waiting for
    it (LLVM's prefetch: a hint, no load, no fault)."""
    sig = types.void(array, index)

    def codegen(context, builder, signature, args):
        array_type, index_type = signature.args
        arr = context.make_array(array_type)(context, builder, args[0])
        i = context.cast(builder, args[1], index_type, types.intp)
        ptr = cgutils.get_item_pointer(context, builder, array_type, arr, [i],
                                       wraparound=False, boundscheck=False)
        ptr = builder.bitcast(ptr, ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32]),
            _PREFETCH_INTRINSIC)
        # read, keep in all cache levels, data cache
        builder.call(fn, [ptr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def stop_requested(typingctx, flag):
    """``flag[0] != 0`` read afresh from memory each time (an atomic load).

    Another thread sets the flag to stop a running kernel
    (:func:`terrascape._stoppable.run_stoppable`). A plain
    read of an array the loop never writes is one LLVM may take out of the loop and make
    once: in a ``prange`` loop it did, and the kernel never saw the flag set.
    """
    sig = types.boolean(flag)

    def codegen(context, builder, signature, args):
        array_type = signature.args[0]
        arr = context.make_array(array_type)(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        ptr = cgutils.get_item_pointer(context, builder, array_type, arr, [zero],
                                       wraparound=False, boundscheck=False)
        value = builder.load_atomic(ptr, "acquire", 1)
        return builder.icmp_unsigned("!=", value, ir.Constant(value.type, 0))

    return sig, codegen


__all__ = ["CACHE", "FASTMATH", "njit", "prange", "prefetch", "read_only", "stop_requested"]
