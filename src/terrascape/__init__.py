"""terrascape — generate, texture, shade and render terrain in real time, with or without a GPU.

Importing the package is cheap: it loads the error types and nothing heavy. ``Heightmap``
(numpy) and the subpackages are imported when first named (PEP 562 module ``__getattr__``),
so ``terrascape --help`` and a library user who only needs the errors never pay for numpy,
scipy, numba or OpenGL.
"""

from __future__ import annotations

import importlib

from terrascape import _startup

if _startup.running_as_cli():  # before the slow imports: Ctrl-C while starting is one line
    _startup.install()

from terrascape.errors import (
    FileFormatError,
    GLUnavailableError,
    HeightmapSizeError,
    InvalidParameterError,
    OutputExistsError,
    TerrascapeError,
)

# typing costs a fifth of the whole import; type checkers read this constant as theirs.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from terrascape.heightmap import Heightmap

__version__ = "0.1.0"

#: Names the package offers that live in modules imported on first use.
_LAZY = {"Heightmap": "terrascape.heightmap"}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'terrascape' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = [
    "FileFormatError",
    "GLUnavailableError",
    "Heightmap",
    "HeightmapSizeError",
    "InvalidParameterError",
    "OutputExistsError",
    "TerrascapeError",
    "__version__",
]
