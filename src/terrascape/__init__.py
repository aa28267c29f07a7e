"""terrascape — generate, texture, shade and render terrain in real time, with or without a GPU."""

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
from terrascape.heightmap import Heightmap

__version__ = "0.1.0"

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
