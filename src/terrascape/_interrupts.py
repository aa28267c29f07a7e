"""Short sections that a signal's exception must not cut in two.

Under the CLI, SIGINT, SIGTERM and SIGHUP raise :class:`~terrascape.errors.Interrupted`
wherever the main thread is. Starting a child process is a step it must not land in:
raised after the fork but before the caller holds the child (inside ``subprocess.Popen``),
it leaves the child running unknown to anyone. ffmpeg, left so, wrote its video after the
command had removed the unfinished one. Inside :func:`interrupts_deferred` the CLI's
handler only records the signal (:func:`defer_interrupt`); the exception is raised when the
section ends. Keep such sections to a few milliseconds: a signal waits for them.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from terrascape.errors import Interrupted

_pending: int | None = None  # the first signal held back
_depth = 0


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold back the CLI's :class:`Interrupted` until the block ends, then raise it (in
    place of any exception the block raised). Only the main thread handles signals; in
    another thread the block runs as it is."""
    global _depth, _pending
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        if _depth == 0 and _pending is not None:
            signum, _pending = _pending, None
            raise Interrupted(signum)


def defer_interrupt(signum: int) -> bool:
    """For the CLI's signal handler: True when a deferred section is open, the signal then
    recorded for its end."""
    global _pending
    if _depth > 0:
        if _pending is None:
            _pending = signum
        return True
    return False
