"""Typed exceptions. Every error a user can cause is a :class:`TerrascapeError`.

The CLI turns any of them into one red line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations


class TerrascapeError(Exception):
    """Base class of every error terrascape raises on purpose."""


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
