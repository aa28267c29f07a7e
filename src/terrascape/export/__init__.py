"""Exporters for GIS, game engines and the web: one module per destination.

Every destination module defines ``NAME`` (the ``terrascape export NAME`` word), ``SUMMARY``
(one line of help) and ``export(heightmap, out_dir, options) -> list[Path]`` (the files
written, among them a ``Name_import.txt`` with the exact import settings). Destinations are
discovered by module name, so adding one edits no shared list. :mod:`glb` and :mod:`meshing`
are the shared textured-glTF writer and rectangular RTIN mesher.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

from terrascape.errors import InvalidParameterError
from terrascape.export._common import ExportOptions

__all__ = ["ExportOptions", "destinations", "get_destination"]

_NOT_DESTINATIONS = {"glb", "meshing", "instances"}


def destinations() -> list[str]:
    """Names of the export destinations shipped in this package."""
    names = []
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_") or info.name in _NOT_DESTINATIONS or info.ispkg:
            continue
        names.append(info.name)
    return sorted(names)


def get_destination(name: str) -> ModuleType:
    """The module of destination ``name``."""
    if name not in destinations():
        raise InvalidParameterError(
            f"unknown export destination {name!r}; available: {', '.join(destinations())}"
        )
    return importlib.import_module(f"{__name__}.{name}")
