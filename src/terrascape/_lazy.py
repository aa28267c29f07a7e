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


class _LazyPackage(types.ModuleType):
    """A package whose exported names win over its submodules of the same name.

    Importing ``pkg.name`` makes the import system set the attribute ``pkg.name`` to the
    submodule; when the package exports a function called ``name`` (``generate.fbm`` from
    ``generate/noise.py``, ``generate.diamond_square`` from ``generate/diamond_square.py``),
    ``from pkg import name`` would then return the module instead of the function, depending on
    what happened to be imported first. The eager package this replaces bound the function
    after its submodule, so that is what the attribute keeps here.
    """

    def __setattr__(self, name: str, value: object) -> None:
        exported = self.__dict__.get("_lazy_where", {})
        if (name in exported and isinstance(value, types.ModuleType)
                and value.__name__ == f"{self.__name__}.{name}"):
            if exported[name] == value.__name__:
                value = getattr(value, name)
            else:  # the name comes from another module: resolve it on first use
                self.__dict__.pop(name, None)
                return
        super().__setattr__(name, value)


def lazy_exports(package: str, exports: dict[str, tuple[str, ...]]
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package`` offering ``exports``: module name
    (relative to the package) → the names it provides."""
    where = {name: f"{package}.{module}" for module, names in exports.items() for name in names}
    module_object = importlib.import_module(package)
    namespace = module_object.__dict__
    namespace["_lazy_where"] = where
    module_object.__class__ = _LazyPackage

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
