"""Package faces that import their modules on first use (PEP 562 module ``__getattr__``).

A package ``__init__`` that imports every module pays for all of them (numpy, scipy, numba
kernels) whenever any one is needed, even by ``terrascape --help``. With
:func:`lazy_exports` the package still offers the same names, and ``from terrascape.io import
read_heightmap`` imports ``terrascape.io.heightmap_file`` only then.

References
----------
.. [1] I. Levkivskyi, "PEP 562 – Module __getattr__ and __dir__", 2017.
   https://peps.python.org/pep-0562/
"""

from __future__ import annotations

import importlib
import types
from collections.abc import Callable


def lazy_exports(package: str, exports: dict[str, tuple[str, ...]]
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package`` offering ``exports``: module name
    (relative to the package) → the names it provides."""
    where = {name: f"{package}.{module}" for module, names in exports.items() for name in names}
    face = importlib.import_module(package)
    namespace = face.__dict__
    # A name that is also its module's name (generate.hills is the function hills in the
    # module hills): once the module is imported, the import system sets the package's
    # attribute to the module. The face keeps offering the function, as an eager
    # ``from .hills import hills`` would have.
    shadowed = {name for name, module in where.items() if module == f"{package}.{name}"}
    if shadowed:
        face.__class__ = type("LazyPackage", (type(face),), {
            "__setattr__": _keep_exports(shadowed), "__module__": __name__})

    def __getattr__(name: str) -> object:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value  # found by the next lookup without this function
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *where})

    return __getattr__, __dir__


def _keep_exports(names: set[str]) -> Callable[[types.ModuleType, str, object], None]:
    def __setattr__(self: types.ModuleType, name: str, value: object) -> None:
        if (name in names and isinstance(value, types.ModuleType)
                and value.__name__ == f"{self.__name__}.{name}"):
            value = getattr(value, name)
        types.ModuleType.__setattr__(self, name, value)

    return __setattr__
