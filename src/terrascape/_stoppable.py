"""Long compiled calls that Ctrl-C and SIGTERM stop at once.

Python handles a signal only between two of its own steps: during one compiled (numba)
call of a minute, Ctrl-C waits for the minute. So a long kernel runs on a worker thread
while the calling (main) thread waits for it, which is a Python step that a signal
interrupts. The signal's exception (``KeyboardInterrupt``, or the CLI's ``Interrupted``)
then sets a stop flag that the kernel reads between its steps (an iteration, a row); the
caller waits the few milliseconds the kernel needs to see it, and the exception goes on.
Nothing of the stopped call is returned.

The kernel must release the GIL (``nogil=True``, or ``parallel=True``, whose loops run
without it): one that holds it keeps the waiting thread from running any Python, the
signal's handler included, until it returns.

Waiting on a thread also keeps the signal away from numba's conversion of the kernel's
result into Python objects: an exception raised there became a ``SystemError`` with a
traceback, and could crash the interpreter (a Jupyter kernel dies of it).
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, wait
from typing import Any

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher

_WORKERS: dict[int, _Worker] = {}


def run_stoppable(long: bool, kernel: Callable[..., Any], *args: Any) -> Any:
    """``kernel(*args, stop)``, where ``stop`` is a one-element ``uint8`` flag the kernel
    checks between its steps and ends on when it is set.

    When ``long`` and called from the main thread (the only one that handles signals), the
    kernel runs on a worker thread, with the caller's number of numba threads, while this
    thread waits; an exception while waiting (a signal's) sets the flag, waits for the
    kernel to end and goes on. Otherwise it runs on the calling thread: a short call skips
    the hand-over (about 0.1 ms), and calls from several threads run side by side instead
    of queueing on the one worker.
    """
    stop = np.zeros(1, np.uint8)
    if not long or threading.current_thread() is not threading.main_thread():
        return kernel(*args, stop)
    if isinstance(kernel, Dispatcher):
        options = kernel.targetoptions
        if not (options.get("nogil") or options.get("parallel")):
            raise TypeError(f"{kernel.__name__} holds the GIL: compile it with nogil=True")
        # compiled (or loaded from the cache) here, where a signal stops the compiler at
        # once: on the worker the caller would wait for the whole compilation
        kernel.compile(tuple(numba.typeof(a) for a in (*args, stop)))
    threads = numba.get_num_threads()  # a per-thread setting: the worker takes ours

    def run() -> Any:
        numba.set_num_threads(threads)
        return kernel(*args, stop)

    # made before the hand-over, so that whenever a signal lands the except clause can
    # stop the call: cancelled if the worker has not begun it, waited for if it has
    future: Future = Future()
    try:
        _worker().submit(future, run)
        return future.result()
    except BaseException:
        stop[0] = 1
        if not future.cancel():
            wait([future])
        raise


def for_each_band(work: Callable[[int], None], starts: range, parallel: bool,
                  stop: np.ndarray) -> None:
    """``work(start)`` for each of ``starts`` (the first line of each band of a grid), none
    begun once ``stop[0]`` is set; shared among as many threads as numba's when
    ``parallel``. Give it ``run_stoppable``'s ``stop`` and call it, when parallel, through
    ``run_stoppable``: off the main thread, where no signal can interrupt the start of the
    pool's threads (which would hang the interpreter's exit). Useful where ``work`` spends
    its time in code that releases the GIL (numpy's and scipy's array loops)."""

    def band(start: int) -> None:
        if not stop[0]:
            work(start)

    workers = numba.get_num_threads() if parallel else 1
    if workers > 1 and len(starts) > 1:
        with ThreadPoolExecutor(min(workers, len(starts))) as pool:
            list(pool.map(band, starts))
    else:
        for start in starts:
            band(start)


class _Worker:
    """One daemon thread running the calls handed to it, one at a time, kept for the next.

    Not a ``ThreadPoolExecutor``: a signal during its first ``submit`` interrupted the
    start of its thread before the executor had registered it, and the interpreter then
    waited for that thread at exit, for ever. A daemon thread is not waited for; a stopped
    call has ended before the exception reaches the caller, so none runs at exit.
    """

    def __init__(self) -> None:
        self._calls: queue.SimpleQueue = queue.SimpleQueue()
        threading.Thread(target=self._serve, name="terrascape-long", daemon=True).start()

    def submit(self, future: Future, call: Callable[[], Any]) -> None:
        self._calls.put((future, call))

    def _serve(self) -> None:
        while True:
            future, call = self._calls.get()
            if future.set_running_or_notify_cancel():  # else cancelled before it began
                try:
                    future.set_result(call())
                except BaseException as exc:  # handed to the caller, which re-raises it
                    future.set_exception(exc)
            # dropped before waiting for the next call: the call holds its arguments, and
            # kept here until then they would outlive the caller's use of them (a finished
            # blur's float64 image stayed in memory while the command wrote its output)
            future = call = None


def _worker() -> _Worker:
    """The process's worker (a forked child has the object but not its thread)."""
    worker = _WORKERS.get(os.getpid())
    if worker is None:
        worker = _WORKERS[os.getpid()] = _Worker()
    return worker


__all__ = ["for_each_band", "run_stoppable"]
