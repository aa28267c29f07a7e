"""Parsers for CLI values such as ``1280x720`` and ``X,Y,Z``; errors are usage errors."""

from __future__ import annotations

import math
import os
from pathlib import Path

from terrascape.errors import InvalidParameterError


def parse_size(text: str, *, name: str = "size") -> tuple[int, int]:
    """``"1280x720"`` → ``(1280, 720)``; both positive."""
    parts = text.lower().replace("×", "x").split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise InvalidParameterError(f"{name} must look like 1280x720, got {text!r}") from None
    if w <= 0 or h <= 0:
        raise InvalidParameterError(f"{name} must be positive, got {text!r}")
    return w, h


def parse_floats(text: str, count: int, *, name: str) -> tuple[float, ...]:
    """``"1,2,3"`` → ``(1.0, 2.0, 3.0)``; exactly ``count`` finite numbers."""
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        raise InvalidParameterError(
            f"{name} must be {count} comma-separated numbers, got {text!r}"
        ) from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise InvalidParameterError(
            f"{name} must be {count} comma-separated finite numbers, got {text!r}"
        )
    return values


def is_world_store(path: str | os.PathLike | None) -> bool:
    """Whether a command's map argument is a world store (``world.zarr``) rather than a file.

    A folder holding ``zarr.json`` is looked at by the world module, which needs the
    ``world`` extra (zarr, dask); anything else is decided here, so rendering, viewing or
    exporting a plain heightmap never needs that extra.
    """
    if path is None:
        return False
    p = Path(path)
    if not (p.is_dir() and (p / "zarr.json").is_file()):
        return False
    from terrascape.world.store import is_world

    return is_world(p)
