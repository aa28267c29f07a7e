"""The static meshers (one mesh for the whole map, for an error bound or a triangle budget)
behind one interface, and the table that lists them.

A static mesher is a function ``mesh(heightmap, *, max_error=None, max_triangles=None,
**options)`` returning ``uint32 (M, 3)`` grid vertex indices (``row·cols + col``),
counter-clockwise seen from above, that covers the whole map and keeps every sample within
``max_error`` when it is given. :data:`STATIC_MESHERS` lists them with the extra keywords
each takes; ``terrascape mesh --mesher`` (its choices, its help and the checks of its
options) and ``docs/architecture.md`` read it. This module imports no numba code: a mesher's
module is imported when it meshes (the CLI's ``--help`` stays fast).

Adding a mesher: its function in ``lod/`` (or wherever it lives), one
:class:`StaticMesher` entry below, its line in ``docs/architecture.md``; the parametrised
tests in ``tests/lod/test_static_meshers.py`` then check its bound and budget.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from terrascape.errors import InvalidParameterError

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy as np

    from terrascape.heightmap import Heightmap


@dataclass(frozen=True)
class StaticMesher:
    """One row of :data:`STATIC_MESHERS`.

    ``target`` is ``"module:function"`` (imported by :meth:`load`); ``options`` the
    keywords the function takes besides ``max_error`` and ``max_triangles``, each with its
    help; ``label`` the name in tables and timings; ``warm_up`` the ``terrascape warm-up``
    task that compiles it ahead of its first run.
    """

    name: str
    target: str
    label: str
    help: str
    options: dict[str, str]
    warm_up: str

    @property
    def first_run_note(self) -> str:
        """What a command says while this mesher is still at work after a few seconds: a big
        map, or a first run that compiles it (which one, the command cannot tell)."""
        return ("a big map takes a while, and a first run on a new installation also compiles "
                f"the mesher, once (`terrascape warm-up --only {self.warm_up}` does it ahead)")

    def load(self) -> Callable[..., np.ndarray]:
        module, _, function = self.target.partition(":")
        return getattr(importlib.import_module(module), function)

    def mesh(self, heightmap: Heightmap, *, max_error: float | None = None,
             max_triangles: int | None = None, **options: Any) -> np.ndarray:
        """The mesher's triangles for ``heightmap``; an option it does not take raises
        :class:`~terrascape.errors.InvalidParameterError`."""
        for key in options:
            if key not in self.options:
                raise InvalidParameterError(
                    f"the {self.name} mesher does not take {key}"
                    + (f" (it takes {', '.join(self.options)})" if self.options else ""))
        return self.load()(heightmap, max_error=max_error, max_triangles=max_triangles,
                           **options)


STATIC_MESHERS: dict[str, StaticMesher] = {
    m.name: m
    for m in (
        StaticMesher(
            "rtin", "terrascape.export.meshing:rtin_rectangle", "RTIN",
            "right triangles of a bintree: crack-free tiles, fast; any map size, padded "
            "internally",
            {},
            "lod",
        ),
        StaticMesher(
            "greedy", "terrascape.lod.greedy_tin:greedy_tin", "greedy TIN",
            "Delaunay greedy insertion after Garland & Heckbert: fewer triangles for the "
            "same error, any map size; its first run compiles for a while, or ahead with "
            "`terrascape warm-up --only greedy`",
            {"in_pieces": "False: one greedy order over the whole map instead of pieces "
                          "meshed in parallel"},
            "greedy",
        ),
    )
}


#: The mesher used when none is named (the first entry: fast, crack-free tiles).
DEFAULT_STATIC_MESHER = next(iter(STATIC_MESHERS))


def static_mesher(name: str | None) -> StaticMesher:
    """The :data:`STATIC_MESHERS` entry ``name`` (``None``: :data:`DEFAULT_STATIC_MESHER`);
    a one-line error naming the choices otherwise."""
    if name is None:
        name = DEFAULT_STATIC_MESHER
    try:
        return STATIC_MESHERS[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"unknown static mesher {name!r}: choose one of {', '.join(STATIC_MESHERS)}"
        ) from None


__all__ = ["DEFAULT_STATIC_MESHER", "STATIC_MESHERS", "StaticMesher", "static_mesher"]
