"""Long compiled calls that Ctrl-C and SIGTERM stop at once.

Python handles a signal only between two of its own steps: during one compiled (numba)
call of a minute, Ctrl-C waits for the minute. So a long kernel runs on a pool thread while
the calling (main) thread waits for it, which is a Python step that a signal interrupts. The
signal's exception (``KeyboardInterrupt``, or the CLI's ``Interrupted``) then sets a stop
flag that the kernel reads between its steps (an iteration, a row); the caller waits the
few milliseconds the kernel needs to see it, and the exception goes on. Nothing of the
stopped call is returned.

Waiting on a thread also keeps the signal away from numba's conversion of the kernel's
result into Python objects: an exception raised there became a ``SystemError`` with a
traceback, and could crash the interpreter (a Jupyter kernel dies of it).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Any

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher

_POOLS: dict[int, ThreadPoolExecutor] = {}


def run_stoppable(long: bool, kernel: Callable[..., Any], *args: Any) -> Any:
    """``kernel(*args, stop)``, where ``stop`` is a one-element ``uint8`` flag the kernel
    checks between its steps and ends on when it is set.

    When ``long`` and called from the main thread (the only one that handles signals), the
    kernel runs on a pool thread, with the caller's number of numba threads, while this
    thread waits; an exception while waiting (a signal's) sets the flag, waits for the
    kernel to end and goes on. Otherwise it runs on the calling thread: a short call skips
    the hand-over (about 0.1 ms), and calls from several threads run side by side instead
    of queueing on the one pool thread.
    """
    stop = np.zeros(1, np.uint8)
    if not long or threading.current_thread() is not threading.main_thread():
        return kernel(*args, stop)
    if isinstance(kernel, Dispatcher):
        # compiled (or loaded from the cache) here, where a signal stops the compiler at
        # once: on the pool thread the caller would wait for the whole compilation
        kernel.compile(tuple(numba.typeof(a) for a in (*args, stop)))
    threads = numba.get_num_threads()  # a per-thread setting: the pool thread takes ours

    def run() -> Any:
        numba.set_num_threads(threads)
        return kernel(*args, stop)

    future = _pool().submit(run)
    try:
        return future.result()
    except BaseException:
        stop[0] = 1
        wait([future])
        raise


def _pool() -> ThreadPoolExecutor:
    """One thread, kept for the next call; one per process (a forked child has the pool
    but not its thread)."""
    pool = _POOLS.get(os.getpid())
    if pool is None:
        pool = _POOLS[os.getpid()] = ThreadPoolExecutor(1, thread_name_prefix="terrascape-long")
    return pool


__all__ = ["run_stoppable"]
