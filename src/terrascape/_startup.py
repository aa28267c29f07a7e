"""Signals while the CLI starts: one line and exit 128 + N, never an import traceback.

Importing numpy, scipy, typer and rich takes most of a second; a Ctrl-C in that time would
print a ``KeyboardInterrupt`` traceback from deep inside an import. Nothing can have been
written yet, so the handler installed here just says so and leaves. ``run_app`` replaces it
with the handler that unwinds (and removes temporary files) once commands run.
"""

from __future__ import annotations

import os
import sys


def _exit_during_startup(signum: int, _frame: object) -> None:
    import signal

    name = signal.Signals(signum).name
    os.write(2, f"interrupted ({name}) while starting; nothing was written\n".encode())
    os._exit(128 + signum)


def running_as_cli() -> bool:
    """True when this process is the ``terrascape`` console script (not a library user)."""
    return os.path.basename(sys.argv[0] if sys.argv else "") == "terrascape"


def install() -> None:
    """Install the startup handlers for SIGINT, SIGTERM and SIGHUP (main thread only)."""
    import signal  # here, not at the top: a library user's import does not pay for it

    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None:
            try:
                signal.signal(sig, _exit_during_startup)
            except (ValueError, OSError):  # not the main thread
                return
