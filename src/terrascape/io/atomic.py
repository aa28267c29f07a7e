"""Atomic file output: write to a temporary file in the same folder, then rename.

A failure at any point leaves no partial file and never touches an existing one.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from terrascape.errors import FileFormatError, OutputExistsError


def check_output_path(path: str | os.PathLike, *, force: bool = False) -> Path:
    """Refuse to overwrite without ``force``; refuse a missing parent folder."""
    p = Path(path)
    if p.exists() and not force:
        raise OutputExistsError(f"{p} exists; pass force=True (CLI: --force) to overwrite it")
    if p.is_dir():
        raise OutputExistsError(f"{p} is a directory, expected a file path")
    if not p.parent.exists():
        raise FileFormatError(f"output folder {p.parent} does not exist")
    return p


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it over ``path``.

    The temporary name keeps the final suffix, so writers that pick a format by extension
    (Pillow, tifffile) behave the same.
    """
    final = check_output_path(path, force=force)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{final.stem}.", suffix=f".part{final.suffix}", dir=final.parent
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        if not tmp.exists() or tmp.stat().st_size == 0:
            raise FileFormatError(f"writing {final} produced no data")
        # mkstemp creates 0600 files; give the result the permissions a plain open() would.
        os.chmod(tmp, 0o666 & ~_current_umask())
        os.replace(tmp, final)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
