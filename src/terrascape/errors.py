"""Typed exceptions. Every error a user can cause is a :class:`TerrascapeError`.

The CLI turns any of them into one red line on stderr, never a traceback. The exit code is
:attr:`TerrascapeError.exit_code`: 2 for a usage error (a bad parameter or input file, an
output that exists), 1 for an environment failure (:class:`EnvironmentFailure`: the disk is
full or read-only, permission denied, not enough memory). A signal ends the CLI with
``128 + signal number`` (130 for Ctrl-C, 143 for SIGTERM) and the line "nothing was written".
"""

from __future__ import annotations


class TerrascapeError(Exception):
    """Base class of every error terrascape raises on purpose."""

    #: Exit code of the CLI for this error: 2 = usage (fix the command line or the input).
    exit_code: int = 2


class InvalidParameterError(TerrascapeError, ValueError):
    """A parameter is out of range, NaN, or inconsistent with another one."""


class HeightmapSizeError(InvalidParameterError):
    """A heightmap has a size the algorithm cannot take (e.g. not 2**n + 1)."""


class FileFormatError(TerrascapeError, ValueError):
    """A file is missing, truncated, corrupt, or of an unknown/unsupported format."""


class OutputExistsError(TerrascapeError, FileExistsError):
    """An output path exists and overwriting was not asked for (``force=True`` / ``--force``)."""


class GLUnavailableError(TerrascapeError, RuntimeError):
    """No usable OpenGL >= 3.3 context could be created, or a needed GL feature is missing."""


class EnvironmentFailure(TerrascapeError):
    """The command was valid but the machine could not carry it out (exit code 1)."""

    exit_code = 1


class OutputWriteError(EnvironmentFailure, OSError):
    """An output could not be written: disk full, read-only file system, permission denied,
    a parent that is a file, a name too long. Nothing was written (the old file, if any, is
    unchanged)."""

    def __init__(self, message: str, errno: int | None = None) -> None:
        super().__init__(message)  # one argument: str() is the message, not "[Errno n] …"
        if errno is not None:
            self.errno = errno


class MemoryLimitError(EnvironmentFailure, MemoryError):
    """The estimated peak memory of an operation exceeds the limit (``--max-memory``), or an
    allocation failed. Raised before the work starts whenever the peak can be estimated."""


class Interrupted(BaseException):
    """A termination signal (SIGINT, SIGTERM, SIGHUP) arrived while the CLI was running.

    Derived from :class:`BaseException` (like :class:`KeyboardInterrupt`) so that no
    ``except Exception`` swallows it; every ``finally`` on the way out runs, which removes
    the temporary files of unfinished outputs.
    """

    def __init__(self, signum: int) -> None:
        import signal

        self.signum = int(signum)
        try:
            self.signal_name = signal.Signals(self.signum).name
        except ValueError:
            self.signal_name = f"signal {self.signum}"
        super().__init__(self.signal_name)

    @property
    def exit_code(self) -> int:
        """``128 + signal number``, the shell's convention (130 = SIGINT, 143 = SIGTERM)."""
        return 128 + self.signum
